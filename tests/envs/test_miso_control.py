"""The multi-antenna UAV's beams and phases as the agent's control (``ios_uav_env.envs.miso_control``,
id ``ios_uav_env/MISOControl-v0``, and its batched form ``miso_control_vector``): the reward is the
objective of ``miso.user_rates`` at the action's setting, no action beats the certified bound, the
AO setting given as an action reaches the AO value, K = 1 reaches the bound (closed form), seeded
episodes repeat bit for bit, the batch's row b is the single env seeded seed + b across
autoresets, bad keywords are refused by name; with a Rician ``channel`` the slots are the model's
draws from the env's generator, the bound still holds, and the same properties hold. (The id's
checkers and golden episode: ``test_checkers.py``, ``test_golden.py``.)"""

from __future__ import annotations

import math
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import ios_uav_env
from ios_uav_env.envs.miso_control import CHANNELS, INFO_KEYS, N_SLOTS, USERS, X_RANGE, MISOControlEnv, wrap
from ios_uav_env.envs.miso_control_vector import MISOControlVectorEnv
from ios_uav_env.model.miso import (
    aligned_phases,
    baselines,
    mrt_beam,
    objective_value,
    slot_bounds,
    slot_channels,
    user_rates,
)
from ios_uav_env.model.miso_fading import rician_slot_channels
from ios_uav_env.model.miso_slot import slot_optimum

ID = ios_uav_env.MISO_CONTROL_ID
#: Small settings (the per-slot AO of each runs in ~0.05 s).
SMALL = [{"antennas": 2, "users": 2}, {"antennas": 4, "users": 3, "elements": (2, 4), "objective": "maxmin"}]


def _episode(env: gym.Env, seed: int) -> list:
    """Everything a seeded episode of random actions shows, and the autoreset's first outputs."""
    obs, info = env.reset(seed=seed)
    out = [obs, *info.values()]
    rng = np.random.default_rng(seed)
    for _ in range(N_SLOTS):
        obs, reward, terminated, truncated, info = env.step(rng.uniform(-1, 1, env.action_space.shape))
        out += [obs, reward, terminated, truncated, *info.values()]
    return out


def test_the_id_makes_the_env_and_its_info_keys_stay_fixed():
    env = gym.make(ID, antennas=2, users=3)
    assert isinstance(env.unwrapped, MISOControlEnv) and env.spec.max_episode_steps is None
    _, info = env.reset(seed=0)
    assert tuple(info) == INFO_KEYS and info["pct_of_optimum"] == 0.0 and info["rates"].shape == (3,)
    base = env.unwrapped  # the episode's scenario: the first K users as nodes, the line as q0 -> qF
    assert base.config.nodes == USERS[:3] and base.config.surface == "ios"
    assert base.config.q0 == tuple(base.positions[0]) and base.config.qF == tuple(base.positions[-1])
    assert env.observation_space.shape == (3 + 4 * 3 + 2 * 2 * 4 + 3 * 16,) == (len(base.observation_names),)
    assert env.action_space.shape == (2 * 2 * 3 + 16,)
    for n in range(N_SLOTS):
        _, _, terminated, truncated, info = env.step(env.action_space.sample())
        assert tuple(info) == INFO_KEYS and info["slot"] == n and terminated == (n == N_SLOTS - 1)
        assert not truncated
    with pytest.raises(RuntimeError, match="ended"):
        env.step(env.action_space.sample())


@pytest.mark.parametrize("kwargs", SMALL, ids=str)
def test_the_reward_is_the_settings_objective_and_info_is_the_models(kwargs):
    env = MISOControlEnv(**kwargs)
    rng = np.random.default_rng(1)
    env.reset(seed=2)
    totals, warm = np.zeros(3), None
    for _ in range(N_SLOTS):
        ch = env.channels[env.slot]
        action = rng.uniform(-1, 1, env.action_space.shape)
        phases, beams = env.setting(action)
        assert np.sum(np.abs(beams) ** 2) == pytest.approx(1.0, rel=1e-12)  # all of P
        rates = user_rates(ch.matrix(phases), beams)
        _, reward, _, _, info = env.step(action)
        assert reward == objective_value(rates, env.objective) and np.array_equal(info["rates"], rates)
        warm = slot_optimum(ch, env.objective, warm=warm)  # the env's chain of warm starts
        refs = baselines(ch, env.objective, np.random.default_rng(0))
        bound = slot_bounds(ch).of(env.objective)
        assert (info["optimum"], info["bound"]) == (warm.value, bound)
        assert (info["mrt_aligned"], info["tdma"]) == (refs["MRT aligned"], refs["TDMA"])
        assert np.array_equal(info["zf_aligned"], refs["ZF aligned"], equal_nan=True)
        assert reward <= bound * (1 + 1e-12) and warm.value <= bound * (1 + 1e-9)
        assert warm.value >= refs["MRT aligned"] * (1 - 1e-12)  # AO starts there and never falls
        totals += (reward, warm.value, bound)
        assert info["return"] == pytest.approx(totals[0], rel=1e-12)
        assert info["pct_of_optimum"] == pytest.approx(100 * totals[0] / totals[1], rel=1e-12)
        assert info["pct_of_bound"] == pytest.approx(100 * totals[0] / totals[2], rel=1e-12)
    assert 0 < info["pct_of_bound"] < info["pct_of_optimum"] < 100  # random settings fall short


def test_many_random_settings_stay_below_the_bound_and_the_beams_scale_freely():
    env = MISOControlEnv(antennas=4, users=4, elements=(2, 2), optimum=False)
    env.reset(seed=3)
    rng = np.random.default_rng(4)
    for ch in env.channels[::3]:
        bound = slot_bounds(ch).sum_rate
        for _ in range(50):
            action = rng.uniform(-1, 1, env.action_space.shape)
            phases, beams = env.setting(action)
            assert objective_value(user_rates(ch.matrix(phases), beams), "sum") <= bound * (1 + 1e-12)
            half = action.copy()
            half[: -env.M] /= 2  # the same beams' directions at half the amplitude: the same setting
            assert np.allclose(env.setting(half)[1], beams, rtol=0, atol=1e-15)
    silent = np.zeros(env.action_space.shape)  # A = 0: nothing sent
    assert not np.any(env.setting(silent)[1]) and env.step(silent)[1] == 0.0


@pytest.mark.parametrize("kwargs", SMALL, ids=str)
def test_the_ao_setting_as_an_action_reaches_the_ao_value(kwargs):
    env = MISOControlEnv(**kwargs)
    env.reset(seed=5)
    for _ in range(N_SLOTS):
        best = slot_optimum(env.channels[env.slot], env.objective, warm=env.solution)
        _, reward, terminated, _, info = env.step(env.action_of(best.phases, best.beams))
        assert info["optimum"] == best.value
        assert reward >= best.value * (1 - 1e-9)  # (full power: at least AO's, to rounding)
    assert terminated and info["pct_of_optimum"] >= 100 * (1 - 1e-9)


@pytest.mark.parametrize(("antennas", "channel"), [(1, "los"), (2, "los"), (8, "los"), (4, "rician")])
def test_one_user_reaches_the_bound_with_the_observed_phases_and_mrt(antennas, channel):
    """K = 1, a rank-one UAV-surface link (LoS, or Rician with the link scattering, which fades the
    direct row only): the optimum is the aligned phases (the observation's last M features, times
    pi) with MRT, and the bound is that value (Wu & Zhang's closed form)."""
    env = MISOControlEnv(antennas=antennas, users=1, elements=(4, 4), channel=channel)
    obs, _ = env.reset(seed=6)
    for _ in range(N_SLOTS):
        ch = env.channels[env.slot]
        assert np.allclose(obs[-env.M :], wrap(aligned_phases(ch, 0)), rtol=0, atol=1e-6)  # (float32)
        phases = np.pi * obs[-env.M :].astype(np.float64)
        beam = mrt_beam(ch.matrix(phases)[0])[:, None]
        obs, reward, _, _, info = env.step(env.action_of(phases, beam))
        assert reward == pytest.approx(info["bound"], rel=1e-5)  # (float32 phases)
        assert info["optimum"] == pytest.approx(info["bound"], rel=1e-9)  # AO is the closed form


def test_without_the_optimum_the_episode_is_the_same_and_the_ao_keys_are_nan():
    with_ao, without = MISOControlEnv(antennas=2), MISOControlEnv(antennas=2, optimum=False)
    first, second = _episode(with_ao, 8), _episode(without, 8)
    names = ["obs", *INFO_KEYS] + [
        k for _ in range(N_SLOTS) for k in ("obs", "r", "term", "trunc", *INFO_KEYS)
    ]
    for name, x, y in zip(names, first, second, strict=True):
        if name in ("optimum", "mrt_aligned", "zf_aligned", "tdma", "optimum_return", "pct_of_optimum"):
            assert math.isnan(y) and (not math.isnan(x) or name == "zf_aligned"), name
        else:
            assert np.array_equal(x, y), name


def test_seeded_episodes_repeat_bit_for_bit_and_the_env_pickles():
    kwargs = SMALL[1]
    a, b = gym.make(ID, **kwargs), gym.make(ID, **kwargs)
    first, second = _episode(a, 11), _episode(b, 11)
    assert all(np.array_equal(x, y, equal_nan=True) for x, y in zip(first, second, strict=True))
    assert not np.array_equal(first[0], gym.make(ID, **kwargs).reset(seed=12)[0])  # another line
    plain = MISOControlEnv(**kwargs, optimum=False)  # (the AO's repetition is checked above)
    clone = pickle.loads(pickle.dumps(plain))
    pairs = zip(_episode(clone, 13), _episode(plain, 13), strict=True)
    assert all(np.array_equal(x, y, equal_nan=True) for x, y in pairs)


@pytest.mark.parametrize(
    ("mode", "optimum", "channel"),
    [("next_step", False, "los"), ("same_step", True, "los"), ("next_step", False, "rician_element")],
)
def test_batch_row_b_is_the_single_env_seeded_seed_plus_b_across_an_autoreset(mode, optimum, channel):
    kwargs = {"antennas": 2, "users": 2, "elements": (2, 2), "optimum": optimum, "channel": channel}
    B, seed = 3, 20
    vec = gym.make_vec(ID, num_envs=B, vectorization_mode="vector_entry_point", autoreset_mode=mode, **kwargs)
    assert isinstance(vec.unwrapped, MISOControlVectorEnv)
    singles = [MISOControlEnv(**kwargs) for _ in range(B)]
    obs, info = vec.reset(seed=seed)
    rows = [env.reset(seed=seed + b) for b, env in enumerate(singles)]
    for b, (o, i) in enumerate(rows):
        assert np.array_equal(obs[b], o)
        assert all(np.array_equal(info[k][b], i[k], equal_nan=True) for k in INFO_KEYS)
    rng, pending = np.random.default_rng(0), np.zeros(B, dtype=bool)
    for _ in range(N_SLOTS + 3):  # every row ends its episode, then runs on in the next one
        actions = rng.uniform(-1, 1, vec.action_space.shape).astype(np.float32)
        obs, reward, terminated, truncated, info = vec.step(actions)
        assert not truncated.any() and all(info[f"_{k}"].all() for k in INFO_KEYS)
        for b, env in enumerate(singles):
            if pending[b]:  # NEXT_STEP: this step is the row's reset
                (o, i), r, t = env.reset(), 0.0, False
            else:
                o, r, t, _, i = env.step(actions[b])
                if mode == "same_step" and t:
                    assert np.array_equal(info["final_obs"][b], o) and info["_final_obs"][b]
                    assert all(
                        np.array_equal(info["final_info"][k][b], i[k], equal_nan=True) for k in INFO_KEYS
                    )
                    o, i = env.reset()
            assert np.array_equal(obs[b], o) and reward[b] == r and terminated[b] == t
            assert all(np.array_equal(info[k][b], i[k], equal_nan=True) for k in INFO_KEYS)
        pending = terminated & (mode == "next_step")
    vec.close()


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"antennas": 0}, "antennas"), ({"antennas": 9}, "antennas"), ({"antennas": 2.0}, "antennas"),
        ({"antennas": True}, "antennas"), ({"users": 0}, "users"), ({"users": 5}, "users"),
        ({"elements": (1, 2)}, "elements"), ({"elements": (8, 16)}, "elements"),
        ({"elements": 16}, "elements"), ({"objective": "sum_rate"}, "objective"), ({"optimum": 1}, "optimum"),
        ({"channel": "rayleigh"}, "channel"), ({"channel": "link"}, "channel"),
        ({"channel": ["los"]}, "channel"), ({"access": ["noma"]}, "access"), ({"access": "tdma"}, "access"),
    ],
)  # fmt: skip
def test_bad_keywords_are_refused_by_name(kwargs, name):
    with pytest.raises(ValueError, match=rf"^{name} must"):
        gym.make(ID, **kwargs)


def test_bad_actions_and_calls_are_refused():
    env = MISOControlEnv(antennas=2, optimum=False)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(env.action_space.shape))
    env.reset(seed=0)
    for bad in (np.zeros(3), np.full(env.action_space.shape, np.nan)):
        with pytest.raises(ValueError, match="action must be"):
            env.step(bad)
    with pytest.raises(ValueError, match="options"):
        env.reset(options={"config": None})
    vec = MISOControlVectorEnv(2, antennas=2, optimum=False)
    with pytest.raises(RuntimeError, match="reset"):
        vec.step(np.zeros(vec.action_space.shape))
    vec.reset(seed=0)
    with pytest.raises(ValueError, match="actions must"):
        vec.step(np.zeros(env.action_space.shape))
    for bad, name in ((0, "num_envs"), ("later", "autoreset_mode")):
        with pytest.raises(ValueError, match=f"^{name} must"):
            MISOControlVectorEnv(**{name: bad})


@pytest.mark.parametrize("channel", ["rician", "rician_element"])
def test_a_rician_episodes_slots_are_the_models_draws_from_the_envs_generator(channel):
    """reset(seed=s) draws x, then every slot's fading (``miso_fading.rician_slot_channels``) from
    the same generator: the channels are the model's, bit for bit, with the scattering the channel
    names; the LoS channel (the default) draws nothing more and is unchanged."""
    kwargs = {"antennas": 4, "users": 2, "elements": (2, 4), "optimum": False}
    env, los = MISOControlEnv(**kwargs, channel=channel), MISOControlEnv(**kwargs)
    obs, _ = env.reset(seed=3)
    rng = np.random.default_rng(3)
    assert env.positions[0, 0] == rng.uniform(*X_RANGE)
    want = rician_slot_channels(env.config, env.array, env.positions, rng, CHANNELS[channel])
    for got, ref in zip(env.channels, want, strict=True):
        assert all(
            np.array_equal(getattr(got, f), getattr(ref, f)) for f in ("coef", "to_elements", "direct")
        )
        assert got.rank_one == (channel == "rician")
    obs_los, _ = los.reset(seed=3)
    plain = slot_channels(los.config, los.array, los.positions)
    assert all(np.array_equal(a.direct, b.direct) for a, b in zip(los.channels, plain, strict=True))
    assert not np.array_equal(obs, obs_los)  # the faded rows are observed
    steering = [n for n, name in enumerate(env.observation_names) if name.startswith("miso_steering_")]
    assert np.array_equal(obs[steering], obs_los[steering])  # the LoS steering vector, both channels


@pytest.mark.parametrize("channel", ["rician", "rician_element"])
def test_a_rician_episode_repeats_bit_for_bit_and_stays_below_the_bound(channel):
    kwargs = {"antennas": 2, "users": 2, "elements": (2, 2), "channel": channel}
    first, second = _episode(gym.make(ID, **kwargs), 4), _episode(gym.make(ID, **kwargs), 4)
    assert all(np.array_equal(x, y, equal_nan=True) for x, y in zip(first, second, strict=True))
    env = MISOControlEnv(**kwargs)
    env.reset(seed=5)
    rng = np.random.default_rng(6)
    for _ in range(N_SLOTS):
        _, reward, _, _, info = env.step(rng.uniform(-1, 1, env.action_space.shape))
        assert reward <= info["bound"] * (1 + 1e-12) and info["optimum"] <= info["bound"] * (1 + 1e-9)
        assert info["optimum"] >= info["mrt_aligned"] * (1 - 1e-12)


@pytest.mark.parametrize("channel", ["rician", "rician_element"])
def test_gymnasiums_checker_passes_a_rician_channel_without_warnings(channel):
    env = gym.make(ID, antennas=2, users=2, elements=(2, 2), channel=channel)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=True)


def test_a_multi_antenna_flight_refuses_the_rician_channel_naming_the_per_slot_env():
    with pytest.raises(ValueError, match=r"fading 'rician'.*ios_uav_env/MISOControl-v0 \(channel='rician'"):
        gym.make("ios_uav_env/MISOUAV-v0", channel="rician")
