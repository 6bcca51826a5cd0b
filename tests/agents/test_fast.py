"""The fast trainer (agents.fast): GAE, the recipe's checks, a run's files, resume and learning.

Tiny budgets: 32-64 rows, 8-slot rollouts, short episodes (T = 40 s)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import torch

from agents.fast import FastPPO, FastRecipe, gae
from agents.fast.recipe import Schedule
from agents.hyperparams import check_entry, resolve

ENV = "ios_uav_env/IOSUAV-v0"
MULTI = "ios_uav_env/IOSUAV-MultiNode-v0"


pytestmark = pytest.mark.usefixtures("one_torch_thread")


def entry(**overrides):
    base = {
        "n_envs": 32, "n_timesteps": 2048, "policy": "MlpPolicy", "n_steps": 8, "batch_size": 128,
        "n_epochs": 2, "gamma": 0.99, "learning_rate": "lin_1e-3",
        "policy_kwargs": "dict(net_arch=dict(pi=[16], vf=[16]), log_std_init=-1.0)",
    }  # fmt: skip
    base.update(overrides)
    return {k: v for k, v in base.items() if v is not None}


def recipe(**overrides) -> FastRecipe:
    return FastRecipe.from_hyperparams(resolve(check_entry("ppo", entry(**overrides))))


# --- GAE --------------------------------------------------------------------------------
def test_gae_matches_a_hand_computed_case():
    # one row, 3 slots, the episode ends at slot 1 (index 1): no bootstrap across it
    g, lam = 0.9, 0.5
    r = torch.tensor([[1.0], [2.0], [3.0]])
    v = torch.tensor([[0.5], [1.0], [1.5]])
    d = torch.tensor([[0.0], [1.0], [0.0]])
    last = torch.tensor([2.0])
    adv, ret = gae(r, v, d, last, g, lam)
    a2 = 3.0 + g * 2.0 - 1.5  # slot 2 bootstraps from the last value
    a1 = 2.0 - 1.0  # slot 1 ends its episode: no next value, no carry
    a0 = (1.0 + g * 1.0 - 0.5) + g * lam * a1
    assert torch.allclose(adv[:, 0], torch.tensor([a0, a1, a2]))
    assert torch.allclose(ret, adv + v)


def test_gae_equals_sb3s_rollout_buffer():
    from gymnasium import spaces
    from stable_baselines3.common.buffers import RolloutBuffer

    rng = np.random.default_rng(0)
    t, b, g, lam = 6, 4, 0.97, 0.9
    rewards, values = rng.normal(size=(t, b)), rng.normal(size=(t, b))
    dones = (rng.random((t, b)) < 0.3).astype(np.float32)
    last = rng.normal(size=b)
    buf = RolloutBuffer(
        t, spaces.Box(-1, 1, (1,)), spaces.Box(-1, 1, (1,)), gamma=g, gae_lambda=lam, n_envs=b
    )
    starts = np.vstack([np.zeros((1, b)), dones[:-1]])  # SB3 marks the step after an end
    for i in range(t):
        buf.add(np.zeros((b, 1)), np.zeros((b, 1)), rewards[i], starts[i], torch.tensor(values[i]),
                torch.zeros(b))  # fmt: skip
    buf.compute_returns_and_advantage(torch.tensor(last), dones[-1])
    adv, ret = gae(*(torch.tensor(x, dtype=torch.float64) for x in (rewards, values, dones, last)), g, lam)
    np.testing.assert_allclose(adv.numpy(), buf.advantages, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(ret.numpy(), buf.returns, rtol=1e-5, atol=1e-6)


def test_gae_refuses_mismatched_shapes():
    with pytest.raises(ValueError, match="one shape"):
        gae(torch.zeros(3, 2), torch.zeros(3, 1), torch.zeros(3, 2), torch.zeros(2), 0.9, 0.9)
    with pytest.raises(ValueError, match="last_values"):
        gae(torch.zeros(3, 2), torch.zeros(3, 2), torch.zeros(3, 2), torch.zeros(3), 0.9, 0.9)


# --- the recipe --------------------------------------------------------------------------
def test_recipe_reads_schedules_and_the_callbacks_it_applies():
    r = recipe(callback=[{"agents.callbacks.LogStdSchedule": {"start": -1.0, "end": -3.0}}])
    assert r.learning_rate == Schedule(1e-3, linear=True) and r.learning_rate(0.25) == pytest.approx(2.5e-4)
    assert r.clip_range == Schedule(0.2) and r.log_std == (-1.0, -3.0)
    assert r.rollout_size == 32 * 8


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"use_sde": True}, "'use_sde' is not read by the fast trainer"),
        ({"callback": "agents.callbacks.TargetEntropySchedule"}, "TargetEntropySchedule"),
        ({"env_wrapper": "agents.wrappers.ActionRepeat"}, "ActionRepeat"),
        (
            {"env_wrapper": [{"agents.wrappers.ExploringStarts": {"prob": 1.5}}]},
            r"ExploringStarts prob .* \[0, 1\]",
        ),
        ({"env_wrapper": [{"agents.wrappers.ShiftReward": {"scale": 0}}]}, "ShiftReward scale must be > 0"),
        ({"batch_size": 512}, r"batch_size must be in \[2, n_envs \* n_steps = 256\]"),
        ({"callback": "agents.callbacks.ExploringStartsSchedule"}, "needs 'agents.wrappers.ExploringStarts'"),
        ({"policy": "CnnPolicy"}, "MlpPolicy"),
    ],
)
def test_recipe_refuses_what_it_cannot_honour(overrides, message):
    with pytest.raises(ValueError, match=message):
        recipe(**overrides)


# --- the algorithm ------------------------------------------------------------------------
def test_collect_and_update_fill_the_rollout_and_follow_the_schedules():
    torch.manual_seed(0)
    r = recipe(callback=[{"agents.callbacks.LogStdSchedule": {"start": -1.0, "end": -3.0}}],
               normalize="{'norm_obs': True, 'norm_reward': True}")  # fmt: skip
    algo = FastPPO(ENV, r, total=4 * r.rollout_size, env_kwargs={"T": 40})
    try:
        assert algo.collect()
        buf = algo._buf
        assert torch.all(buf["values"] != 0) and torch.all(torch.isfinite(buf["rewards"]))
        # normalised observations: the statistics saw the reset and every slot
        assert algo.vecnormalize.obs_rms.count > r.n_steps * r.n_envs
        first = algo.update()
        assert first["learning_rate"] == pytest.approx(1e-3)  # progress 0: the initial value
        assert algo.steps == r.rollout_size and algo.model.num_timesteps == algo.steps
        algo.collect()
        assert float(algo.policy.log_std[0]) == pytest.approx(-1.0 - 0.25 * 2.0)
        assert algo.update()["learning_rate"] == pytest.approx(1e-3 * 0.75)
        assert not algo.policy.log_std.requires_grad  # scheduled, not learned
    finally:
        algo.close()


def test_a_stop_drops_the_unfinished_rollout():
    r = recipe()
    algo = FastPPO(ENV, r, total=r.rollout_size, env_kwargs={"T": 40})
    calls = iter(range(100))
    try:
        assert not algo.collect(stop=lambda: next(calls) >= 3)
        assert algo.cut_steps == 3 * r.n_envs and algo.steps == 0
    finally:
        algo.close()


def test_truncated_rows_are_bootstrapped_from_their_final_observation():
    r = recipe(gamma=0.5)
    algo = FastPPO(ENV, r, total=r.rollout_size, env_kwargs={"T": 40})
    try:
        algo.reset()
        final = np.asarray(algo._obs, dtype=np.float32)
        n = r.n_envs
        terminated, truncated = np.zeros(n, bool), np.zeros(n, bool)
        truncated[:3], terminated[2] = True, True  # rows 0, 1 cut by a time limit; row 2 ended
        info = {"final_obs": final, "_final_info": truncated, "final_info": {}}
        reward = algo._episode_ends(np.zeros(n), terminated, truncated, info)
        with torch.no_grad():
            values = algo._forward(torch.from_numpy(final))[1].numpy()
        np.testing.assert_allclose(reward[:2], 0.5 * values[:2], rtol=1e-6)
        assert np.all(reward[2:] == 0.0)
    finally:
        algo.close()


def test_a_learnt_policy_beats_random_on_a_short_scenario():
    """40 updates on T = 40 s episodes: the deterministic policy beats uniform random actions."""
    import gymnasium as gym

    from agents.loading import Agent
    from ios_uav_env.envs.rollout import run_episode

    torch.manual_seed(0)
    r = recipe(n_envs=64, batch_size=256, n_epochs=4, gamma=0.99, learning_rate=3e-3,
               normalize="{'norm_obs': False, 'norm_reward': True}")  # fmt: skip
    algo = FastPPO(ENV, r, total=40 * r.rollout_size, env_kwargs={"T": 40, "arrival_guard": True})
    env = gym.make(ENV, T=40)
    try:
        rng = np.random.default_rng(0)
        space = env.action_space
        random = np.mean([run_episode(env, lambda o: rng.uniform(space.low, space.high), seed=s).average_rate
                          for s in range(5)])  # fmt: skip
        while algo.steps < algo.total:
            algo.collect()
            algo.update()
        learnt = run_episode(env, Agent(algo.model, algo.vecnormalize, ENV, {"T": 40}).act, seed=0)
    finally:
        algo.close()
        env.close()
    assert learnt.feasible and learnt.average_rate > 1.2 * random


# --- a run: the folder, loading, resume ------------------------------------------------------
@pytest.fixture
def fast_file(tmp_path: Path) -> Path:
    import yaml

    path = tmp_path / "fast.yml"
    e = entry(normalize="{'norm_obs': True, 'norm_reward': True}",
              callback=[{"agents.callbacks.LogStdSchedule": {"start": -1.0, "end": -2.0}}])  # fmt: skip
    path.write_text(yaml.safe_dump({ENV: e}))
    return path


def _settings(fast_file: Path, out: Path, timesteps: int):
    from agents.training import TrainSettings

    return TrainSettings(algo="ppo", trainer="fast", env_kwargs={"T": 40}, timesteps=timesteps,
                         hyperparams_file=str(fast_file), out=str(out), checkpoint_freq=512, eval_freq=0,
                         progress_bar=False, threads=1)  # fmt: skip


def _rows(run_dir: Path) -> list[dict]:
    return [json.loads(line) for line in (run_dir / "progress.csv").read_text().splitlines()]


def test_a_fast_run_writes_a_run_folder_that_loads_everywhere(fast_file, tmp_path):
    from agents.loading import load_agent
    from agents.numpy_policy import NumpyPolicy
    from agents.training import train

    result = train(_settings(fast_file, tmp_path / "run", 1024))
    run = result.run_dir
    config = json.loads((run / "config.json").read_text())
    assert config["args"]["trainer"] == "fast" and config["algo"] == "ppo"
    assert {p.name for p in (run / "checkpoints").glob("*_512_steps.*")} >= {
        "rl_model_512_steps.zip", "rl_model_vecnormalize_512_steps.pkl", "rl_model_trainer_512_steps.pkl",
        "rl_model_progress_512_steps.json",
    }  # fmt: skip
    agent = load_agent(run)
    assert agent.env_kwargs == {"T": 40} and agent.vecnormalize is not None
    policy = NumpyPolicy.from_sb3(agent.model, agent.vecnormalize)
    obs = np.random.default_rng(0).normal(size=(5, agent.model.observation_space.shape[0]))
    np.testing.assert_allclose(policy.act(obs), agent.act(obs), atol=1e-5)
    assert load_agent(run, checkpoint=512).model.num_timesteps == 512
    summary = result.summary
    assert summary["steps"] == 1024 and summary["trainer"] == "fast" and summary["final_eval"]["feasible"]


def test_a_resumed_run_continues_the_same_optimiser_and_schedule(fast_file, tmp_path):
    from agents.fast.run import train_fast
    from agents.hyperparams import load_hyperparams
    from agents.training import TrainingInterrupted, resume, train
    from agents.training.folder import lock_run_dir

    total = 2048  # 8 updates of 256 steps
    whole = train(_settings(fast_file, tmp_path / "whole", total)).run_dir

    class Stop:  # a SIGINT during the 5th rollout
        signum = None

        def __init__(self):
            self.calls = 0

        def __call__(self):
            self.calls += 1
            if self.calls > 4 * 8 + 2:
                self.signum = 2
            return self.signum is not None

    settings = _settings(fast_file, tmp_path / "cut", total)
    settings.validate()
    hp = load_hyperparams("ppo", settings.env_id, fast_file)
    run = Path(settings.out)
    from agents.training.folder import check_new_run_dir

    check_new_run_dir(run)
    with lock_run_dir(run), pytest.raises(TrainingInterrupted) as stopped:
        train_fast(settings, Stop(), False, hp, total, run)
    assert stopped.value.steps == 1024 and stopped.value.steps_at_signal == 1024 + 2 * 32
    resume(run, progress_bar=False)
    cut, ref = _rows(run), _rows(whole)
    assert [row["steps"] for row in cut] == [row["steps"] for row in ref]
    for a, b in zip(cut, ref, strict=True):  # the schedule goes on where it stopped
        assert a["learning_rate"] == pytest.approx(b["learning_rate"]) and a["clip_range"] == b["clip_range"]
    from agents.loading import load_agent

    optimiser = load_agent(run).model.policy.optimizer.state_dict()["state"]
    steps = {int(s["step"]) for s in optimiser.values()}
    assert steps == {8 * 2 * 2}  # Adam's step count: 8 updates x 2 epochs x 2 minibatches, none reset
    assert math.isclose(float(load_agent(run).model.policy.log_std.detach()[0]), -1.0 - 7 / 8)


def test_train_py_takes_the_fast_trainer_and_refuses_what_it_does_not_train(tmp_path, capsys):
    import train

    with pytest.raises(SystemExit):
        train.parse_args(["--algo", "sac", "--trainer", "fast"])
    assert "trains PPO only" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        train.parse_args(["--algo", "ppo", "--threads", "2"])
    assert "only the fast trainer" in capsys.readouterr().err
    _, settings = train.parse_args(["--algo", "ppo", "--trainer", "fast", "--threads", "1"])
    assert settings.trainer == "fast" and settings.threads == 1
    assert settings.hyperparams_path().name == "fast_ppo.yml"


def test_gae_equals_torchrls_generalized_advantage_estimate():
    """TorchRL's GAE (time on dim -2) on the same rollout: the same advantages."""
    functional = pytest.importorskip("torchrl.objectives.value.functional")
    gen = torch.Generator().manual_seed(1)
    t, b = 7, 5
    r, v, last = (
        torch.randn(t, b, generator=gen),
        torch.randn(t, b, generator=gen),
        torch.randn(b, generator=gen),
    )
    d = (torch.rand(t, b, generator=gen) < 0.3).float()
    nv = torch.cat([v[1:], last[None]], 0)
    ours, _ = gae(r, v, d, last, 0.95, 0.9)
    as_trl = [x.T.unsqueeze(-1).contiguous() for x in (v, nv, r, d)]
    done = as_trl[3].bool()
    theirs, _ = functional.generalized_advantage_estimate(0.95, 0.9, *as_trl[:3], done, done)
    torch.testing.assert_close(ours, theirs.squeeze(-1).T)


def test_every_shipped_fast_recipe_is_read_whole():
    """Each entry of agents/hyperparams/fast_ppo.yml passes the zoo checks and the fast reader."""
    import yaml

    from agents.hyperparams import load_hyperparams
    from agents.training.settings import FAST_HYPERPARAMS

    ids = list(yaml.safe_load(FAST_HYPERPARAMS.read_text()))
    assert "ios_uav_env/IOSUAV-v0" in ids and MULTI in ids
    for env_id in ids:
        recipe = FastRecipe.from_hyperparams(load_hyperparams("ppo", env_id, FAST_HYPERPARAMS))
        assert recipe.rollout_size % recipe.batch_size == 0, env_id  # whole minibatches


def test_the_trainers_let_numbas_threads_sleep_between_kernels():
    """agents.fast and agents.vec_env set OMP_WAIT_POLICY=PASSIVE on import (before the first
    batched step launches numba's OpenMP threads), and leave a value the user set alone."""
    import os
    import subprocess
    import sys

    code = "import os, agents.fast, agents.vec_env; print(os.environ.get('OMP_WAIT_POLICY'))"
    root = Path(__file__).resolve().parents[2]
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    env["PYTHONPATH"] = str(root)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["PASSIVE"]
    env["OMP_WAIT_POLICY"] = "ACTIVE"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["ACTIVE"]


def test_the_same_seed_gives_the_same_training_bit_for_bit():
    """Two runs seeded alike (rows, sampling, minibatches, exploring starts) end with the same
    parameters; another seed does not."""
    starts = [{"agents.wrappers.ExploringStarts": {"prob": 0.5, "max_moves": 10}}]
    r = recipe(env_wrapper=starts, normalize="{'norm_obs': True, 'norm_reward': True}")

    def train(seed: int) -> list[torch.Tensor]:
        algo = FastPPO(ENV, r, total=3 * r.rollout_size, env_kwargs={"T": 40}, seed=seed)
        try:
            while algo.steps < algo.total:
                algo.collect()
                algo.update()
            return [p.detach().clone() for p in algo.policy.parameters()]
        finally:
            algo.close()

    first, again, other = train(3), train(3), train(4)
    assert all(torch.equal(a, b) for a, b in zip(first, again, strict=True))
    assert not all(torch.equal(a, b) for a, b in zip(first, other, strict=True))
