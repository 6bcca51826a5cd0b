"""train.py --vec-env batched: a run on agents.vec_env.BatchedVecEnv (monitor, config, resume) and
its argument checks."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("yaml")

from agents.training import TrainSettings, check_hyperparams, resume, train  # noqa: E402
from train import parse_args  # noqa: E402

TINY = """
ios_uav_env/IOSUAV-v0:
  n_envs: 4
  n_timesteps: 256
  policy: 'MlpPolicy'
  normalize: "{'norm_obs': False, 'norm_reward': True}"
  n_steps: 32
  batch_size: 64
  n_epochs: 1
  gamma: 0.999
  learning_rate: lin_3e-4
  policy_kwargs: "dict(net_arch=[16, 16])"
  env_wrapper:
    - agents.wrappers.ShiftReward:
        offset: 0.5
"""


def _monitor_rows(run_dir: Path) -> list[str]:
    lines = (run_dir / "monitor" / "batched.monitor.csv").read_text().splitlines()
    assert lines[0].startswith("#") and lines[1] == "r,l,t"
    assert sum(line.startswith("#") for line in lines) == 1  # one header, also after a resume
    return lines[2:]


def test_batched_run_and_resume(tmp_path: Path) -> None:
    (tmp_path / "hp.yml").write_text(TINY)
    out = tmp_path / "run"
    settings = TrainSettings(
        algo="ppo", vec_env="batched", env_kwargs={"T": 40}, hyperparams_file=str(tmp_path / "hp.yml"),
        out=str(out), checkpoint_freq=128, eval_freq=0, progress_bar=False,
    )  # fmt: skip
    result = train(settings)
    assert result.summary["steps"] == 256
    assert result.summary["final_eval"]["feasible"]
    config = json.loads((out / "config.json").read_text())
    assert config["vec_env"] == "batched" and config["args"]["vec_env"] == "batched"
    first = _monitor_rows(out)
    assert first  # 4 staggered rows of 39-step episodes: episodes ended within 256 steps
    assert {int(row.split(",")[1]) for row in first} >= {39}
    again = resume(out, timesteps=512, progress_bar=False)
    assert again.summary["steps"] == 512
    assert len(_monitor_rows(out)) > len(first)  # appended to


def test_vec_env_argument(tmp_path: Path) -> None:
    (tmp_path / "hp.yml").write_text(TINY)
    _, settings = parse_args(
        ["--algo", "ppo", "--vec-env", "batched", "--hyperparams", str(tmp_path / "hp.yml")]
    )
    assert settings.vec_env == "batched"
    _, settings = parse_args(["--algo", "ppo", "--hyperparams", str(tmp_path / "hp.yml")])
    assert settings.vec_env == "dummy"
    with pytest.raises(SystemExit):
        parse_args(["--algo", "ppo", "--vec-env", "subproc"])


def test_batched_refuses_a_wrapper_without_a_vec_form(tmp_path: Path) -> None:
    path = tmp_path / "hp.yml"
    wrapper = "gymnasium.wrappers.RecordEpisodeStatistics: {}"
    path.write_text(TINY.replace("agents.wrappers.ShiftReward:\n        offset: 0.5", wrapper))
    check_hyperparams("ppo", "ios_uav_env/IOSUAV-v0", path)  # fine with the DummyVecEnv
    with pytest.raises(ValueError, match="cannot wrap the batched env"):
        check_hyperparams("ppo", "ios_uav_env/IOSUAV-v0", path, vec_env="batched")


def _multinode_run(tmp_path: Path, hyperparams: str) -> tuple[Any, Path]:
    """A tiny batched run of ``hyperparams`` (TINY's text) on the multi-node id, T = 40 s."""
    text = hyperparams.replace("ios_uav_env/IOSUAV-v0", "ios_uav_env/IOSUAV-MultiNode-v0")
    (tmp_path / "hp.yml").write_text(text)
    out = tmp_path / "run"
    settings = TrainSettings(
        algo="ppo", env_id="ios_uav_env/IOSUAV-MultiNode-v0", vec_env="batched", env_kwargs={"T": 40},
        hyperparams_file=str(tmp_path / "hp.yml"), out=str(out), checkpoint_freq=1024, eval_freq=0,
        progress_bar=False,
    )  # fmt: skip
    return train(settings), out


def test_batched_run_on_the_multinode_id(tmp_path: Path) -> None:
    result, out = _multinode_run(tmp_path, TINY)
    assert result.summary["steps"] == 256 and result.summary["final_eval"]["feasible"]
    assert {int(row.split(",")[1]) for row in _monitor_rows(out)} >= {39}  # whole 39-step episodes


def test_action_repeat_run_and_its_agent_hold_the_action(tmp_path: Path) -> None:
    """ActionRepeat (with ExploringStarts) in the hyperparameters: the batched run decides every 3
    slots (13 decisions per 39-slot episode in the monitor), and the loaded agent holds its
    actions alike (Agent.repeat)."""
    from agents.loading import load_agent
    from ios_uav_env.envs.rollout import run_episode

    wrappers = "ActionRepeat:\n        repeat: 3\n    - agents.wrappers.ExploringStarts:\n        prob: 0.5"
    result, out = _multinode_run(tmp_path, TINY.replace("ShiftReward:\n        offset: 0.5", wrappers))
    lengths = {int(row.split(",")[1]) for row in _monitor_rows(out)}
    assert 13 in lengths and min(lengths) < 13  # ceil(39 / 3) decisions; shorter after a prefix
    agent = load_agent(out)
    assert agent.repeat == 3
    import gymnasium as gym

    env = gym.make("ios_uav_env/IOSUAV-MultiNode-v0", T=40)
    episode = run_episode(env, agent, seed=0)
    shares = env.unwrapped.shares[:, 1:]
    np.testing.assert_array_equal(shares[:, 0:3], np.repeat(shares[:, 0:1], 3, axis=1))
    assert result.summary["final_eval"]["average_rate"] == pytest.approx(episode.average_rate, rel=1e-12)
    # the numpy export of the suite and the benchmark's episode loop hold the action too
    from types import SimpleNamespace

    from agents.evaluate_multi import fast_act
    from ios_uav_env.benchmark.scoring import play

    play(env, fast_act(agent), SimpleNamespace(config=env.unwrapped.config, index=0), seed=0)
    np.testing.assert_allclose(env.unwrapped.trajectory, episode.trajectory, atol=1e-5)  # float32 export
    held = env.unwrapped.shares[:, 1:]
    np.testing.assert_array_equal(held[:, 3:6], np.repeat(held[:, 3:4], 3, axis=1))
