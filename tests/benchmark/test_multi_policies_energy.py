"""ios_uav_env.benchmark.multi_policies on the multi-node energy layout (``objective="energy_efficiency"``:
4 energy features after the node blocks): bound to the env's names it flies as on the rate layout;
unbound, an energy observation is refused, naming the energy features and the bind."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env  # noqa: F401
from ios_uav_env.benchmark.multi_policies import StraightEqualShares
from ios_uav_env.envs.observation_layout import ENERGY_NAMES
from ios_uav_env.envs.rollout import policy_for

FIXED_ID = "ios_uav_env/IOSUAV-MultiNode-v0"
RANDOM_ID = "ios_uav_env/IOSUAV-MultiNode-Random-v0"
ENERGY = {"objective": "energy_efficiency"}


def _flight(env_id, kwargs, seed=3):
    env = gym.make(env_id, **kwargs)
    policy = StraightEqualShares().bind(env.unwrapped.observation_names)
    obs, _ = env.reset(seed=seed)
    actions, done = [], False
    while not done:
        actions.append(policy(obs))
        obs, _, done, _, _ = env.step(actions[-1])
    return env.unwrapped, np.array(actions)


@pytest.mark.parametrize("env_id", [FIXED_ID, RANDOM_ID])
@pytest.mark.parametrize("peak", [False, True])
def test_bound_to_the_energy_layout_it_flies_as_on_the_rate_layout(env_id, peak):
    kwargs = {"peak_hint": True} if peak else {}
    energy_env, energy_actions = _flight(env_id, {**kwargs, **ENERGY})
    assert energy_env.observation_names[-len(ENERGY_NAMES) :] == ENERGY_NAMES
    assert energy_actions.shape[1] == 2 + energy_env.max_nodes  # K_max from the mask features only
    rate_env, rate_actions = _flight(env_id, kwargs)
    np.testing.assert_array_equal(energy_env.trajectory, rate_env.trajectory)  # qF read by name
    np.testing.assert_array_equal(energy_actions, rate_actions)
    assert np.allclose(energy_env.trajectory[-1], energy_env.config.qF)
    policy = policy_for(StraightEqualShares(), env_id, {**kwargs, **ENERGY})  # the benchmark's binding
    obs, _ = gym.make(env_id, **kwargs, **ENERGY).reset(seed=3)
    np.testing.assert_array_equal(policy(obs), energy_actions[0])


@pytest.mark.parametrize("env_id", [FIXED_ID, RANDOM_ID])
def test_unbound_an_energy_observation_is_refused_naming_the_energy_features(env_id):
    obs, _ = gym.make(env_id, **ENERGY).reset(seed=0)
    with pytest.raises(ValueError, match=r"12 \+ 6 K_max entries.*policy.bind.*energy features \(move_x"):
        StraightEqualShares()(obs)
    rate_obs, _ = gym.make(env_id).reset(seed=0)
    assert StraightEqualShares()(rate_obs).shape == (2 + (obs.shape[0] - 16) // 6,)
