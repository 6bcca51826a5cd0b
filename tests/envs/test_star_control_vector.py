"""The STAR control's batched form (``ios_uav_env.envs.star_control_vector``) and its ``control``
and ``optimum`` keywords: row i is ``STARControlEnv`` seeded ``seed + i`` bit for bit across
autoresets, in both autoreset modes; the residual control's zero action is the aligned surface
(the optimum under TDMA with continuous phases); bad keywords and actions are refused by name."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env
from ios_uav_env.envs import star_control_vector
from ios_uav_env.envs.star_control import INFO_KEYS, N_SLOTS, STARControlEnv
from ios_uav_env.envs.star_control_vector import STARControlVectorEnv
from ios_uav_env.model.star import quantise
from tests.envs.test_batched import foreign_private_names

ID = ios_uav_env.STAR_CONTROL_ID
OLD_GYMNASIUM = int(gym.__version__.split(".")[0]) < 1
CASES = [
    {}, {"elements": (4, 4), "bits": 1}, {"elements": (4, 8), "bits": 2, "group": 2, "control": "residual"},
    {"elements": (4, 4), "access": "noma", "protocol": "ms", "control": "residual"},
]  # fmt: skip


def _same(x, y) -> bool:
    x, y = np.asarray(x), np.asarray(y)
    return bool(np.array_equal(x, y, equal_nan=x.dtype.kind == "f"))


def _single_step(env: STARControlEnv, action: np.ndarray, restart: bool) -> tuple:
    """The single env's step, or (NEXT_STEP autoreset) its next episode's start with reward 0."""
    if restart:
        obs, info = env.reset()
        return obs, 0.0, False, info
    obs, reward, terminated, _, info = env.step(action)
    return obs, reward, terminated, info


def _compare(kwargs: dict, same_step: bool, steps: int = N_SLOTS + 4, b: int = 3, seed: int = 9) -> int:
    """Step ``b`` rows and ``b`` single envs with the same actions past an autoreset; every output
    of row i must be the single env's bit for bit. Returns the episodes ended."""
    vec = STARControlVectorEnv(b, autoreset_mode="same_step" if same_step else "next_step", **kwargs)
    singles = [STARControlEnv(**kwargs) for _ in range(b)]
    obs, info = vec.reset(seed=seed)
    for i, env in enumerate(singles):
        first, first_info = env.reset(seed=seed + i)
        assert _same(first, obs[i]) and all(_same(first_info[k], info[k][i]) for k in INFO_KEYS)
    rng, pending, ended = np.random.default_rng(seed), [False] * b, 0
    for _ in range(steps):
        actions = rng.uniform(-1, 1, (b, *vec.single_action_space.shape))
        obs, reward, terminated, truncated, info = vec.step(actions)
        assert not truncated.any() and info["slot"].dtype == np.int64
        for i, env in enumerate(singles):
            one_obs, one_reward, one_done, one_info = _single_step(env, actions[i], pending[i])
            assert one_reward == reward[i] and one_done == terminated[i]
            where = info["final_info"] if same_step and one_done else info
            assert all(_same(one_info[k], where[k][i]) for k in INFO_KEYS), i
            if (
                same_step and one_done
            ):  # SAME_STEP: the last observation under final_obs, the next episode now
                assert _same(one_obs, info["final_obs"][i]) and info["_final_obs"][i]
                one_obs, one_info = env.reset()
                assert all(_same(one_info[k], info[k][i]) for k in INFO_KEYS)
            assert _same(one_obs, obs[i])
            pending[i] = one_done and not same_step
            ended += one_done
    return ended


@pytest.mark.parametrize("kwargs", CASES, ids=str)
def test_row_i_is_the_single_env_seeded_seed_plus_i_across_an_autoreset(kwargs):
    assert _compare(kwargs, same_step=False) == 3


@pytest.mark.parametrize("kwargs", [CASES[1], {"elements": (4, 4), "optimum": False}], ids=str)
def test_same_step_autoreset_keeps_the_last_observation_and_info(kwargs):
    assert _compare(kwargs, same_step=True) == 3


@pytest.mark.skipif(OLD_GYMNASIUM, reason="Gymnasium < 1.0: no vector_entry_point mode")
def test_make_vec_returns_the_batched_form_with_the_envs_spaces():
    vec = gym.make_vec(ID, num_envs=2, vectorization_mode="vector_entry_point", elements=(4, 4), bits=2)
    env = gym.make(ID, elements=(4, 4), bits=2)
    assert isinstance(vec.unwrapped, STARControlVectorEnv)
    assert (
        vec.single_action_space == env.action_space and vec.single_observation_space == env.observation_space
    )
    assert vec.observation_names == env.unwrapped.observation_names


def test_without_the_optimum_its_keys_are_nan_and_the_rest_unchanged():
    with_opt, without = STARControlEnv(elements=(4, 4)), STARControlEnv(elements=(4, 4), optimum=False)
    for env in (with_opt, without):
        env.reset(seed=3)
    action = np.full(with_opt.action_space.shape, 0.2)
    a, b = with_opt.step(action), without.step(action)
    assert _same(a[0], b[0]) and a[1] == b[1] and a[4]["return"] == b[4]["return"]
    assert all(np.isnan(b[4][k]) for k in ("optimum", "optimum_upper", "optimum_return", "pct_of_optimum"))
    assert not np.isnan(a[4]["pct_of_optimum"])


@pytest.mark.parametrize("bits", [None, 1, 2])
def test_the_residual_controls_zero_action_is_the_aligned_surface(bits):
    """Zero: each side's aligned phases (rounded to the grid with b bits) and the aligned share, so
    under TDMA with continuous phases the reward is the optimum; direct control's zero is not."""
    residual = STARControlEnv(elements=(4, 4), bits=bits, control="residual")
    direct = STARControlEnv(elements=(4, 4), bits=bits)
    residual.reset(seed=4)
    direct.reset(seed=4)
    for _ in range(N_SLOTS):
        ch = residual.channels[residual.slot]
        zero = np.zeros(residual.action_space.shape)
        setting = residual.setting(zero)
        assert np.array_equal(setting["theta_r"], quantise(ch.phi_r, bits))
        assert np.array_equal(setting["theta_t"], quantise(ch.phi_t, bits))
        _, reward, _, _, info = residual.step(zero)
        _, other, _, _, _ = direct.step(zero)
        if bits is None:
            assert reward == pytest.approx(info["optimum"], rel=1e-12)
        else:
            assert 0 < reward <= info["optimum"] * (1 + 1e-12)
        assert other < 0.9 * info["optimum"]
    assert info["pct_of_optimum"] > 60  # (1 bit, M = 16: 73 %)


def test_the_optimums_own_setting_as_a_residual_action_reaches_it():
    from ios_uav_env.model.star_slot import slot_optimum

    env = STARControlEnv(elements=(4, 4), bits=2, control="residual")
    env.reset(seed=5)
    for _ in range(N_SLOTS):
        opt = slot_optimum(env.channels[env.slot], env.surface, env.access)
        _, reward, _, _, info = env.step(env.action_of(opt.setting))
        assert reward == pytest.approx(opt.value, rel=1e-9)
    assert info["pct_of_optimum"] == pytest.approx(100.0, rel=1e-9)


def test_bad_arguments_are_refused_by_name():
    with pytest.raises(ValueError, match="^control must be one of"):
        STARControlEnv(control="offset")
    with pytest.raises(ValueError, match="^optimum must be True or False"):
        STARControlEnv(optimum=1)
    with pytest.raises(ValueError, match="^control must be one of"):
        STARControlVectorEnv(2, control="offset")
    with pytest.raises(ValueError, match="num_envs must be an integer >= 1"):
        STARControlVectorEnv(0)
    vec = STARControlVectorEnv(2, elements=(4, 4))
    with pytest.raises(RuntimeError, match="call reset"):
        vec.step(np.zeros((2, 33)))
    vec.reset(seed=0)
    with pytest.raises(ValueError, match="actions must be a finite array of shape"):
        vec.step(np.zeros((2, 32)))
    bad = np.zeros((2, 33))
    bad[1, 3] = np.nan
    with pytest.raises(ValueError, match="actions must be a finite array"):
        vec.step(bad)
    with pytest.raises(NotImplementedError, match="path is given"):
        vec.fly([0], [[0.0, 0.0]], [1])
    with pytest.raises(ValueError, match="options"):
        vec.reset(options={"config": None, "x": 1})


def test_the_batched_form_touches_no_private_name_of_another_object():
    source = Path(star_control_vector.__file__).read_text(encoding="utf-8")
    assert not foreign_private_names(source)
