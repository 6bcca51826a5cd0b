"""What training logs and prints as an episode's score: the value of the id's objective (the
average rate, the max-min rate of several nodes, the energy efficiency), named, with its unit,
on the fast trainer's log and on the SB3 path's evaluations. Tiny budgets."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

from ios_uav_env import ENERGY_ID
from tests.agents.test_fast import ENV, MULTI, entry

pytestmark = pytest.mark.usefixtures("one_torch_thread")

#: id -> (the score's name, its unit)
LABELS = {ENV: ("average_rate", "bps/Hz"), ENERGY_ID: ("energy_efficiency", "bits/J"),
          MULTI: ("min_rate", "bps/Hz")}  # fmt: skip


@pytest.mark.parametrize("env_id", [ENV, ENERGY_ID])
def test_the_fast_trainer_logs_and_prints_the_objective_of_its_id(env_id, tmp_path, capsys):
    # before: the energy id's log and print gave its average rate (0.69 bps/Hz) as the episode
    # score, not its energy efficiency (thousands of bits/J), with neither name nor unit
    import yaml

    import train
    from ios_uav_env.envs.rollout import run_episode

    hp = tmp_path / "fast.yml"
    hp.write_text(yaml.safe_dump({env_id: entry(normalize="{'norm_obs': False, 'norm_reward': True}")}))
    run = tmp_path / "run"
    argv = ["--algo", "ppo", "--trainer", "fast", "--env", env_id, "--hyperparams", str(hp),
            "--out", str(run), "--timesteps", "768", "--env-kwargs", "T:40", "--eval-freq", "0",
            "--no-progress", "--threads", "1"]  # fmt: skip
    assert train.main(argv) == 0
    name, unit = LABELS[env_id]
    rows = [json.loads(line) for line in (run / "progress.csv").read_text().splitlines()]
    scores = [row["episode_score"] for row in rows if np.isfinite(row["episode_score"])]
    assert scores and all(row["score_name"] == name and row["score_unit"] == unit for row in rows)
    # a rate is a few bps/Hz; an efficiency thousands of bits/J
    assert all(100.0 < s for s in scores) if unit == "bits/J" else all(0.0 < s < 10.0 for s in scores)
    final = json.loads((run / "summary.json").read_text())["final_eval"]
    from agents.loading import load_agent

    agent = load_agent(run)
    episode = run_episode(gym.make(env_id, T=40), agent.act, seed=0)
    assert final["score_name"] == name and final["score_unit"] == unit
    assert final["score"] == pytest.approx(episode.score, rel=1e-9)
    assert final["average_rate"] == pytest.approx(episode.average_rate, rel=1e-9)
    out = capsys.readouterr().out
    value = f"{final['score']:{'.6f' if unit == 'bps/Hz' else '.6g'}}"
    assert f"deterministic episode: {name.replace('_', ' ')} {value} {unit}" in out


@pytest.mark.parametrize("env_id", [ENV, ENERGY_ID, MULTI])
def test_the_sb3_evaluation_logs_the_objective_of_its_id(env_id):
    # before: eval/average_rate only, whatever the objective
    from stable_baselines3 import PPO
    from stable_baselines3.common.logger import configure

    from agents.callbacks import Clock, RateEvalCallback
    from ios_uav_env.envs.rollout import run_episode

    env = gym.make(env_id, T=40)
    model = PPO("MlpPolicy", env, n_steps=64, batch_size=64, device="cpu", seed=0)
    model.set_logger(configure(None, []))
    callback = RateEvalCallback(64, env_id, {"T": 40}, Clock(), [])
    callback.init_callback(model)
    record = callback.evaluate()
    name, unit = LABELS[env_id]
    episode = run_episode(gym.make(env_id, T=40), lambda o: model.predict(o, deterministic=True)[0], seed=0)
    assert (record["score_name"], record["score_unit"]) == (name, unit)
    assert record["score"] == pytest.approx(episode.score, rel=1e-9)
    logged = model.logger.name_to_value
    assert logged[f"eval/{name}"] == pytest.approx(episode.score, rel=1e-9)
    assert logged["eval/average_rate"] == pytest.approx(episode.average_rate, rel=1e-9)
