"""The fast trainer's warm start: behaviour cloning of a policy on the observation (``agents.fast.clone``)."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
import torch

from agents.fast import FastPPO
from agents.fast.clone import CloneSettings, clone
from tests.agents.test_fast import ENV, recipe

pytestmark = pytest.mark.usefixtures("one_torch_thread")

EXPERT = "ios_uav_env.envs.policies:HoverAt('ground')"
CLONE = {"agents.callbacks.CloneStart": {"expert": EXPERT, "rounds": 2, "slots": 32, "epochs": 6,
                                         "batch_size": 256, "learning_rate": 3e-3}}  # fmt: skip


def _gap(algo: FastPPO, expert, seed: int) -> float:
    """Mean squared gap between the policy's mean and the expert on fresh states of the env."""
    algo.reset(seed=seed)
    obs, gaps = algo._obs, []
    for _ in range(24):
        label = np.clip(expert(obs), -1.0, 1.0)
        x = torch.from_numpy(np.asarray(algo._normalized_obs(obs), dtype=np.float32))
        with torch.no_grad():
            mean = algo._forward(x)[0].numpy()
        gaps.append(np.mean((np.clip(mean, -1.0, 1.0) - label) ** 2))
        obs = algo.vec.step(np.clip(mean, -1.0, 1.0).astype(np.float64))[0]
    return float(np.mean(gaps))


def test_the_recipe_reads_the_clone_and_sb3_refuses_it():
    r = recipe(callback=[CLONE])
    assert r.clone == CloneSettings(EXPERT, rounds=2, slots=32, epochs=6, learning_rate=3e-3, batch_size=256)
    from agents.callbacks import CloneStart

    with pytest.raises(ValueError, match="fast trainer only"):
        CloneStart(EXPERT)._on_training_start()


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("expert", "HoverAt", "PKG.MODULE:ATTR"),
        ("rounds", 0, "rounds must be an integer >= 1"),
        ("slots", 2.5, "slots must be an integer >= 1"),
        ("learning_rate", 0.0, "learning_rate must be > 0"),
        ("noise", float("nan"), "noise must be a finite number"),
        ("noise", -0.1, "noise must be >= 0"),
    ],
)
def test_bad_clone_settings_name_the_field(field, value, message):
    with pytest.raises(ValueError, match=message):
        CloneSettings(**{"expert": EXPERT, field: value})


def test_an_expert_that_does_not_load_is_named():
    r = recipe(callback=[{"agents.callbacks.CloneStart": {"expert": "ios_uav_env.envs.policies:Nobody"}}])
    algo = FastPPO(ENV, r, total=r.rollout_size, env_kwargs={"T": 40})
    try:
        with pytest.raises(ValueError, match="Nobody"):
            clone(algo, r.clone)
    finally:
        algo.close()


def test_the_clone_follows_the_expert_where_the_untrained_policy_does_not():
    """After two rounds (expert, then DAgger) the policy's mean is near the expert's action on
    states it was not fitted on; the untrained network is far from it; the value was fitted."""
    from ios_uav_env.benchmark.cli import load_policy

    torch.manual_seed(0)
    r = recipe(n_envs=64, batch_size=256, normalize="{'norm_obs': True, 'norm_reward': True}",
               policy_kwargs="dict(net_arch=dict(pi=[32, 32], vf=[32, 32]), log_std_init=-2.0)",
               callback=[CLONE])  # fmt: skip
    algo = FastPPO(ENV, r, total=r.rollout_size, env_kwargs={"T": 40})
    expert = load_policy(EXPERT)
    try:
        before = _gap(algo, expert, seed=500)
        record = clone(algo, r.clone)
        assert algo._obs is None  # PPO's first rollout starts new episodes
        after = _gap(algo, expert, seed=500)
        algo.collect()  # and PPO runs on from the clone
        algo.update()
    finally:
        algo.close()
    assert before > 0.2 and after < 0.25 * before, (before, after)
    rounds = record["rounds"]
    assert [r_["samples"] for r_ in rounds] == [32 * 64, 2 * 32 * 64] and record["env_steps"] == 2 * 32 * 64
    assert rounds[-1]["value_loss"] < rounds[0]["value_loss"]
    json.dumps(record)  # (written as clone.json)


def three_actions(obs: np.ndarray) -> np.ndarray:
    """An expert of the wrong action size."""
    return np.zeros((len(obs), 3))


def nan_actions(obs: np.ndarray) -> np.ndarray:
    """An expert that returns NaN."""
    return np.full((len(obs), 2), np.nan)


@pytest.mark.parametrize(
    ("expert", "message"),
    [
        ("tests.agents.test_fast_clone:three_actions", r"actions of shape \(2, 3\).* need shape \(2, 2\)"),
        ("ios_uav_env.envs.nowhere:HoverAt('ground')", "cannot import 'ios_uav_env.envs.nowhere'"),
        ("tests.agents.test_fast_clone:nan_actions", "returns non-finite actions"),
        ("ios_uav_env.envs.policies:HoverAt('peak')", r"dx_peak.*peak_hint=True"),
    ],
)
def test_a_bad_expert_is_refused_with_the_recipe_before_the_run_folder_exists(
    expert, message, tmp_path, capsys
):
    # before: each failed only in the clone, after config.json was written (or, for the peak hint
    # without peak_hint=True, did not fail at all: HoverAt('peak') flew to the last 3 components)
    import yaml

    import train
    from agents.training import TrainSettings
    from agents.training import train as train_run
    from tests.agents.test_fast import entry

    clone_start = {"agents.callbacks.CloneStart": {"expert": expert, "rounds": 1, "slots": 8}}
    hp = tmp_path / "fast.yml"
    hp.write_text(yaml.safe_dump({ENV: entry(callback=[clone_start])}))
    run = tmp_path / "run"
    with pytest.raises(SystemExit) as exc:
        train.main(["--algo", "ppo", "--trainer", "fast", "--hyperparams", str(hp), "--out", str(run),
                    "--env-kwargs", "T:40", "--no-progress"])  # fmt: skip
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "argument --hyperparams" in err and "CloneStart expert" in err
    assert re.search(message, err) and not run.exists()
    settings = TrainSettings(algo="ppo", trainer="fast", env_kwargs={"T": 40}, hyperparams_file=str(hp),
                             out=str(run), progress_bar=False)  # fmt: skip
    with pytest.raises(ValueError, match=message):
        train_run(settings)
    assert not run.exists()
