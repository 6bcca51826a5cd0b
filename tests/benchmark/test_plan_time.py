"""What a policy's plan time is (ios_uav_env.benchmark.scoring): the episode of one scenario in
the single env, the policy and the env warm (no compilation, no batch setup in it), whether the
policy is batched or not. Checked with a fake clock and the env the scorer makes, not timed."""

from __future__ import annotations

import types

import numpy as np
import pytest

from ios_uav_env.benchmark import evaluate, scoring
from ios_uav_env.envs import rollout
from ios_uav_env.envs.policies import HoverAt


class FakeClock:
    """``time.perf_counter`` that moves only when told to."""

    def __init__(self) -> None:
        self.now = 0.0

    def perf_counter(self) -> float:
        return self.now


class SlowFirstCall:
    """HoverAt("ground"), whose first call costs 100 s (a compilation, a lazy import) and every
    call 1 s on the fake clock; ``calls`` per reset of the env (the episodes it planned)."""

    def __init__(self, clock: FakeClock, batched: bool) -> None:
        self.clock, self.batched, self.first, self.calls = clock, batched, True, []
        self.policy = HoverAt("ground")

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        self.clock.now += 100.0 if self.first else 1.0
        self.first = False
        self.calls[-1] += 1
        obs = np.asarray(obs)
        return np.stack([self.policy(o) for o in obs]) if self.batched else self.policy(obs)


@pytest.fixture
def clock(monkeypatch):
    fake = FakeClock()
    fake_time = types.SimpleNamespace(perf_counter=fake.perf_counter)
    monkeypatch.setattr(scoring, "time", fake_time)
    monkeypatch.setattr(rollout, "time", fake_time)
    return fake


@pytest.fixture
def made(monkeypatch):
    """Whether each env the scorer made was the id's batched env, and how many rows it had."""
    envs = []
    real = scoring._make_env

    def spy(env_id, env_kwargs, batched, num_envs=1):
        env, vector = real(env_id, env_kwargs, batched, num_envs)
        envs.append((vector, num_envs if vector else 1))
        return env, vector

    monkeypatch.setattr(scoring, "_make_env", spy)
    return envs


def _count_episodes(policy: SlowFirstCall, monkeypatch) -> None:
    """Open a new count of ``policy``'s calls at every episode the scorer plays."""
    real = scoring.play

    def play(env, act, scenario, seed, repeat=None):
        policy.calls.append(0)
        return real(env, act, scenario, seed, repeat)

    monkeypatch.setattr(scoring, "play", play)


@pytest.mark.parametrize("batched", [False, True])
def test_a_plan_time_is_the_scenario_s_own_episode_in_the_single_env(clock, made, monkeypatch, batched):
    policy = SlowFirstCall(clock, batched)
    _count_episodes(policy, monkeypatch)
    results = evaluate(policy, "single-node-v1", n=3, batched=batched)
    # every env the scorer made is the single env (a batched policy sees a batch of one)
    assert made and all(not vector for vector, _ in made), made
    timed = policy.calls[-3:]  # the three scored episodes (any warm-up came before them)
    assert [r.seconds for r in results.scenarios] == [float(c) for c in timed]
    assert results.aggregate.median_seconds == float(np.median(timed))


def test_at_once_a_plan_time_is_the_warm_batch_s_time_per_scenario(clock, made, monkeypatch):
    policy = SlowFirstCall(clock, batched=True)
    policy.calls.append(0)
    real = rollout.run_episodes

    def run_episodes(vec, act, **kwargs):
        policy.calls.append(0)
        return real(vec, act, **kwargs)

    monkeypatch.setattr(rollout, "run_episodes", run_episodes)
    results = evaluate(policy, "single-node-v1", n=3, batched=True, at_once=True)
    batch = policy.calls[-1]  # the calls of the timed batch: one per slot of the longest episode
    assert [r.seconds for r in results.scenarios] == [batch / 3.0] * 3
    assert made[-1] == (True, 3)
