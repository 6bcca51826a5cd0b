"""The STAR surface as the agent's control (``ios_uav_env.envs.star_control``, id
``ios_uav_env/STARControl-v0``): the reward is ``star_slot.evaluate`` of the quantised setting, the
per-slot optimum bounds every action's reward and is reached by its own setting, b-bit phases are
on the grid, seeded episodes repeat bit for bit, bad keywords are refused by name. (The id's
checkers and golden episode: ``test_checkers.py``, ``test_golden.py``.)"""

from __future__ import annotations

import pickle

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env
from ios_uav_env.envs.star_control import INFO_KEYS, N_SLOTS, STARControlEnv
from ios_uav_env.model.star import phase_grid, quantise
from ios_uav_env.model.star_slot import evaluate, slot_optimum

ID = ios_uav_env.STAR_CONTROL_ID
#: Settings that run fast (TDMA is closed form; MS under NOMA a threshold search) and one ES-NOMA.
FAST = [{}, {"bits": 1}, {"bits": 2, "elements": (4, 8), "group": 2}, {"access": "noma", "protocol": "ms"},
        {"access": "noma", "protocol": "ms", "bits": 1}]  # fmt: skip
SLOW = [{"access": "noma", "elements": (4, 4)}, {"access": "noma", "elements": (4, 4), "bits": 2}]


def _episode(env: gym.Env, seed: int, steps: int = N_SLOTS) -> list:
    """Everything ``steps`` seeded random steps from ``reset(seed)`` show."""
    obs, info = env.reset(seed=seed)
    out = [obs, *info.values()]
    rng = np.random.default_rng(seed)
    done = False
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(rng.uniform(-1, 1, env.action_space.shape))
        out += [obs, reward, terminated, *info.values()]
        done = terminated or truncated
        if done:
            break
    return out


def test_the_id_makes_the_env_and_its_info_keys_stay_fixed():
    env = gym.make(ID)
    assert isinstance(env.unwrapped, STARControlEnv) and env.spec.max_episode_steps is None
    _, info = env.reset(seed=0)
    assert tuple(info) == INFO_KEYS and info["pct_of_optimum"] == 0.0
    base = env.unwrapped  # the episode's scenario: the users as nodes, the drawn line as q0 -> qF
    assert base.config.N == N_SLOTS and base.config.nodes == ((-5.0, 2.0), (5.0, -2.0))
    assert base.config.q0 == tuple(base.positions[0]) and base.config.qF == tuple(base.positions[-1])
    for n in range(N_SLOTS):
        _, _, terminated, truncated, info = env.step(env.action_space.sample())
        assert tuple(info) == INFO_KEYS and info["slot"] == n and terminated == (n == N_SLOTS - 1)
        assert not truncated


@pytest.mark.parametrize("kwargs", FAST + SLOW[:1], ids=str)
def test_the_reward_is_evaluate_of_the_quantised_setting_and_never_above_the_optimum(kwargs):
    env = STARControlEnv(**kwargs)
    rng = np.random.default_rng(1)
    for seed in range(1 if kwargs in SLOW else 3):
        env.reset(seed=seed)
        total = best = 0.0
        for _ in range(4 if kwargs in SLOW else N_SLOTS):
            ch = env.channels[env.slot]
            action = rng.uniform(-1, 1, env.action_space.shape)
            setting = env.setting(action)
            expected = evaluate(ch, env.surface, env.access, setting)
            for theta in (setting["theta_r"], setting["theta_t"]):
                assert np.allclose(theta, quantise(theta, env.surface.bits), atol=0)  # on the grid
            _, reward, _, _, info = env.step(action)
            assert reward == min(expected) and (info["rate_r"], info["rate_t"]) == expected
            opt = slot_optimum(ch, env.surface, env.access)
            assert (info["optimum"], info["optimum_upper"]) == (opt.value, opt.upper)
            assert reward <= info["optimum_upper"] * (1 + 1e-12)
            if env.access == "tdma":  # closed form: value == upper
                assert info["optimum"] == info["optimum_upper"]
            total, best = total + reward, best + opt.value
            assert info["return"] == pytest.approx(total, rel=1e-12)
            assert info["pct_of_optimum"] == pytest.approx(100 * total / best, rel=1e-12)
        assert 0 < info["pct_of_optimum"] < 100  # random settings fall short


def test_many_random_settings_stay_below_the_optimum():
    """2000 random actions over every slot of two episodes, TDMA with 1-bit phases and MS-NOMA."""
    rng = np.random.default_rng(2)
    for kwargs in ({"bits": 1, "elements": (4, 4)}, {"access": "noma", "protocol": "ms", "elements": (4, 4)}):
        env = STARControlEnv(**kwargs)
        for seed in (3, 4):
            env.reset(seed=seed)
            for ch in env.channels:
                opt = slot_optimum(ch, env.surface, env.access)
                values = [
                    min(
                        evaluate(
                            ch,
                            env.surface,
                            env.access,
                            env.setting(rng.uniform(-1, 1, env.action_space.shape)),
                        )
                    )
                    for _ in range(60)
                ]
                assert max(values) <= opt.upper * (1 + 1e-12), kwargs


@pytest.mark.parametrize("kwargs", FAST[:2] + [FAST[3]] + SLOW, ids=str)
def test_the_optimums_own_setting_as_an_action_reaches_it(kwargs):
    """Closed form (TDMA: each side aligned, or its exact b-bit phases) to 1e-9; the NOMA
    settings (ES's frontier point, MS's threshold) as well: the action expresses them exactly."""
    env = STARControlEnv(**kwargs)
    env.reset(seed=5)
    steps = 4 if kwargs in SLOW else N_SLOTS  # (ES-NOMA's optimum: ~0.1 s a slot)
    for _ in range(steps):
        opt = slot_optimum(env.channels[env.slot], env.surface, env.access)
        _, reward, terminated, _, info = env.step(env.action_of(opt.setting))
        assert reward == pytest.approx(opt.value, rel=1e-9, abs=1e-15)
    assert terminated == (steps == N_SLOTS) and info["pct_of_optimum"] == pytest.approx(100.0, rel=1e-9)


def test_the_tdma_optimum_is_the_observed_channel_phases():
    """With continuous phases and TDMA the observed group phases are the optimal action."""
    env = STARControlEnv(elements=(4, 4))
    obs, _ = env.reset(seed=6)
    G = env.G
    for _ in range(N_SLOTS):
        share = 1 - obs[7]  # c_t / (c_r + c_t)
        action = np.concatenate([obs[8 : 8 + 2 * G].astype(np.float64), [2 * share - 1]])
        obs, reward, _, _, info = env.step(action)
        assert reward == pytest.approx(info["optimum"], rel=1e-5)  # (float32 features)


@pytest.mark.parametrize("bits", [1, 2, 3])
def test_an_action_between_grid_points_gets_the_grids_value(bits):
    env = STARControlEnv(elements=(4, 4), bits=bits)
    env.reset(seed=0)
    step = 2 / 2**bits  # a level's width in action units (theta = pi a)
    k = np.arange(env.G) % 2**bits
    exact = np.concatenate([-1 + k * step, -1 + k * step, [0.3]])  # theta = -pi + 2 pi k / 2^b
    nudged = exact + np.concatenate([np.full(2 * env.G, 0.4 * step), [0.0]])  # off the grid, nearer k
    far = exact + np.concatenate([np.full(2 * env.G, 0.6 * step), [0.0]])  # nearer k + 1
    grid, level = phase_grid(bits), k + 2 ** (bits - 1)
    assert np.array_equal(env.setting(nudged)["theta_r"], grid[level % 2**bits])
    assert np.array_equal(env.setting(far)["theta_t"], grid[(level + 1) % 2**bits])
    r_exact = env.step(exact)[1]
    env.reset(seed=0)
    assert env.step(nudged)[1] == r_exact


def test_grouped_elements_share_their_settings():
    env = STARControlEnv(elements=(4, 8), group=4, access="noma", protocol="ms")
    env.reset(seed=0)
    setting = env.setting(np.linspace(-0.9, 0.9, env.action_space.shape[0]))
    for key in ("theta_r", "theta_t", "u_t"):
        groups = setting[key].reshape(env.G, 4)
        assert np.all(groups == groups[:, :1]), key
    assert env.G == 8 and env.action_space.shape == (3 * 8 + 1,) and env.observation_space.shape == (8 + 16,)


@pytest.mark.parametrize("kwargs", [{}, {"access": "noma", "protocol": "ms", "bits": 2}], ids=str)
def test_seeded_episodes_repeat_bit_for_bit_and_the_env_pickles(kwargs):
    a, b = gym.make(ID, **kwargs), gym.make(ID, **kwargs)
    first, second = _episode(a, 11), _episode(b, 11)
    assert len(first) == len(second)
    assert all(np.array_equal(x, y) for x, y in zip(first, second, strict=True))
    other = _episode(gym.make(ID, **kwargs), 12)
    assert not np.array_equal(first[0], other[0])  # another seed, another line
    clone = pickle.loads(pickle.dumps(a.unwrapped))
    assert all(
        np.array_equal(x, y) for x, y in zip(_episode(clone, 13), _episode(b.unwrapped, 13), strict=True)
    )


def test_without_channel_phases_the_observation_is_the_geometry():
    env = STARControlEnv(channel_phases=False)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (8,) and env.observation_names[-1] == "star_rate_share_r"


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"elements": (2, 4)}, "elements"), ({"elements": (17, 16)}, "elements"),
        ({"elements": 64}, "elements"), ({"elements": (4.0, 4)}, "elements"),
        ({"bits": 0}, "bits"), ({"bits": 1.5}, "bits"),
        ({"group": 3}, "group"), ({"group": 0}, "group"), ({"group": True}, "group"),
        ({"protocol": "ts"}, "protocol"), ({"protocol": "ms"}, "protocol"), ({"access": "sdma"}, "access"),
        ({"channel_phases": 1}, "channel_phases"),
    ],
)  # fmt: skip
def test_bad_keywords_are_refused_by_name(kwargs, name):
    with pytest.raises(ValueError, match=rf"^{name} must"):
        gym.make(ID, **kwargs)


def test_bad_actions_and_calls_are_refused():
    env = STARControlEnv(elements=(4, 4))
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(env.action_space.shape))
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action must be"):
        env.step(np.zeros(3))
    with pytest.raises(ValueError, match="action must be"):
        env.step(np.full(env.action_space.shape, np.nan))
    with pytest.raises(ValueError, match="options"):
        env.reset(options={"config": None})


def test_the_layout_is_published_and_every_feature_is_known():
    from ios_uav_env.envs.observation_layout import feature_source

    env = gym.make(ID, elements=(4, 8), group=2)
    names = env.unwrapped.observation_names
    obs, _ = env.reset(seed=0)
    assert len(names) == len(set(names)) == obs.shape[0] == 8 + 2 * 16
    assert all(feature_source(n).startswith(ID) for n in names)
    assert feature_source("star_phase_r_0") == f"{ID} with channel_phases=True"


@pytest.mark.parametrize(
    "change",
    [{"elements": (4, 8)}, {"bits": 2}, {"group": 2}, {"access": "noma"}, {"protocol": "ms"},
     {"channel_phases": False}, {"direct_link": True}],
    ids=str,
)  # fmt: skip
def test_every_keyword_changes_the_episode(change):
    base = {"elements": (4, 4)}
    if "protocol" in change:  # (the protocol only with NOMA: MS against ES there)
        base = {**base, "access": "noma"}
    ref = _episode(STARControlEnv(**base), 0, steps=3)
    new = _episode(STARControlEnv(**{**base, **change}), 0, steps=3)
    same = len(ref) == len(new) and all(np.array_equal(x, y) for x, y in zip(ref, new, strict=True))
    assert not same
