"""The fast trainer started from a trained model (``agents.fast.init_from``, ``--init-from``): a model
written by ``agents.imitation`` becomes the run's first policy; a model of another network is
refused with every mismatch named."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import torch
import yaml

import ios_uav_env  # noqa: F401
from agents.fast import FastPPO
from agents.imitation import ImitationSettings, _new_model, model_config, save_model_folder
from tests.agents.test_fast import entry, recipe

pytestmark = pytest.mark.usefixtures("one_torch_thread")

RANDOM = "ios_uav_env/IOSUAV-MultiNode-Random-v0"
HINTED = {"softmin_beta": 20, "peak_hint": True}  # agents.imitation's default env arguments
NORMALIZE = "{'norm_obs': True, 'norm_reward': True}"
EXPERT = "ios_uav_env.envs.policies:HoverAt('ground')"
ARCH = "dict(net_arch=dict(pi=[24, 24], vf=[24, 24]), log_std_init=-1.0)"


def _observations(env_kwargs: dict, n: int, seed: int) -> np.ndarray:
    env = gym.make(RANDOM, **env_kwargs)
    rng = np.random.default_rng(seed)
    obs = [env.reset(seed=seed)[0]]
    while len(obs) < n:
        o, _, term, trunc, _ = env.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
        obs.append(env.reset()[0] if term or trunc else o)
    return np.stack(obs)


@pytest.fixture(scope="module")
def imitation_model(tmp_path_factory) -> Path:
    """A model folder as ``agents.imitation`` writes it (its own ``_new_model`` and
    ``save_model_folder``): an MLP of [24, 24] on the hinted random multi-node id, observation
    statistics of real observations, and weights moved away from their initialisation (a fit would
    do that; here a seeded perturbation)."""
    folder = tmp_path_factory.mktemp("imitation")
    settings = ImitationSettings(out=str(folder), net_arch=(24, 24), env_kwargs=dict(HINTED), seed=5)
    env = gym.make(RANDOM, **HINTED).unwrapped
    model, venv = _new_model(settings, env, _observations(HINTED, 200, 0))
    generator = torch.Generator().manual_seed(1)
    with torch.no_grad():
        for p in model.policy.parameters():
            p.add_(0.3 * torch.randn(p.shape, generator=generator))
    save_model_folder(folder, model, venv, model_config(settings))
    return folder


def test_the_fast_trainers_first_policy_is_the_imitation_model(imitation_model):
    """On observations of the env, the run's deterministic action (its Gaussian's mean on its own
    normalised observation, clipped) equals the imitation model's (``load_agent``'s ``act``) to
    1e-6: the same float32 weights and statistics, torch's float32 products in another order at
    most (a few ulps of O(1) actions). A new model of the same recipe is far from it."""
    from agents.loading import load_agent

    r = recipe(n_envs=8, batch_size=64, normalize=NORMALIZE, policy_kwargs=ARCH)
    source = load_agent(imitation_model)
    obs = _observations(HINTED, 64, 3)
    want = source.act(obs)

    def actions(algo: FastPPO) -> np.ndarray:
        x = torch.from_numpy(np.asarray(algo._normalized_obs(obs), dtype=np.float32))
        with torch.no_grad():
            mean = algo._forward(x)[0].numpy()
        return np.clip(mean, algo._low, algo._high)

    started = FastPPO(
        RANDOM, r, total=r.rollout_size, env_kwargs=HINTED, seed=9, init_from=str(imitation_model)
    )
    fresh = FastPPO(RANDOM, r, total=r.rollout_size, env_kwargs=HINTED, seed=9)
    try:
        np.testing.assert_allclose(actions(started), want, atol=1e-6)
        assert np.abs(actions(fresh) - want).max() > 0.1
        np.testing.assert_array_equal(started.vecnormalize.obs_rms.mean, source.vecnormalize.obs_rms.mean)
        assert started.init_model.path == imitation_model / "model.zip"
        started.collect()  # and it trains on from there
        started.update()
        assert started.steps == r.rollout_size
    finally:
        started.close()
        fresh.close()


@pytest.mark.parametrize(
    ("overrides", "env_kwargs", "messages"),
    [
        ({"policy_kwargs": "dict(net_arch=dict(pi=[32], vf=[24, 24]))"}, HINTED,
         ["actor layer sizes: the model's [24, 24], the run's [32]"]),
        ({"policy_kwargs": "dict(net_arch=dict(pi=[24, 24], vf=[24, 24]), activation_fn=nn.ReLU)"}, HINTED,
         ["activation: the model's ['Tanh'], the run's ['ReLU']"]),
        ({}, {"softmin_beta": 20}, ["observation size: the model's (", "the run's ("]),
        ({"normalize": None}, HINTED, ["the model has observation statistics", "does not normalise"]),
        ({"callback": [{"agents.callbacks.CloneStart": {"expert": EXPERT}}]}, HINTED,
         ["warm-starts by cloning", "one warm start"]),
    ],
)  # fmt: skip
def test_a_model_of_another_network_is_refused_naming_the_mismatch(
    imitation_model, overrides, env_kwargs, messages
):
    r = recipe(**{"n_envs": 8, "batch_size": 64, "normalize": NORMALIZE, "policy_kwargs": ARCH, **overrides})
    with pytest.raises(ValueError, match="init_from") as error:
        FastPPO(
            RANDOM, r, total=r.rollout_size, env_kwargs=env_kwargs, init_from=str(imitation_model)
        ).close()
    for message in messages:
        assert message in str(error.value)


def test_a_bare_zip_without_statistics_and_a_missing_model(imitation_model, tmp_path):
    """A ``.zip`` alone (no statistics beside it) fits a recipe that does not normalise; a path
    without a model is named."""
    bare = tmp_path / "bare.zip"
    bare.write_bytes((imitation_model / "model.zip").read_bytes())
    r = recipe(n_envs=8, batch_size=64, policy_kwargs=ARCH)
    algo = FastPPO(RANDOM, r, total=r.rollout_size, env_kwargs=HINTED, init_from=str(bare))
    try:
        assert algo.init_model.vecnormalize is None
    finally:
        algo.close()
    with pytest.raises(ValueError, match="init_from: no model at .*nothing"):
        FastPPO(
            RANDOM, r, total=r.rollout_size, env_kwargs=HINTED, init_from=str(tmp_path / "nothing")
        ).close()


def test_train_py_starts_from_the_model_and_refuses_a_mismatch(imitation_model, tmp_path, capsys):
    from train import main

    path = tmp_path / "fast.yml"
    e = entry(n_envs=8, batch_size=64, normalize=NORMALIZE, policy_kwargs=ARCH, env_kwargs=HINTED)
    path.write_text(yaml.safe_dump({RANDOM: e}))
    base = ["--algo", "ppo", "--env", RANDOM, "--hyperparams", str(path), "--no-progress", "--eval-freq", "0"]
    with pytest.raises(SystemExit) as exit_:
        main([*base, "--init-from", str(imitation_model), "--out", str(tmp_path / "sb3")])
    assert exit_.value.code == 2 and "--init-from: only the fast trainer takes it" in capsys.readouterr().err
    wrong = tmp_path / "wrong.yml"
    wrong.write_text(yaml.safe_dump({RANDOM: {**e, "policy_kwargs": "dict(net_arch=[8])"}}))
    with pytest.raises(SystemExit) as exit_:
        main(
            [*base[:4], "--hyperparams", str(wrong), "--trainer", "fast", "--init-from", str(imitation_model)]
        )
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and "argument --init-from" in err and "layer sizes" in err
    run = tmp_path / "run"
    argv = [
        *base,
        "--trainer",
        "fast",
        "--timesteps",
        "512",
        "--init-from",
        str(imitation_model),
        "--out",
        str(run),
    ]
    assert main(argv) == 0
    config = json.loads((run / "config.json").read_text())
    assert config["args"]["init_from"] == str(imitation_model)
