"""agents.star_learner: the learned residual over ChannelPhases, its weights file and its trainer."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

from agents.star_learner import (
    ELEMENT_IN,
    ELEMENT_OUT,
    GLOBAL_FEATURES,
    StarLearner,
    features,
    load_weights,
    residuals,
)
from ios_uav_env.benchmark.star_policies import ChannelPhases
from ios_uav_env.benchmark.star_suite import StarTask

KEYWORDS = dict(group=1, direct_link=False)


def _task(side: int, bits: int | None, access: str, protocol: str = "es", **env_kwargs) -> tuple:
    env = gym.make("ios_uav_env/STARControl-v0", elements=(side, side), bits=bits, access=access,
                   protocol=protocol, optimum=False, **env_kwargs)  # fmt: skip
    star = dict(elements=[side, side], bits=bits, protocol=protocol, access=access, **KEYWORDS)
    return env, StarTask.of(star, env)


def _write(folder, rng: np.random.Generator | None = None, width: int = 8) -> None:
    """A model folder: zero last layers (rng None) or random weights."""
    arrays = {}
    for net, n_in, n_out in (("element", ELEMENT_IN, ELEMENT_OUT), ("split", GLOBAL_FEATURES, 1)):
        for j, (a, b) in enumerate(((n_in, width), (width, n_out))):
            zero = rng is None and j == 1
            arrays[f"{net}_w{j}"] = (
                np.zeros((a, b)) if zero else (rng or np.random.default_rng(0)).normal(size=(a, b))
            )
            arrays[f"{net}_b{j}"] = np.zeros(b)
    folder.mkdir(parents=True, exist_ok=True)
    np.savez(folder / "weights.npz", **arrays)
    (folder / "config.json").write_text(json.dumps({"trainer": "test"}), encoding="utf-8")


@pytest.mark.parametrize("access, protocol", [("tdma", "es"), ("noma", "es"), ("noma", "ms")])
def test_a_zero_residual_is_channel_phases(tmp_path, access, protocol):
    _write(tmp_path / "zero")
    env, task = _task(4, 1, access, protocol)
    learner, heuristic = StarLearner(tmp_path / "zero").bind(task), ChannelPhases().bind(task)
    obs, _ = env.reset(seed=3)
    for _ in range(4):
        action = learner(obs)
        assert action.shape == env.action_space.shape
        np.testing.assert_allclose(action, heuristic(obs), rtol=0, atol=1e-12)
        obs = env.step(action)[0]


def test_the_residual_moves_the_action_and_its_phases_wrap(tmp_path):
    _write(tmp_path / "random", np.random.default_rng(1))
    env, task = _task(8, None, "noma", "es")
    learner = StarLearner(tmp_path / "random").bind(task)
    obs, _ = env.reset(seed=0)
    action, base = learner(obs), ChannelPhases().bind(task)(obs)
    assert np.all(action >= -1) and np.all(action[: 2 * task.G] < 1) and np.all(action <= 1)
    assert not np.allclose(action, base)
    group, glob = features(obs[None], task)
    assert group.shape == (1, task.G, 4) and glob.shape == (1, GLOBAL_FEATURES)
    g_out, s_out = residuals(learner.weights, group, glob)
    assert g_out.shape == (1, task.G, ELEMENT_OUT) and s_out.shape == (1,)


def test_continuous_phases_have_no_rounding_error_and_bits_do():
    env, task = _task(4, None, "tdma")
    obs, _ = env.reset(seed=0)
    group, _ = features(obs[None], task)
    np.testing.assert_allclose(group[..., [0, 2]], 1.0, atol=1e-12)  # cos of a zero error
    env, task = _task(4, 1, "tdma")
    group, glob = features(env.reset(seed=0)[0][None], task)
    assert np.all(group[..., [0, 2]] >= np.cos(np.pi / 2) - 1e-12) and np.any(group[..., 0] < 0.99)
    assert glob[0, 8:13].tolist() == [1.0, 0.0, 0.0, 0.5, 0.5]  # TDMA, 2^-1, log2(16) / 8


def test_bad_weights_and_layouts_are_refused_by_name(tmp_path):
    with pytest.raises(ValueError, match="weights.npz: no such file"):
        StarLearner(tmp_path / "none")
    _write(tmp_path / "bare")
    (tmp_path / "bare" / "config.json").unlink()
    with pytest.raises(ValueError, match="config.json: no such file"):
        StarLearner(tmp_path / "bare")
    _write(tmp_path / "bad")
    with np.load(tmp_path / "bad" / "weights.npz") as data:
        arrays = dict(data)
    arrays["split_w0"] = np.zeros((GLOBAL_FEATURES + 1, 8))
    np.savez(tmp_path / "bad" / "weights.npz", **arrays)
    with pytest.raises(ValueError, match=r"weights.npz: split_w0.. must be layers from 21 to 1"):
        load_weights(tmp_path / "bad")
    _write(tmp_path / "zero")
    _, task = _task(4, None, "tdma", channel_phases=False)
    with pytest.raises(ValueError, match="channel_phases=True"):
        StarLearner(tmp_path / "zero").bind(task)
    with pytest.raises(ValueError, match="unbound"):
        StarLearner(tmp_path / "zero")(np.zeros(40))


def test_the_trainer_writes_a_model_the_learner_plays_and_keeps_it(tmp_path, capsys, one_torch_thread):
    """Two iterations on one episode a setting (every stage runs and is recorded): the torch
    networks' export is what the numpy learner computes (random weights, every setting's
    features), and a model is not replaced without --overwrite."""
    import torch

    from agents import star_training

    out = tmp_path / "model"
    argv = ["--out", str(out), "--iterations", "2", "--episodes", "1", "--batch", "4", "--imitate", "20"]
    assert star_training.main(argv) == out
    config = json.loads((out / "config.json").read_text())
    assert config["command"].startswith("python -m agents.star_training --out") and config["settings"] == 27
    printed = capsys.readouterr().out
    for stage in ("split imitated", "group outputs learned", "split imitated again"):
        assert f"{stage}: " in printed and stage in config["pct_of_zero_residual"]
    with pytest.raises(SystemExit):
        star_training.main(argv)
    assert "--overwrite" in capsys.readouterr().err
    nets = star_training._networks(8)
    torch.manual_seed(0)
    for p in nets.parameters():
        torch.nn.init.normal_(p)
    np.savez(out / "weights.npz", **star_training.export(nets))
    weights = load_weights(out)
    pool = star_training.make_pool(13, 1, set())  # M = 64, 1-bit, ES-NOMA
    mine = residuals(weights, pool.group, pool.glob)
    theirs = star_training._forward(nets, torch.from_numpy(pool.group), torch.from_numpy(pool.glob))
    for a, b in zip(mine, theirs, strict=True):
        np.testing.assert_allclose(a, b.detach().numpy(), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("argv, message", [
    (["--imitate", "0"], "--imitate must be >= 1"),
    (["--iterations", "-1"], "--iterations must be >= 0"),
    (["--batch", "17", "--episodes", "1"], "--batch must be <= --episodes x 16"),
])  # fmt: skip
def test_the_trainer_refuses_bad_arguments(tmp_path, capsys, argv, message):
    from agents import star_training

    with pytest.raises(SystemExit):
        star_training.main(["--out", str(tmp_path), *argv])
    assert message in capsys.readouterr().err
