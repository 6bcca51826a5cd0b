"""The env (ios_uav_env/envs/single.py, guard.py): the checkers, determinism, pickling, the guard,
the reward shaping, and parity with the model's own scoring."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from ios_uav_env import ScenarioConfig, average_rate, check_trajectory, faded_rates, slot_rates
from ios_uav_env.envs.guard import guarded_position, project_to_disks
from ios_uav_env.envs.observation import rate_upper_bound
from ios_uav_env.envs.rendering import rate_grid
from ios_uav_env.envs.single import CHANNELS, INFO_KEYS, OBS_NAMES, IOSUAVEnv

DEFAULT = ScenarioConfig()
D = DEFAULT.D


def rollout(env: IOSUAVEnv, policy, seed: int | None = 0) -> dict:
    """Run one episode; policy(env) -> action. Returns everything the env gave back."""
    obs, info = env.reset(seed=seed)
    out = {"obs": [obs], "rewards": [], "infos": [info]}
    terminated = False
    while not terminated:
        obs, reward, terminated, truncated, info = env.step(policy(env))
        assert not truncated
        out["obs"].append(obs)
        out["rewards"].append(reward)
        out["infos"].append(info)
    out["trajectory"] = env.trajectory
    return out


def towards(point):
    def policy(env):
        move = (np.asarray(point, dtype=float) - env.trajectory[-1]) / env.config.D
        return move / max(1.0, float(np.hypot(*move)))

    return policy


def away_from_final(env):
    move = env.trajectory[-1] - np.asarray(env.config.qF)
    return move / np.hypot(*move)


# --- spaces and observation -------------------------------------------------------------------
def test_spaces_and_observation_layout():
    env = IOSUAVEnv(length_scale=400.0)
    assert env.action_space.shape == (2,) and env.action_space.dtype == np.float32
    assert np.all(env.action_space.low == -1) and np.all(env.action_space.high == 1)
    assert env.observation_space.shape == (len(OBS_NAMES),) and env.observation_space.dtype == np.float32
    obs, info = env.reset(seed=0)
    (x0, y0), (xf, yf), (xg, yg) = DEFAULT.q0, DEFAULT.qF, DEFAULT.ground_node
    s = (DEFAULT.N - 1) - math.dist(DEFAULT.q0, DEFAULT.qF) / D
    r0 = slot_rates(DEFAULT, np.array(DEFAULT.q0))[0]
    expected = [x0, y0, xf - x0, yf - y0, xg - x0, yg - y0, -x0, -y0]
    expected = [v / 400.0 for v in expected] + [1.0, s / (1 + s), r0]
    np.testing.assert_allclose(obs, expected, rtol=1e-6)
    assert info["slot"] == 1 and info["rate"] == pytest.approx(r0, rel=1e-12)
    assert info["distance_to_final"] == pytest.approx(800.0)
    assert rate_upper_bound(env.kernel) >= slot_rates(DEFAULT, np.array([[100.0, 0.0], [-100, -20]])).max()


@pytest.mark.parametrize("policy", [away_from_final, lambda env: np.array([1.0, 1.0])])
def test_observations_stay_in_bounds_without_the_guard(policy):
    env = IOSUAVEnv(arrival_guard=False, T=300.0)
    out = rollout(env, policy)
    assert all(env.observation_space.contains(o) for o in out["obs"])
    assert out["obs"][-1][9] < -0.99  # the slack says qF is hopelessly out of reach


def test_slack_and_time_left_at_the_end_with_the_guard():
    env = IOSUAVEnv()
    out = rollout(env, towards((100.0, 0.0)))
    last = out["obs"][-1]
    assert last[8] == 0.0 and last[9] == 0.0 and abs(last[2]) < 1e-9
    assert all(-1e-9 <= o[9] for o in out["obs"])  # with the guard qF never goes out of reach


# --- validation ------------------------------------------------------------------------------
@pytest.mark.parametrize("bad", [[np.nan, 0.0], [0.0, np.inf], np.array([np.nan, 1.0], dtype=np.float32)])
def test_non_finite_action_is_refused(bad):
    env = IOSUAVEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(bad)


@pytest.mark.parametrize("bad", [np.zeros(3), np.zeros((1, 2)), 0.5, "up"])
def test_wrong_action_shape_is_refused(bad):
    env = IOSUAVEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"action must"):
        env.step(bad)


def test_bad_arguments_name_themselves():
    with pytest.raises(ValueError, match="channel.*'expected', 'rician'"):
        IOSUAVEnv(channel="rayleigh")
    # Python's own wording: TorchRL retries without its keywords only on this message
    with pytest.raises(
        TypeError, match=r"^IOSUAVEnv.__init__\(\) got an unexpected keyword argument 'frameskip'$"
    ):
        IOSUAVEnv(frameskip=1)
    with pytest.raises(ValueError, match="render_mode"):
        IOSUAVEnv(render_mode="human")
    with pytest.raises(ValueError, match="terminal_weight"):
        IOSUAVEnv(terminal_weight=-1.0)
    with pytest.raises(ValueError, match="length_scale"):
        IOSUAVEnv(length_scale=0.0)
    with pytest.raises(ValueError, match="options"):
        IOSUAVEnv().reset(options={"q0": (0, 0)})


def test_config_and_overrides():
    env = IOSUAVEnv(ScenarioConfig(T=60.0), surface="ris", v_max=30.0)
    assert env.config == ScenarioConfig(T=60.0, surface="ris", v_max=30.0)
    assert IOSUAVEnv({"T": 40.0}).config.N == 40


def test_step_before_reset_and_after_the_end():
    env = IOSUAVEnv(T=40.0)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(2))
    rollout(env, lambda env: np.zeros(2))
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(2))


# --- determinism and pickling ----------------------------------------------------------------
def _actions(seed: int, n: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1.5, 1.5, (n, 2)).astype(np.float32)


@pytest.mark.parametrize("channel", CHANNELS)
@pytest.mark.parametrize("guard", [True, False])
def test_seeded_rollouts_match_exactly(channel, guard):
    def replay(actions):
        moves = iter(actions)
        return lambda env: next(moves)

    actions = _actions(7, DEFAULT.N - 1)
    runs = [rollout(IOSUAVEnv(channel=channel, arrival_guard=guard), replay(actions), seed=3) for _ in "ab"]
    a, b = runs
    assert all(np.array_equal(x, y) for x, y in zip(a["obs"], b["obs"], strict=True))
    assert a["rewards"] == b["rewards"]
    assert [i["rate"] for i in a["infos"]] == [i["rate"] for i in b["infos"]]
    for x, y in zip(a["infos"], b["infos"], strict=True):
        assert x.keys() == y.keys() and all(np.array_equal(x[k], y[k]) for k in x)
    assert np.array_equal(a["trajectory"], b["trajectory"])


def test_rician_rates_follow_the_seed_and_expected_ones_do_not():
    rates = {}
    for channel in CHANNELS:
        for seed in (1, 2):
            out = rollout(IOSUAVEnv(channel=channel), towards((100.0, 0.0)), seed=seed)
            rates[channel, seed] = [i["rate"] for i in out["infos"]]
    assert rates["expected", 1] == rates["expected", 2]
    assert rates["rician", 1] != rates["rician", 2]
    assert rates["rician", 1][5] != rates["expected", 1][5]


@pytest.mark.parametrize("channel", CHANNELS)
def test_pickle_round_trip_continues_identically(channel):
    actions = _actions(11, DEFAULT.N - 1)
    env = IOSUAVEnv(channel=channel)
    env.reset(seed=5)
    for a in actions[:40]:
        env.step(a)
    clone = pickle.loads(pickle.dumps(env))
    for a in actions[40:]:
        out_a, out_b = env.step(a), clone.step(a)
        assert np.array_equal(out_a[0], out_b[0]) and out_a[1:4] == out_b[1:4]
        assert out_a[4]["rate"] == out_b[4]["rate"] and out_a[4]["average_rate"] == out_b[4]["average_rate"]
    assert np.array_equal(env.trajectory, clone.trajectory)


# --- the arrival guard ------------------------------------------------------------------------
ADVERSARIES = {
    "away from qF": away_from_final,
    "always (1, 1)": lambda env: np.array([1.0, 1.0], dtype=np.float32),
    "large random": lambda env: env.np_random.uniform(-50, 50, 2),
    "stay put": lambda env: np.zeros(2),
    "towards G": towards(DEFAULT.ground_node),
}


@pytest.mark.parametrize("name", sorted(ADVERSARIES))
@pytest.mark.parametrize("T", [DEFAULT.min_horizon(), DEFAULT.min_horizon() + 1, 150.0, 600.0])
def test_guard_makes_any_action_sequence_feasible(name, T):
    env = IOSUAVEnv(T=T, surface="ris")
    out = rollout(env, ADVERSARIES[name], seed=0)
    q = out["trajectory"]
    assert q.shape == (env.config.N, 2)
    assert np.linalg.norm(q[-1] - np.asarray(DEFAULT.qF)) <= 1e-6
    assert np.linalg.norm(np.diff(q, axis=0), axis=1).max() <= D + 1e-9
    report = check_trajectory(env.config, q)
    assert report.feasible and out["infos"][-1]["feasible"]
    assert out["infos"][-1]["terminal_miss"] == report.end_error == 0.0
    penalties = [i[f"reward_{k}"] for i in out["infos"][1:] for k in ("reach", "terminal")]
    assert all(p == 0.0 for p in penalties)


def test_projection_onto_two_disks_is_the_nearest_feasible_point():
    rng = np.random.default_rng(0)
    for _ in range(300):
        a, b = rng.uniform(-3, 3, 2), rng.uniform(-3, 3, 2)
        ra, rb = rng.uniform(0.2, 3, 2)
        if np.linalg.norm(a - b) > ra + rb:
            continue
        t = rng.uniform(-6, 6, 2)
        p = np.array(project_to_disks(tuple(t), tuple(a), ra, tuple(b), rb))
        assert np.linalg.norm(p - a) <= ra + 1e-9 and np.linalg.norm(p - b) <= rb + 1e-9
        if np.linalg.norm(t - a) <= ra and np.linalg.norm(t - b) <= rb:
            assert np.array_equal(p, t)
            continue
        # brute force: t is outside, so its nearest feasible point is on the boundary of the
        # intersection: the arcs of each circle that lie inside the other disk
        ang = np.linspace(0, 2 * np.pi, 20001)[:, None]
        ring = np.hstack([np.cos(ang), np.sin(ang)])
        arcs = np.vstack([a + ra * ring, b + rb * ring])
        inside = (np.linalg.norm(arcs - a, axis=1) <= ra + 1e-12) & (
            np.linalg.norm(arcs - b, axis=1) <= rb + 1e-12
        )
        nearest = np.linalg.norm(arcs[inside] - t, axis=1).min()
        assert nearest - 2e-3 <= np.linalg.norm(p - t) <= nearest + 1e-9  # 2e-3: the arcs' sampling


def test_guarded_position_keeps_points_inside_and_lands_on_the_final_point():
    assert guarded_position((0.0, 0.0), (5.0, 5.0), (30.0, 0.0), 25.0, 0) == (30.0, 0.0)
    assert guarded_position((0.0, 0.0), (3.0, 4.0), (100.0, 0.0), 25.0, 10) == (3.0, 4.0)
    x, y = guarded_position((0.0, 0.0), (-25.0, 0.0), (50.0, 0.0), 25.0, 1)  # must go towards qF
    assert x == pytest.approx(25.0) and y == pytest.approx(0.0, abs=1e-6)


# --- rewards without the guard ----------------------------------------------------------------
def test_shaping_makes_arrival_pay():
    # the same greed for the best-rate point, once with the guard's way out replayed (arrives)
    guarded = rollout(IOSUAVEnv(), towards((100.0, 0.0)))["trajectory"]
    moves = iter(np.diff(guarded, axis=0) / D)
    arrive = rollout(IOSUAVEnv(arrival_guard=False), lambda env: next(moves))
    hover = rollout(IOSUAVEnv(arrival_guard=False), towards((100.0, 0.0)))  # never leaves
    flee = rollout(IOSUAVEnv(arrival_guard=False), away_from_final)
    assert arrive["infos"][-1]["feasible"] and not hover["infos"][-1]["feasible"]
    assert sum(arrive["rewards"]) > sum(hover["rewards"]) + 50 > sum(flee["rewards"])
    hover_rates = sum(i["reward_rate"] for i in hover["infos"][1:])
    assert hover_rates > sum(arrive["rewards"])  # without the shaping, not arriving would pay
    for out in (flee, hover):
        last = out["infos"][-1]
        assert last["reward_terminal"] < 0 and last["terminal_miss"] > 1.0
        assert any(i["reward_reach"] < 0 for i in out["infos"][1:])
    assert all(i["reward_reach"] == 0 and i["reward_terminal"] == 0 for i in arrive["infos"][1:])


def test_penalty_terms_follow_the_documented_equations():
    w_reach, w_term = 0.5, 3.0
    out = rollout(
        IOSUAVEnv(arrival_guard=False, reach_weight=w_reach, terminal_weight=w_term), lambda env: np.zeros(2)
    )
    for k, info in enumerate(out["infos"][1:], start=1):
        left = DEFAULT.N - 1 - k
        excess = max(0.0, info["distance_to_final"] - left * D - 1e-6) / D
        assert info["reward_reach"] == pytest.approx(-w_reach * excess, rel=1e-12, abs=0)
        terms = info["reward_rate"] + info["reward_reach"] + info["reward_terminal"]
        assert out["rewards"][k - 1] == pytest.approx(terms, rel=1e-12)
    miss = (800.0 - 1e-6) / D
    assert out["infos"][-1]["reward_terminal"] == pytest.approx(-w_term * (miss + math.sqrt(miss)))


def test_default_weights_make_any_final_miss_cost_more_than_it_can_win():
    # a final miss of d metres wins at most (steepest rate slope) x d in the last slot's rate
    xs, ys, rates = rate_grid(DEFAULT, (-450.0, 450.0, -250.0, 250.0), (451, 251))
    grad_y, grad_x = np.gradient(rates, ys, xs)
    slope = 1.5 * np.hypot(grad_x, grad_y).max()  # bps/Hz per m, with a margin for the grid
    env = IOSUAVEnv(arrival_guard=False)
    for miss in np.geomspace(1e-4, 1e3, 29):
        e = miss / D  # the last step's reach term is e too
        cost = env.options.reach_weight * e + env.options.terminal_weight * (e + math.sqrt(e))
        assert cost > slope * miss


# --- parity with the model's scoring ----------------------------------------------------------
def test_rate_terms_sum_to_the_average_rate_and_info_matches_the_model():
    env = IOSUAVEnv()
    out = rollout(env, towards((100.0, 0.0)))
    last = out["infos"][-1]
    r0 = slot_rates(DEFAULT, np.array(DEFAULT.q0))[0]
    assert last["average_rate"] == pytest.approx(average_rate(DEFAULT, out["trajectory"]), rel=1e-13)
    rates = sum(i["reward_rate"] for i in out["infos"][1:])
    assert rates == pytest.approx(DEFAULT.N * last["average_rate"] - r0, abs=1e-9)
    assert sum(out["rewards"]) == pytest.approx(rates, abs=1e-12)  # the guard: no penalties
    positions = np.array([i["position"] for i in out["infos"]])
    assert np.array_equal(positions, out["trajectory"])
    assert [i["slot"] for i in out["infos"]] == list(range(1, DEFAULT.N + 1))


def test_replaying_a_straight_line_reproduces_its_average_rate():
    line = np.linspace(DEFAULT.q0, DEFAULT.qF, DEFAULT.N)
    moves = iter(np.diff(line, axis=0) / D)  # float64 actions, used as given
    out = rollout(IOSUAVEnv(arrival_guard=False), lambda env: next(moves))
    assert np.abs(out["trajectory"] - line).max() < 1e-9
    assert out["infos"][-1]["average_rate"] == pytest.approx(average_rate(DEFAULT, line), abs=1e-9)
    assert out["infos"][-1]["feasible"]


def test_rician_samples_are_the_models_faded_rates():
    env = IOSUAVEnv(channel="rician")
    env.reset(seed=9)
    rng = np.random.default_rng(123)
    env.np_random = np.random.default_rng(123)
    _, _, _, _, info = env.step(np.array([0.6, -0.8]))
    q = env.trajectory[-1]
    assert info["rate"] == pytest.approx(faded_rates(DEFAULT, q, rng)[0], rel=1e-10)
    assert info["expected_rate"] == pytest.approx(slot_rates(DEFAULT, q)[0], rel=1e-12)


def test_rician_mean_rate_is_near_the_expected_rate():
    # E log2(1 + eta |h|^2) <= log2(1 + eta E|h|^2) (Jensen), and close to it at kappa = 3
    faded, expected = [], []
    for seed in range(4):
        out = rollout(IOSUAVEnv(channel="rician"), towards((100.0, 0.0)), seed=seed)
        faded.append(out["infos"][-1]["mean_faded_rate"])
        expected.append(out["infos"][-1]["average_rate"])
        assert out["infos"][-1]["mean_faded_rate"] == pytest.approx(
            np.mean([i["rate"] for i in out["infos"]]), rel=1e-12
        )
    assert np.ptp(expected) == 0.0 and np.ptp(faded) > 0.0
    assert 0.8 * expected[0] < np.mean(faded) < expected[0]


# --- info: fixed keys, numbers only, the running score and check ------------------------------
@pytest.mark.parametrize("guard", [True, False])
@pytest.mark.parametrize("channel", CHANNELS)
def test_info_has_the_same_numeric_keys_on_every_step(guard, channel):
    out = rollout(IOSUAVEnv(T=60.0, arrival_guard=guard, channel=channel), away_from_final)
    for info in out["infos"]:
        assert tuple(info) == INFO_KEYS
        values = np.concatenate([np.atleast_1d(np.asarray(v, dtype=float)) for v in info.values()])
        assert np.all(np.isfinite(values))
        assert np.asarray(info["position"]).shape == (2,)


@pytest.mark.parametrize("policy", [away_from_final, towards((100.0, 0.0)), lambda env: np.zeros(2)])
def test_info_running_check_ends_as_the_trajectory_check(policy):
    for guard in (True, False):
        out = rollout(IOSUAVEnv(T=60.0, arrival_guard=guard), policy)
        report = check_trajectory(ScenarioConfig(T=60.0), out["trajectory"])
        last = out["infos"][-1]
        assert last["feasible"] == report.feasible
        assert last["terminal_miss"] == pytest.approx(report.end_error, abs=1e-9)
        assert last["worst_violation"] == pytest.approx(report.worst_violation, abs=1e-9)
        # before the end: feasible so far means qF is still within reach
        for info, obs in zip(out["infos"], out["obs"], strict=True):
            assert info["feasible"] == (info["worst_violation"] <= 1e-6)
            assert (info["terminal_miss"] > 1e-6) == (obs[9] < -1e-7 / D)


def test_info_average_rate_is_the_running_mean_of_the_way_points():
    out = rollout(IOSUAVEnv(T=60.0), towards((100.0, 0.0)))
    for k, info in enumerate(out["infos"], start=1):
        q = out["trajectory"][:k]
        assert info["average_rate"] == pytest.approx(float(np.mean(slot_rates(DEFAULT, q))), rel=1e-12)
        assert info["mean_faded_rate"] == info["average_rate"]


def test_ids_have_no_time_limit_and_end_at_slot_n():
    import gymnasium as gym

    env = gym.make("ios_uav_env/IOSUAV-v0", T=300)
    assert env.spec.max_episode_steps is None
    out = rollout(env.unwrapped, lambda env: np.zeros(2))
    assert len(out["rewards"]) == 299 and out["infos"][-1]["slot"] == 300


def test_info_values_are_numpy_numbers_with_a_dtype():
    # TorchRL's default_info_dict_reader reads ``value.dtype``: plain Python floats break it
    env = IOSUAVEnv(T=40.0)
    _, info = env.reset(seed=0)
    _, _, _, _, step_info = env.step(np.zeros(2))
    for i in (info, step_info):
        assert all(hasattr(v, "dtype") for v in i.values())
        assert i["slot"].dtype == np.int64 and i["feasible"].dtype == np.bool_
    assert info["position"] is not step_info["position"] and step_info["slot"] == 2
