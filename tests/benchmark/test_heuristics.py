"""ios_uav_env.benchmark.heuristics: the suites' policy rows, a policy flown in the env."""

from __future__ import annotations

import doctest

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env.benchmark.heuristics as heuristics
from ios_uav_env import MULTINODE_MOBILE_ID, RANDOM_ENV_ID, GaussMarkov, IOSUAVEnv, ScenarioConfig
from ios_uav_env.benchmark import fly, hover_episode
from ios_uav_env.benchmark.multi_policies import StraightEqualShares
from ios_uav_env.envs.policies import HoverAt
from ios_uav_env.envs.rollout import policy_for, run_episode

SMALL = {"ios_shape": (10, 6), "quadrature_nodes": 4}
WALK = ScenarioConfig(
    ground_node=(-60.0, -20.0), T=30.0, q0=(-200.0, 20.0), qF=(200.0, 20.0),
    motion=GaussMarkov(speed=6.0, sigma=2.0), **SMALL,
)  # fmt: skip


def test_the_docstring_example_holds():
    assert doctest.testmod(heuristics).failed == 0


@pytest.mark.parametrize("knowledge", ["exact", "reports"])
def test_the_scenarios_own_env_flies_the_loop_of_the_policy(knowledge):
    env, policy = IOSUAVEnv(WALK, knowledge=knowledge), HoverAt("ground", D=WALK.D)
    obs, _ = env.reset(seed=11, options={"config": WALK})
    done = False
    while not done:
        obs, _, done, _, _ = env.step(policy(obs))
    episode = hover_episode(WALK, "ground", seed=11, knowledge=knowledge)
    assert np.array_equal(episode.trajectory, env.trajectory)
    assert episode.feasible and episode.steps == WALK.N - 1
    other = hover_episode(WALK, "ground", seed=12, knowledge=knowledge)
    assert not np.array_equal(other.trajectory, episode.trajectory)  # the seed draws the node's walk


def test_an_ids_env_gets_the_policys_arguments():
    config = ScenarioConfig(T=80.0, ground_node=(120.0, -60.0))  # the peak by the IOS, not at G
    policy = HoverAt("peak")
    env = gym.make(RANDOM_ENV_ID, **policy.env_kwargs)
    try:
        expected = run_episode(env, policy, seed=0, options={"config": config})
    finally:
        env.close()
    episode = hover_episode(config, "peak", env_id=RANDOM_ENV_ID)
    assert np.array_equal(episode.trajectory, expected.trajectory)
    assert episode.average_rate == expected.average_rate
    ground = hover_episode(config, "ground", env_id=RANDOM_ENV_ID)
    assert ground.average_rate != episode.average_rate  # the target is flown, not ignored


def test_an_unknown_target_is_refused_before_any_env_is_made():
    with pytest.raises(ValueError, match="target must be one of"):
        hover_episode(WALK, "qF")


def test_fly_returns_a_multinode_policys_own_shares():
    config = WALK.replace(ground_nodes=((-60.0, -20.0), (80.0, 40.0)))
    policy = policy_for(StraightEqualShares(), MULTINODE_MOBILE_ID, {})
    env = gym.make(MULTINODE_MOBILE_ID)
    try:
        obs, _ = env.reset(seed=5, options={"config": config})
        done = False
        while not done:
            obs, _, done, _, _ = env.step(policy(obs))
        expected = env.unwrapped.trajectory, env.unwrapped.shares
    finally:
        env.close()
    flight = fly(StraightEqualShares(), config, env_id=MULTINODE_MOBILE_ID, seed=5)
    assert np.array_equal(flight.trajectory, expected[0]) and np.array_equal(flight.shares, expected[1])
    assert flight.shares.shape == (2, config.N) and flight.seconds == flight.episode.seconds > 0
    own = fly(StraightEqualShares(), config, seed=5)  # the scenario's own env: MultiNodeEnv, exact knowledge
    assert own.shares.shape == (2, config.N) and own.episode.feasible
    assert hover_episode(WALK, "ground", seed=5).trajectory.shape == (WALK.N, 2)
    assert fly(HoverAt("ground", D=WALK.D), WALK, seed=5).shares is None  # one node: no shares
