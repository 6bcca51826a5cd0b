"""``MISOControl-v0`` with ``access="noma"`` (``ios_uav_env.envs.miso_control``): the reward is the
objective of the SIC rates in the slot's stated decoding order, ``info`` carries the NOMA AO value
and the same certified bound, the AO setting as an action reaches the AO value, the default access
keeps the SDMA episode bit for bit, the batched form's rows are the singles, both checkers pass,
and a bad access is refused by name."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import ios_uav_env
from ios_uav_env.envs.miso_control import ACCESS, INFO_KEYS, N_SLOTS, MISOControlEnv
from ios_uav_env.envs.miso_control_vector import MISOControlVectorEnv
from ios_uav_env.model.miso import objective_value, slot_bounds, user_rates
from ios_uav_env.model.miso_noma import decoding_order, sic_rates
from ios_uav_env.model.miso_noma_slot import noma_optimum
from tests.envs.test_miso_control import _episode

#: Small settings: the per-slot NOMA AO of each runs in about a tenth of a second.
SMALL = [
    {"antennas": 2, "users": 2, "elements": (2, 2), "access": "noma"},
    {"antennas": 2, "users": 3, "elements": (2, 2), "objective": "maxmin", "access": "noma"},
]


@pytest.mark.parametrize("kwargs", SMALL, ids=str)
def test_the_reward_is_the_sic_objective_and_info_the_noma_ao_and_bound(kwargs):
    env = MISOControlEnv(**kwargs)
    rng = np.random.default_rng(1)
    env.reset(seed=2)
    warm, differs = None, False
    for _ in range(N_SLOTS):
        ch = env.channels[env.slot]
        action = rng.uniform(-1, 1, env.action_space.shape)
        phases, beams = env.setting(action)
        H = ch.matrix(phases)
        rates = sic_rates(H, beams, decoding_order(ch))
        _, reward, _, _, info = env.step(action)
        assert reward == objective_value(rates, env.objective) and np.array_equal(info["rates"], rates)
        differs |= not np.allclose(rates, user_rates(H, beams))  # not the SDMA rates
        warm = noma_optimum(ch, env.objective, warm=warm)  # the env's chain of warm starts
        bound = slot_bounds(ch).of(env.objective)
        assert (info["optimum"], info["bound"]) == (warm.value, bound)
        assert reward <= bound * (1 + 1e-12) and warm.value <= bound * (1 + 1e-12)
    assert differs and 0 < info["pct_of_bound"] < info["pct_of_optimum"] < 100


def test_the_ao_setting_as_an_action_reaches_the_ao_value():
    env = MISOControlEnv(**SMALL[0])
    env.reset(seed=5)
    for _ in range(N_SLOTS):
        best = noma_optimum(env.channels[env.slot], env.objective, warm=env.solution)
        _, reward, terminated, _, info = env.step(env.action_of(best.phases, best.beams))
        assert info["optimum"] == best.value and reward >= best.value * (1 - 1e-9)
    assert terminated and info["pct_of_optimum"] >= 100 * (1 - 1e-9)


def test_the_default_access_is_sdma_and_leaves_the_episode_unchanged():
    """The default is linear precoding (``miso.user_rates``: each user treats the others as noise);
    the golden episodes of ``MISOControl-v0`` hold its outputs from before the keyword."""
    assert ACCESS == ("sdma", "noma") and MISOControlEnv().access == "sdma"
    env = MISOControlEnv(antennas=2, elements=(2, 2), optimum=False)
    env.reset(seed=4)
    ch, action = env.channels[env.slot], np.random.default_rng(4).uniform(-1, 1, env.action_space.shape)
    phases, beams = env.setting(action)
    assert env.step(action)[1] == objective_value(user_rates(ch.matrix(phases), beams), env.objective)
    kwargs = {"antennas": 2, "elements": (2, 2), "optimum": False}
    first = _episode(MISOControlEnv(**kwargs), 8)
    second = _episode(MISOControlEnv(access="sdma", **kwargs), 8)
    assert len(first) == len(second)
    assert all(np.array_equal(x, y, equal_nan=True) for x, y in zip(first, second, strict=True))
    noma = _episode(MISOControlEnv(access="noma", **kwargs), 8)  # the observations are the same
    assert np.array_equal(noma[0], first[0])


@pytest.mark.parametrize("bad", ["NOMA", "tdma", "", None, 1])
def test_a_bad_access_is_refused_by_name(bad):
    with pytest.raises(ValueError, match=r"access must be one of \('sdma', 'noma'\)"):
        MISOControlEnv(access=bad)
    with pytest.raises(ValueError, match="access must be one of"):
        gym.make(ios_uav_env.MISO_CONTROL_ID, access=bad)


def test_the_batched_rows_are_the_singles_across_an_autoreset():
    kwargs = {"antennas": 2, "users": 2, "elements": (2, 2), "access": "noma", "optimum": False}
    vec = gym.make_vec(
        ios_uav_env.MISO_CONTROL_ID, num_envs=2, vectorization_mode="vector_entry_point", **kwargs
    )
    assert isinstance(vec.unwrapped, MISOControlVectorEnv)
    singles = [MISOControlEnv(**kwargs) for _ in range(2)]
    obs, info = vec.reset(seed=7)
    for b, env in enumerate(singles):
        o, i = env.reset(seed=7 + b)
        assert np.array_equal(obs[b], o) and all(
            np.array_equal(info[k][b], i[k], equal_nan=True) for k in INFO_KEYS
        )
    rng, pending = np.random.default_rng(0), np.zeros(2, dtype=bool)
    for _ in range(N_SLOTS + 2):  # through one NEXT_STEP autoreset
        actions = rng.uniform(-1, 1, vec.action_space.shape)
        obs, reward, terminated, _, info = vec.step(actions)
        for b, env in enumerate(singles):
            if pending[b]:  # NEXT_STEP: this step is the row's reset
                (o, i), r, t = env.reset(), 0.0, False
            else:
                o, r, t, _, i = env.step(actions[b])
            assert np.array_equal(obs[b], o) and reward[b] == r and terminated[b] == t
            assert all(np.array_equal(info[k][b], i[k], equal_nan=True) for k in INFO_KEYS)
        pending = terminated.copy()
    vec.close()


def test_both_checkers_pass_without_warnings():
    env = gym.make(ios_uav_env.MISO_CONTROL_ID, antennas=2, elements=(2, 2), access="noma")  # (NaN-free info)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=True)
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sb3_checker.check_env(env.unwrapped, warn=True)


def test_noma_on_rician_slots_decodes_the_drawn_channels():
    """The two keywords combine: under ``channel="rician"`` the SIC rates are those of the slot's
    drawn channel (and its own decoding order), not of the LoS one, and stay under its bound; the
    AO reference is the NOMA AO of the drawn channel."""
    env = MISOControlEnv(**SMALL[0], channel="rician")
    los = MISOControlEnv(**SMALL[0], optimum=False)
    env.reset(seed=3)
    los.reset(seed=3)
    action = np.random.default_rng(0).uniform(-1, 1, env.action_space.shape)
    ch = env.channels[env.slot]
    assert not np.allclose(ch.matrix(np.zeros(env.M)), los.channels[los.slot].matrix(np.zeros(env.M)))
    phases, beams = env.setting(action)
    rates = sic_rates(ch.matrix(phases), beams, decoding_order(ch))
    _, reward, _, _, info = env.step(action)
    assert reward == objective_value(rates, env.objective)
    assert reward <= slot_bounds(ch).of(env.objective) * (1 + 1e-12)
    assert info["optimum"] == noma_optimum(ch, env.objective).value  # the first slot: no warm start
    assert info["bound"] == slot_bounds(ch).of(env.objective)
