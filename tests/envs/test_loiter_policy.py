"""The loiter policy on the observation (ios_uav_env/envs/policies.py: Loiter, moves_left)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env  # noqa: F401  (registers the ids)
from ios_uav_env import ENERGY_ID, ENERGY_RANDOM_ID, ScenarioConfig, score_plan
from ios_uav_env.envs.loiter_flight import loiter_path
from ios_uav_env.envs.observation import ENERGY_NAMES, PEAK_NAMES, observation_names
from ios_uav_env.envs.policies import _MIN_POWER_MOVE, Loiter, moves_left
from ios_uav_env.envs.rollout import run_episode
from ios_uav_env.model.propulsion import max_range_speed

#: The energy scenario of the tests: a short horizon that still leaves time to loiter at V_mr.
CONFIG = ScenarioConfig(T=90.0, ios_shape=(100, 20), objective="energy_efficiency")


@pytest.mark.parametrize("instance", [False, True])
def test_the_minimum_power_move_is_read_from_its_named_component(instance):
    names = observation_names(instance, peak=True, energy=True)
    assert names[_MIN_POWER_MOVE] == "min_power_move" == ENERGY_NAMES[-1]
    assert names[-len(PEAK_NAMES) :] == PEAK_NAMES


def test_moves_left_is_read_off_the_observation_at_every_slot():
    """The slack and the final point's offset give the env's own count of moves left, for any
    flight (here random moves, guard on) and any drawn horizon."""
    env = gym.make(ENERGY_RANDOM_ID, peak_hint=True)
    for seed in range(3):
        obs, _ = env.reset(seed=seed)
        n_moves = env.unwrapped.config.N - 1
        env.action_space.seed(seed)
        for k in range(n_moves):
            assert moves_left(obs, 25.0, 400.0) == n_moves - k
            obs, *_ = env.step(env.action_space.sample())
        assert moves_left(obs, 25.0, 400.0) == 0


def test_loiter_flies_the_loiter_flight_of_the_package():
    """From the observation alone it flies ``loiter_path``'s flight (legs at V_mr, the polygon at
    V_mp around the peak, the last leg home), up to the float32 rounding of the told peak."""
    env = gym.make(ENERGY_ID, config=CONFIG, peak_hint=True)
    episode = run_episode(env, Loiter(), seed=0)
    expected, info = loiter_path(CONFIG)  # around rate_peak(CONFIG), the hint's peak
    assert info["loiter_moves"] > 10 and info["cruise_speed"] == pytest.approx(max_range_speed())
    np.testing.assert_allclose(episode.trajectory, expected, atol=1e-3)
    assert episode.feasible
    ee = score_plan(CONFIG, episode.trajectory).energy_efficiency
    assert ee == pytest.approx(score_plan(CONFIG, expected).energy_efficiency, rel=1e-6)


def test_loiter_beats_hovering_at_the_peak_on_the_energy_objective():
    from ios_uav_env.envs.policies import HoverAt

    scores = {}
    for name, policy in (("loiter", Loiter()), ("hover", HoverAt("peak"))):
        env = gym.make(ENERGY_ID, config=CONFIG, **policy.env_kwargs)
        scores[name] = run_episode(env, policy, seed=0).energy_efficiency
    assert scores["loiter"] > 1.1 * scores["hover"]


def test_loiter_takes_a_batch_and_refuses_a_layout_without_the_hint():
    env = gym.make(ENERGY_RANDOM_ID, peak_hint=True)
    obs = np.stack([env.reset(seed=s)[0] for s in range(4)])
    policy = Loiter()
    batch = policy(obs)
    assert batch.shape == (4, 2) and batch.dtype == np.float32
    np.testing.assert_array_equal(batch[2], policy(obs[2]))
    assert np.all(np.hypot(batch[:, 0], batch[:, 1]) <= 1.0 + 1e-6)
    with pytest.raises(ValueError, match="peak_hint"):
        policy(np.zeros(11, dtype=np.float32))


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [({"D": 0.0}, "D"), ({"length_scale": -1.0}, "length_scale"), ({"cruise": float("nan")}, "cruise"),
     ({"sides": 1}, "sides"), ({"sides": True}, "sides")],
)  # fmt: skip
def test_bad_arguments_are_refused_naming_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        Loiter(**kwargs)
