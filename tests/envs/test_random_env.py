"""The randomised env (ios_uav_env/envs/random_env.py) and the reset option that pins a scenario
(every id): checkers, seeding, the ranges, the observation's layout and bounds."""

from __future__ import annotations

import math
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import ios_uav_env
from ios_uav_env import (
    DEFAULT_RANGES,
    RANDOM_ENV_ID,
    RandomIOSUAVEnv,
    ScenarioConfig,
    ScenarioRanges,
    check_trajectory,
    sample_scenario,
    slot_rates,
)
from ios_uav_env.envs.core.env import UAVEnv
from ios_uav_env.envs.observation import ground_free_rate_bound
from ios_uav_env.envs.rendering import rate_grid
from ios_uav_env.envs.single import CHANNELS, INSTANCE_NAMES, OBS_NAMES, IOSUAVEnv

DEFAULT = ScenarioConfig()
DRAWN = ("ground_node", "T", "ios_shape", "surface", "q0", "qF")


def run(env: gym.Env, policy, seed: int | None = None, options: dict | None = None) -> dict:
    """One episode; policy(env, obs) -> action."""
    obs, info = env.reset(seed=seed, options=options)
    out = {"obs": [obs], "rewards": [], "infos": [info]}
    done = False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy(env, obs))
        done = terminated or truncated
        out["obs"].append(obs)
        out["rewards"].append(reward)
        out["infos"].append(info)
    out["trajectory"] = env.unwrapped.trajectory
    out["terminated"] = terminated
    out["config"] = env.unwrapped.config
    return out


def away_from_final(env, obs):
    move = env.unwrapped.trajectory[-1] - np.asarray(env.unwrapped.config.qF)
    return move / max(np.hypot(*move), 1e-9)


POLICIES = {
    "away from qF": away_from_final,
    "always (1, 1)": lambda env, obs: np.array([1.0, 1.0], dtype=np.float32),
    "towards G": lambda env, obs: np.asarray(obs[4:6]) * 16.0,
    "random": lambda env, obs: env.unwrapped.np_random.uniform(-1.5, 1.5, 2),
}


def test_registration_and_episode_lengths_follow_the_drawn_horizon():
    assert RANDOM_ENV_ID not in ios_uav_env.ENV_IDS  # the fixed ids' table is unchanged
    env = gym.make(RANDOM_ENV_ID)
    assert isinstance(env.unwrapped, UAVEnv) and env.unwrapped.draws and env.unwrapped.view == "v0"
    assert env.spec.max_episode_steps is None and DEFAULT_RANGES.max_moves == 199
    env.reset(seed=4)
    lengths = set()
    for _ in range(4):
        out = run(env, POLICIES["random"])
        steps = len(out["rewards"])
        assert steps == env.unwrapped.config.N - 1 and out["terminated"] and out["infos"][-1]["feasible"]
        lengths.add(steps)
    assert len(lengths) > 1


# --- seeding ----------------------------------------------------------------------------------
@pytest.mark.parametrize("channel", CHANNELS)
def test_same_seed_same_scenarios_and_rollouts(channel):
    def episodes(seed):
        env = gym.make(RANDOM_ENV_ID, channel=channel, arrival_guard=False)
        actions = iter(np.random.default_rng(9).uniform(-1.5, 1.5, (1000, 2)).astype(np.float32))
        outs = [run(env, lambda e, o: next(actions), seed=seed)]
        outs += [run(env, lambda e, o: next(actions)) for _ in range(2)]  # the stream goes on
        return outs

    a, b = episodes(3), episodes(3)
    for x, y in zip(a, b, strict=True):
        assert x["config"] == y["config"]
        assert all(np.array_equal(p, q) for p, q in zip(x["obs"], y["obs"], strict=True))
        assert x["rewards"] == y["rewards"] and np.array_equal(x["trajectory"], y["trajectory"])
    assert len({o["config"] for o in a}) == 3  # three different scenarios
    assert not np.array_equal(a[0]["obs"][0], episodes(4)[0]["obs"][0])


def test_the_scenario_is_the_seeded_draw():
    env = gym.make(RANDOM_ENV_ID)
    env.reset(seed=11)
    first = env.unwrapped.config
    env.reset()
    second = env.unwrapped.config
    rng = np.random.default_rng(11)
    assert (first, second) == (sample_scenario(rng), sample_scenario(rng))
    assert sample_scenario(123) == sample_scenario(np.random.default_rng(123))


def test_a_fixed_real_range_takes_its_draw_and_a_fixed_integer_one_takes_none():
    """sample_scenario's documented stream: pinning x_G to one point keeps every later draw (a
    uniform draw is still taken), pinning the surface to one kind shifts them (numpy draws nothing
    from a one-value integer range)."""
    free = sample_scenario(3)
    pinned_x = sample_scenario(3, ScenarioRanges(ground_x=(50.0, 50.0)))
    assert pinned_x.ground_node[0] == 50.0 and pinned_x.ground_node[1] == free.ground_node[1]
    assert (pinned_x.q0, pinned_x.qF, pinned_x.T) == (free.q0, free.qF, free.T)
    one_surface = sample_scenario(3, ScenarioRanges(surfaces=(free.surface,)))
    assert one_surface.surface == free.surface and one_surface.ground_node == free.ground_node
    assert one_surface.q0 != free.q0  # the surface's draw was not taken: the ends moved


def test_pickle_round_trip_continues_identically():
    env = RandomIOSUAVEnv()
    env.reset(seed=5)
    actions = np.random.default_rng(1).uniform(-1, 1, (env.config.N - 1, 2))
    for a in actions[:20]:
        env.step(a)
    clone = pickle.loads(pickle.dumps(env))
    for a in actions[20:]:
        out_a, out_b = env.step(a), clone.step(a)
        assert np.array_equal(out_a[0], out_b[0]) and out_a[1:4] == out_b[1:4]
    env.reset()
    clone.reset()
    assert env.config == clone.config


# --- the ranges --------------------------------------------------------------------------------
def test_every_drawn_scenario_is_valid_and_inside_the_ranges():
    rng = np.random.default_rng(0)
    draws = [sample_scenario(rng) for _ in range(2000)]
    default = {k: v for k, v in DEFAULT.to_dict().items() if k not in DRAWN}
    r = DEFAULT_RANGES
    for c in draws:
        assert {k: v for k, v in c.to_dict().items() if k not in DRAWN} == default
        assert r.ground_x[0] <= c.ground_node[0] <= r.ground_x[1]
        assert r.ground_y[0] <= c.ground_node[1] <= r.ground_y[1]
        assert c.T == int(c.T) and 60 <= c.T <= 200
        assert c.ios_shape[0] == 100 and 20 <= c.ios_shape[1] <= 60 and 2000 <= c.M <= 6000
        assert c.surface in ("ios", "ris")
        assert c.q0[0] == -400.0 and c.qF[0] == 400.0 and -100 <= c.q0[1] <= 100 and -100 <= c.qF[1] <= 100
        assert math.dist(c.q0, c.qF) <= math.hypot(800, 200) + 1e-9
        assert c.min_horizon() <= 34.0 < 60.0 <= c.T  # the horizon always allows reaching qF
        assert ScenarioConfig(**c.to_dict()) == c
    ts, rows = {c.T for c in draws}, {c.ios_shape[1] for c in draws}
    assert {60.0, 200.0} <= ts and {20, 60} <= rows  # the end points are drawn too
    assert {c.surface for c in draws} == {"ios", "ris"}
    # the worst case: |qF - q0| = sqrt(800^2 + 200^2) = 824.6 m needs ceil(32.98) = 33 moves, T >= 34 s
    assert ScenarioConfig(q0=(-400, -100), qF=(400, 100)).min_horizon() == 34.0


def test_ranges_validate_and_round_trip():
    assert ScenarioRanges.from_dict(DEFAULT_RANGES.to_dict()) == DEFAULT_RANGES
    custom = ScenarioRanges(T=(100, 100), surfaces=("none",), base=ScenarioConfig(v_max=20.0))
    assert ScenarioRanges.from_dict(custom.to_dict()) == custom
    c = sample_scenario(0, custom)
    assert (c.T, c.surface, c.v_max) == (100.0, "none", 20.0)
    with pytest.raises(ValueError, match="invalid scenario.*too short"):
        ScenarioRanges(T=(30.0, 200.0))  # 29 moves cannot cover 824.6 m
    with pytest.raises(ValueError, match="invalid scenario"):
        ScenarioRanges(ios_rows=(20, 5000))  # the surface would reach above the UAV
    with pytest.raises(ValueError, match="ground_x"):
        ScenarioRanges(ground_x=(10.0, -10.0))
    with pytest.raises(ValueError, match="ios_rows.*integers"):
        ScenarioRanges(ios_rows=(20.5, 60))
    with pytest.raises(ValueError, match="surfaces"):
        ScenarioRanges(surfaces=("ios", "mirror"))
    with pytest.raises(ValueError, match="whole number of slots"):
        ScenarioRanges(T=(60.2, 60.8))


# --- observation ------------------------------------------------------------------------------
def extreme_scenarios() -> list[ScenarioConfig]:
    out = []
    for gx, gy, y0, yf, surface in [(-250, -150, -100, 100, "ios"), (250, 150, 100, -100, "ios"),
                                    (250, -150, 100, 100, "ris"), (0.5, 0.0, -100, -100, "ios"),
                                    (69.3, 0.0, 0.0, 0.0, "ios")]:  # fmt: skip
        for T, rows in ((60.0, 20), (200.0, 60)):
            out.append(DEFAULT.replace(ground_node=(gx, gy), q0=(-400, y0), qF=(400, yf), T=T,
                                       surface=surface, ios_shape=(100, rows)))  # fmt: skip
    return out


@pytest.mark.parametrize("guard", [True, False])
def test_observation_stays_in_the_space_on_extreme_scenarios(guard):
    env = gym.make(RANDOM_ENV_ID, arrival_guard=guard)
    space = env.observation_space
    assert space.shape == (len(OBS_NAMES) + len(INSTANCE_NAMES),) == (17,)
    for cfg in extreme_scenarios():
        for name, policy in POLICIES.items():
            out = run(env, policy, seed=0, options={"config": cfg})
            assert all(o.shape == (17,) and space.contains(o) for o in out["obs"]), (cfg, name)
    # the rate bound of the space holds wherever G is (G at x = sqrt(3) 40 m maximises it)
    for cfg in extreme_scenarios():
        assert ground_free_rate_bound(cfg) <= space.high[10]
        assert rate_grid(cfg, (-150.0, 150.0, -100.0, 100.0), (61, 41))[2].max() <= space.high[10]


def test_observation_layout_extends_the_fixed_one():
    cfg = DEFAULT.replace(
        ground_node=(120.0, -80.0), T=90.0, ios_shape=(100, 45), q0=(-400, 30), qF=(400, -60)
    )
    fixed = IOSUAVEnv(cfg)
    rand = gym.make(RANDOM_ENV_ID)
    steer = POLICIES["towards G"]
    a, b = run(fixed, steer, seed=0), run(rand, steer, seed=0, options={"config": cfg})
    for o_fixed, o_rand in zip(a["obs"], b["obs"], strict=True):
        assert np.array_equal(o_rand[:11], o_fixed)
    assert a["rewards"] == b["rewards"]
    eps = cfg.epsilon
    instance = [45 * 100 / 6000, 1.0, 0.0, eps / (1 + eps), 90 / 200]
    np.testing.assert_allclose(b["obs"][0][11:16], instance, rtol=1e-6)
    seconds_left = [o[16] for o in b["obs"]]
    np.testing.assert_allclose(seconds_left, [(cfg.N - 1 - n) / 200 for n in range(cfg.N)], atol=1e-7)
    ris = run(rand, steer, seed=0, options={"config": cfg.replace(surface="ris")})["obs"][0]
    assert list(ris[12:15]) == [0.0, 1.0, 0.0]
    assert slot_rates(cfg, np.array(cfg.q0))[0] == pytest.approx(float(b["obs"][0][10]), rel=1e-6)


def test_fixed_ids_keep_eleven_features_and_instance_features_are_opt_in():
    assert gym.make("ios_uav_env/IOSUAV-v0").observation_space.shape == (11,)
    env = gym.make("ios_uav_env/IOSUAV-v0", instance_features=True).unwrapped
    assert env.observation_space.shape == (17,)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env)
    assert gym.make(RANDOM_ENV_ID, instance_features=False).observation_space.shape == (11,)


# --- pinning a scenario with reset(options={"config": ...}) -------------------------------------
def pinned_rollout(env, cfg):
    out = run(env, POLICIES["away from qF"], seed=0, options={"config": cfg})
    assert env.unwrapped.config == cfg
    q = out["trajectory"]
    assert q.shape == (cfg.N, 2) and np.array_equal(q[0], cfg.q0)
    assert np.linalg.norm(q[-1] - np.asarray(cfg.qF)) <= 1e-6 and check_trajectory(cfg, q).feasible
    return out


def test_options_pin_the_random_env_then_it_draws_again():
    env = gym.make(RANDOM_ENV_ID)
    cfg = sample_scenario(np.random.default_rng(77))
    pinned_rollout(env, cfg)
    env.reset(options={"config": cfg.to_dict()})  # a dict of the fields works too
    assert env.unwrapped.config == cfg
    env.reset()
    assert env.unwrapped.config != cfg
    paper = ScenarioConfig()  # the paper's scenario is one of the family
    pinned_rollout(env, paper)


def test_config_argument_pins_every_episode():
    cfg = sample_scenario(np.random.default_rng(5))
    env = gym.make(RANDOM_ENV_ID, config=cfg)
    for seed in (0, 1):
        env.reset(seed=seed)
        assert env.unwrapped.config == cfg
    assert env.observation_space == gym.make(RANDOM_ENV_ID).observation_space
    with pytest.raises(ValueError, match="observation space"):
        RandomIOSUAVEnv(config=ScenarioConfig(ios_shape=(100, 200), uav_altitude=150.0))


@pytest.mark.parametrize("env_id", sorted(ios_uav_env.ENV_IDS))
def test_options_pin_the_fixed_ids(env_id):
    env = gym.make(env_id)
    surface = ios_uav_env.ENV_IDS[env_id]["surface"]
    cfg = ScenarioConfig(
        surface=surface, T=80.0, ground_node=(60.0, 40.0), q0=(-300.0, 10.0), qF=(350.0, -30.0)
    )
    pinned_rollout(env, cfg)
    env.reset(seed=0)
    assert env.unwrapped.config == ScenarioConfig(surface=surface)  # back to the id's own scenario
    assert len(run(env, POLICIES["random"])["rewards"]) == ScenarioConfig().N - 1


def test_a_fixed_id_may_be_pinned_to_another_surface_that_fits():
    env = gym.make("ios_uav_env/IOSUAV-v0")
    pinned_rollout(env, ScenarioConfig(surface="ris", T=100.0))
    with pytest.raises(ValueError, match=r"component 10 \(rate\).*make an env on it"):
        gym.make("ios_uav_env/UAV-v0").reset(options={"config": ScenarioConfig(surface="ios")})


@pytest.mark.parametrize(
    ("options", "error", "match"),
    [
        ({"q0": (0, 0)}, ValueError, r'only options=\{"config"'),
        ({"config": DEFAULT, "seed": 1}, ValueError, r"only options=\{\"config\""),
        ("config", ValueError, r"only options"),
        ({"config": 5}, TypeError, r'options\["config"\] must be a ScenarioConfig'),
        ({"config": {"v_maxx": 3}}, TypeError, "v_maxx"),
        ({"config": {"T": 10.0}}, ValueError, "too short"),
        ({"config": DEFAULT.replace(T=300.0)}, ValueError, "does not fit this env's observation space"),
        ({"config": DEFAULT.replace(ground_node=(-4000.0, 0.0))}, ValueError, "ground"),
    ],
)
@pytest.mark.parametrize("env_id", [RANDOM_ENV_ID, "ios_uav_env/IOSUAV-v0"])
def test_bad_options_name_the_problem(env_id, options, error, match):
    env = gym.make(env_id)
    with pytest.raises(error, match=match):
        env.reset(options=options)
    env.reset(options={})  # empty options: no pin
    env.reset(options={"config": None})


def test_drawn_fields_cannot_be_overridden_but_the_others_can():
    with pytest.raises(ValueError, match=r"\['T'\] are drawn from the ranges"):
        gym.make(RANDOM_ENV_ID, T=100.0)
    with pytest.raises(TypeError, match=r"UAVEnv.__init__\(\) got an unexpected keyword argument 'nope'"):
        gym.make(RANDOM_ENV_ID, nope=1)
    env = gym.make(RANDOM_ENV_ID, v_max=20.0, arrival_guard=False)
    env.reset(seed=0)
    assert env.unwrapped.config.v_max == 20.0 and not env.unwrapped.arrival_guard
    narrow = ScenarioRanges(T=(80.0, 90.0))
    env = gym.make(RANDOM_ENV_ID, ranges=narrow)
    env.reset(seed=0)
    assert 80 <= env.unwrapped.config.T <= 90


def test_sb3_vec_env_auto_resets_across_horizons():
    env_util = pytest.importorskip("stable_baselines3.common.env_util")
    vec = env_util.make_vec_env(RANDOM_ENV_ID, n_envs=2, seed=0)
    obs = vec.reset()
    assert obs.shape == (2, 17)
    ends = 0
    for _ in range(420):
        obs, rewards, dones, infos = vec.step(np.zeros((2, 2), dtype=np.float32))
        ends += int(dones.sum())
        assert all(vec.observation_space.contains(o) for o in obs)
    assert ends >= 4
    vec.close()


FOCUS = {"ground_x": (-150.0, 150.0), "ground_y": (-60.0, 60.0)}


def test_focus_mixes_in_narrower_ranges_at_the_given_rate():
    env = RandomIOSUAVEnv(focus=FOCUS, focus_prob=1.0)
    for seed in range(50):
        env.reset(seed=seed)
        x, y = env.unwrapped.config.ground_node
        assert abs(x) <= 150 and abs(y) <= 60
    half = RandomIOSUAVEnv(focus=FOCUS, focus_prob=0.5)
    inside = []
    for seed in range(400):
        half.reset(seed=seed)
        x, y = half.config.ground_node
        inside.append(abs(x) <= 150 and abs(y) <= 60)
    # P(inside) = 0.5 + 0.5 * (300/500) * (120/300) = 0.62; 400 draws: sd 0.024
    assert 0.53 < np.mean(inside) < 0.71
    assert half.observation_space == RandomIOSUAVEnv().observation_space


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"focus": FOCUS, "focus_prob": 0.0}, "it needs focus_prob > 0"),
        ({"focus_prob": 0.5}, "it needs focus=..."),
        ({"focus": FOCUS, "focus_prob": 0.5, "config": ScenarioConfig(T=100.0)}, "focus is never drawn"),
    ],
)
def test_a_focus_that_would_never_be_drawn_is_refused(kwargs, match):
    """focus_prob = 0 (or a pinned config) never draws the focus, and focus_prob without a focus
    has nothing to draw: each would do nothing, so each is refused."""
    with pytest.raises(ValueError, match=match):
        RandomIOSUAVEnv(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"focus": {"ground_x": (-300.0, 0.0)}, "focus_prob": 0.5}, "focus must lie inside ranges"),
        ({"focus": FOCUS, "focus_prob": 1.5}, "focus_prob"),
        ({"focus": {"surfaces": ("none",)}, "focus_prob": 0.5}, "focus must lie inside ranges"),
    ],
)
def test_bad_focus_is_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        RandomIOSUAVEnv(**kwargs)


# --- one way to build the bounds --------------------------------------------------------------
def test_a_fixed_scenario_is_a_family_with_equal_ends():
    from ios_uav_env.envs.observation import check_fits, space_bounds

    config = ScenarioConfig(T=120.0, ground_node=(30.0, -40.0), surface="ris")
    family = ScenarioRanges.from_config(config)
    assert family.fixed_ground and family.slot_range == (config.N, config.N)
    assert sample_scenario(0, family) == config  # its only scenario
    env = IOSUAVEnv(config, peak_hint=True)
    low, high = space_bounds(family, 400.0, False, peak=True)
    assert np.array_equal(env.observation_space.low, low) and np.array_equal(env.observation_space.high, high)
    # a family's space holds each of its scenarios, and check_fits agrees
    random_env = RandomIOSUAVEnv()
    for seed in range(5):
        check_fits(sample_scenario(seed), 400.0, True, random_env.observation_space)
    with pytest.raises(ValueError, match="does not fit"):
        check_fits(config.replace(T=150.0), 400.0, False, IOSUAVEnv(config).observation_space)


@pytest.mark.parametrize(
    "kwargs",
    [
        {},
        {"peak_hint": True},
        {"instance_features": False, "length_scale": 300.0},
        {"objective": "energy_efficiency"},
        {"motion": {"kind": "gauss_markov"}, "knowledge": "reports"},
        {
            "motion": {"kind": "gauss_markov", "speed": 4.0},
            "knowledge": "rates",
            "objective": "energy_efficiency",
        },
        {"focus": {"ground_x": (-150.0, 150.0)}, "focus_prob": 0.5},
    ],
    ids=lambda kw: ",".join(sorted(kw)) or "default",
)
def test_every_scenario_the_env_draws_fits_its_space(kwargs):
    """The env checks a pinned scenario against its space, not its own draws (a reset would pay
    the check each time): the space is built from the family the draws come from, so each draw
    must pass the pinned scenario's check. Many draws of each kind of family, through the env's
    own reset path."""
    env = RandomIOSUAVEnv(**kwargs)
    for seed in range(150):
        cfg = env.begin_episode(seed, None)
        env.check_scenario(cfg, f"draw {seed}")
