"""The heuristic policies (ios_uav_env/envs/policies.py) and the one episode loop (rollout.py)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env  # noqa: F401  (registers the ids)
from ios_uav_env import ScenarioConfig, average_rate, check_trajectory, rate_peak
from ios_uav_env.envs.observation import observation_names
from ios_uav_env.envs.policies import TARGETS, HoverAt, move_toward
from ios_uav_env.envs.rollout import run_episode

CONFIG = ScenarioConfig(T=80.0, ios_shape=(100, 20))


def test_move_toward_is_full_speed_then_exact():
    far = move_toward(np.array([-400.0, 0.0]), 25.0)
    assert far.dtype == np.float32 and np.hypot(*far) == pytest.approx(1.0) and far[0] == -1.0
    np.testing.assert_allclose(move_toward(np.array([10.0, 0.0]), 25.0), [0.4, 0.0], atol=1e-7)
    assert np.array_equal(move_toward(np.zeros(2), 25.0), np.zeros(2, dtype=np.float32))


@pytest.mark.parametrize("instance", [False, True])
def test_targets_point_at_the_named_observation_components(instance):
    names = observation_names(instance, peak=True)
    assert names[slice(*TARGETS["ground"])] == ("dx_ground", "dy_ground")
    assert names[slice(*TARGETS["peak"])] == ("dx_peak", "dy_peak")


@pytest.mark.parametrize("target", ["peak", "ground"])
def test_hover_at_reaches_its_point_and_the_guard_lands_it(target):
    policy = HoverAt(target)
    env = gym.make("ios_uav_env/IOSUAV-v0", config=CONFIG, **policy.env_kwargs)
    episode = run_episode(env, policy, seed=0)
    point = rate_peak(CONFIG)[:2] if target == "peak" else CONFIG.ground_node
    distances = np.linalg.norm(episode.trajectory - np.asarray(point), axis=1)
    assert distances.min() < 1e-3  # it got there ...
    assert int((distances < 1e-3).sum()) > 5  # ... and hovered
    assert episode.feasible and episode.steps == CONFIG.N - 1


def test_hovering_at_the_peak_beats_hovering_over_g_behind_the_ios():
    # G at x < 0 and a large IOS: the best hover point is across the surface (x > 0)
    config = ScenarioConfig(T=150.0)
    rates = {}
    for target in ("peak", "ground"):
        policy = HoverAt(target)
        env = gym.make("ios_uav_env/IOSUAV-v0", config=config, **policy.env_kwargs)
        rates[target] = run_episode(env, policy).average_rate
    assert rates["peak"] > rates["ground"] + 0.3


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="target"):
        HoverAt("moon")
    with pytest.raises(ValueError, match="D"):
        HoverAt("peak", D=0.0)


def test_run_episode_scores_with_the_model_and_times_the_plan():
    policy = HoverAt("peak")
    env = gym.make("ios_uav_env/IOSUAV-v0", config=CONFIG, channel="rician", **policy.env_kwargs)
    episode = run_episode(env, policy, seed=4)
    assert episode.average_rate == average_rate(CONFIG, episode.trajectory)
    assert episode.feasible == check_trajectory(CONFIG, episode.trajectory).feasible
    assert episode.mean_faded_rate != episode.average_rate and episode.seconds > 0
    assert episode.config == CONFIG and episode.trajectory.shape == (CONFIG.N, 2)
    again = run_episode(env, policy, seed=4)
    assert again.mean_faded_rate == episode.mean_faded_rate and again.episode_return == episode.episode_return


def test_run_episode_pins_a_scenario_with_options():
    env = gym.make("ios_uav_env/IOSUAV-Random-v0")
    episode = run_episode(env, lambda obs: np.zeros(2), seed=0, options={"config": CONFIG})
    assert episode.config == CONFIG and episode.feasible


def test_run_episode_stops_an_env_that_never_ends():
    class Endless(gym.Env):
        observation_space = gym.spaces.Box(-1, 1, (1,))
        action_space = gym.spaces.Box(-1, 1, (1,))

        def reset(self, *, seed=None, options=None):
            return np.zeros(1, dtype=np.float32), {}

        def step(self, action):
            return np.zeros(1, dtype=np.float32), 0.0, False, False, {}

    with pytest.raises(RuntimeError, match="max_steps=10"):
        run_episode(Endless(), lambda obs: np.zeros(1), max_steps=10)
