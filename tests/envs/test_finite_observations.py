"""Every observation entry is a finite float32 for every accepted setting: the fields whose
extreme values would overflow the observation (lengths over length_scale, the energy weight, the
horizon, the minimum-power move, reports far off, the rate bound) are refused at construction,
naming the field and its allowed range; accepted extremes give finite observations."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env  # noqa: F401  (registers the ids)

IOS, ENERGY, RANDOM = "ios_uav_env/IOSUAV-v0", "ios_uav_env/IOSUAV-Energy-v0", "ios_uav_env/IOSUAV-Random-v0"
MOBILE, MULTI = "ios_uav_env/IOSUAV-Mobile-v0", "ios_uav_env/IOSUAV-MultiNode-v0"
MULTI_MOBILE = "ios_uav_env/IOSUAV-MultiNode-Mobile-v0"

#: (id, the extreme setting, the field a refusal must name) for each observation-affecting field;
#: ``None``: the setting is accepted and its observations must be finite.
CASES = [
    (IOS, {"length_scale": 1e-40}, "length_scale must be >="),
    (RANDOM, {"length_scale": 1e-40}, "length_scale must be >="),
    (MULTI, {"length_scale": 1e-40}, "length_scale must be >="),
    (MOBILE, {"length_scale": 1e-40}, "length_scale must be >="),
    (IOS, {"length_scale": 1e300, "T": 40.0}, None),
    (MULTI, {"length_scale": 1e300, "T": 40.0}, None),
    (ENERGY, {"energy_reference": 1e300}, "energy_reference must be <="),
    (ENERGY, {"energy_reference": 1e36, "T": 40.0}, None),
    (ENERGY, {"energy_reference": 1e-300, "T": 40.0}, None),
    (ENERGY, {"bandwidth_hz": 1e-300, "energy_reference": 1.0}, "energy_reference must be <="),
    (ENERGY, {"bandwidth_hz": 1e300, "T": 40.0}, None),
    (MOBILE, {"report_sigma": 1e300}, "report_sigma must be <="),
    (MULTI_MOBILE, {"report_sigma": 1e300}, "length_scale must be >="),
    (MOBILE, {"report_sigma": 1e30}, None),
    (IOS, {"T": 1e41, "dt": 1e39}, "v_max dt"),  # the reach (N - 1) D overflows first
    (IOS, {"T": 1e41, "dt": 1e39, "v_max": 1e-37, "instance_features": True}, "T must be <="),  # the horizon
    (IOS, {"T": 1e41, "dt": 1e39, "v_max": 1e-37}, None),  # (no horizon feature without instance features)
    (ENERGY, {"v_max": 1e-40, "T": 1e44, "dt": 1e42}, "v_max must be >="),
    (IOS, {"g_tx": 1e300, "g_rx": 1e300}, "g_tx"),  # the rate bound overflows
    (IOS, {"g_tx": 1e300, "T": 40.0}, None),
    (IOS, {"power_w": 1e100, "noise_dbm": -250.0, "T": 40.0}, None),
    (ENERGY, {"propulsion": {"P0": 1e300}, "T": 40.0}, None),
]


def _finite_episode(env: gym.Env) -> None:
    obs, _ = env.reset(seed=0)
    rng = np.random.default_rng(0)
    done, seen = False, [obs]
    while not done:
        obs, reward, terminated, truncated, _ = env.step(rng.uniform(-1.0, 1.0, env.action_space.shape))
        seen.append(obs)
        assert np.isfinite(reward)
        done = terminated or truncated
    seen = np.array(seen)
    assert np.all(np.isfinite(seen)) and np.all(np.isfinite(env.observation_space.high))
    assert all(env.observation_space.contains(o) for o in seen)


@pytest.mark.parametrize(("env_id", "kwargs", "refusal"), CASES)
def test_extreme_values_are_refused_or_give_finite_observations(env_id, kwargs, refusal):
    if refusal is None:
        _finite_episode(gym.make(env_id, **kwargs))
        return
    with pytest.raises(ValueError, match=r"beyond float32") as err:
        gym.make(env_id, **kwargs)
    assert refusal in str(err.value)


def test_a_pinned_scenario_that_would_overflow_is_refused_at_reset():
    from ios_uav_env import ScenarioConfig

    env = gym.make(RANDOM)
    with pytest.raises(ValueError, match=r'options\["config"\]: .*beyond float32'):
        env.reset(options={"config": ScenarioConfig(T=1e41, dt=1e39)})
