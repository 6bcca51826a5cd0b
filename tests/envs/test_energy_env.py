"""The energy ids (objective "energy_efficiency"): info's power, energy and EE against the model,
the reward's relation to EE (Dinkelbach's parametric objective), the v0 ids unchanged, seeding,
the batched form row for row, the checkers."""

from __future__ import annotations

import pickle

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env
from ios_uav_env import ENERGY_ID, ENERGY_IDS, ENERGY_RANDOM_ID, ScenarioConfig, propulsion_power, score_plan
from ios_uav_env.envs.core.env import UAVEnv
from ios_uav_env.envs.core.vector import UAVVectorEnv
from ios_uav_env.envs.observation import (
    ENERGY_NAMES,
    hover_flight,
    loiter_efficiency,
    min_power_move,
    optimistic_efficiency,
    reference_efficiency,
)
from ios_uav_env.envs.policies import HoverAt
from ios_uav_env.envs.random_env import RandomIOSUAVEnv
from ios_uav_env.envs.rollout import run_episode
from ios_uav_env.envs.single import INFO_KEYS, OBS_NAMES, IOSUAVEnv
from ios_uav_env.envs.single_vector import IOSUAVVectorEnv, RandomIOSUAVVectorEnv
from ios_uav_env.model.peak import rate_peak

SHORT = ScenarioConfig(T=40.0, objective="energy_efficiency")  # 39 moves; |qF - q0| = 800 m = 32 D
RTOL = 1e-12  # float64 sums of the same terms in another order (numba's fastmath)


def play(env: gym.Env, actions, seed: int | None = 0) -> dict:
    """One episode of ``env`` on the action sequence ``actions`` (cycled)."""
    obs, info = env.reset(seed=seed)
    out = {"obs": [obs], "rewards": [], "infos": [info]}
    done, n = False, 0
    while not done:
        obs, reward, terminated, truncated, info = env.step(actions[n % len(actions)])
        out["obs"].append(obs)
        out["rewards"].append(reward)
        out["infos"].append(info)
        done, n = terminated or truncated, n + 1
    out["trajectory"] = env.unwrapped.trajectory
    return out


def moves_of(config: ScenarioConfig, trajectory: np.ndarray) -> np.ndarray:
    """The actions that replay ``trajectory`` (moves / D)."""
    return np.diff(trajectory, axis=0) / config.D


# --- info against the model ---------------------------------------------------------------
@pytest.mark.parametrize("guard", [True, False])
def test_power_energy_and_ee_in_info_are_the_models(guard):
    env = IOSUAVEnv(SHORT, arrival_guard=guard, channel="rician")
    actions = np.random.default_rng(3).uniform(-1.3, 1.3, (SHORT.N - 1, 2))
    out = play(env, actions, seed=4)
    q = out["trajectory"]
    assert q.shape == (SHORT.N, 2)
    speeds = np.linalg.norm(np.diff(q, axis=0), axis=1) / SHORT.dt
    power = propulsion_power(speeds, SHORT.propulsion)
    infos = out["infos"]
    assert infos[0]["power"] == 0.0 and infos[0]["energy"] == 0.0 and infos[0]["energy_efficiency"] == 0.0
    np.testing.assert_allclose([i["power"] for i in infos[1:]], power, rtol=RTOL)
    np.testing.assert_allclose([i["energy"] for i in infos[1:]], SHORT.dt * np.cumsum(power), rtol=RTOL)
    score = score_plan(SHORT, q)
    last = infos[-1]
    assert last["energy"] == pytest.approx(score.energy, rel=RTOL)
    assert last["energy_efficiency"] == pytest.approx(score.energy_efficiency, rel=RTOL)
    assert last["energy_efficiency"] == pytest.approx(score.objective_value, rel=RTOL)
    # every step: the four weighted terms sum to the reward; the energy term is -(lambda_ref / B) P
    cost = env.reference_efficiency / SHORT.bandwidth_hz
    for info, reward in zip(infos[1:], out["rewards"], strict=True):
        assert info["reward_energy"] == pytest.approx(-cost * info["power"], rel=RTOL)
        terms = info["reward_rate"] + info["reward_energy"] + info["reward_reach"] + info["reward_terminal"]
        assert reward == pytest.approx(terms, rel=1e-12, abs=1e-12)
        assert tuple(info) == INFO_KEYS


def test_run_episode_scores_the_energy_efficiency():
    env = gym.make(ENERGY_ID, T=40.0, peak_hint=True)
    episode = run_episode(env, HoverAt("peak"), seed=0)
    score = score_plan(env.unwrapped.config, episode.trajectory)
    assert episode.feasible and episode.steps == SHORT.N - 1
    assert episode.energy == score.energy and episode.energy_efficiency == score.energy_efficiency
    assert episode.score == episode.objective_value == score.energy_efficiency
    rate_env = gym.make("ios_uav_env/IOSUAV-v0", T=40.0, peak_hint=True)
    rate_episode = run_episode(rate_env, HoverAt("peak"), seed=0)
    assert rate_episode.score == rate_episode.average_rate  # the rate ids' score is unchanged
    assert rate_episode.energy == pytest.approx(episode.energy, rel=RTOL)  # the same flight


def test_return_is_dinkelbachs_parametric_objective():
    """With the guard (no penalty) the return is (B dt sum_n r(q[n]) - lambda_ref E) / (B dt) - r(q0)."""
    env = IOSUAVEnv(SHORT)
    out = play(env, np.random.default_rng(0).uniform(-1, 1, (50, 2)))
    q, lam = out["trajectory"], env.reference_efficiency
    score = score_plan(SHORT, q)
    bits = SHORT.bandwidth_hz * SHORT.T * score.rate
    scale = SHORT.bandwidth_hz * SHORT.dt
    expected = (bits - lam * score.energy) / scale - out["infos"][0]["expected_rate"]
    assert sum(out["rewards"]) == pytest.approx(expected, rel=1e-12)


def test_reference_is_the_hover_plans_ee_below_the_best_and_the_optimistic_bound():
    dp_energy = pytest.importorskip("baselines.dp_energy")
    for config in (SHORT, SHORT.replace(surface="ris", T=50.0)):
        env = gym.make(ENERGY_ID, config=config, surface=config.surface, peak_hint=True)
        env.reset(seed=0)
        lam = env.unwrapped.reference_efficiency
        # the env's own hover plan (HoverAt reads P from the float32 observation: ~1e-5 m)
        episode = run_episode(env, HoverAt("peak"), seed=0)
        np.testing.assert_allclose(hover_flight(config), episode.trajectory, rtol=0, atol=1e-4)
        # score_plan's EE of the hover flight, to rounding: the env computes it in compiled kernels
        # (hover_reference.flight_efficiency: ordered sums of the compiled rates, ~1e-15 relative)
        assert lam == reference_efficiency(config)
        assert lam == pytest.approx(score_plan(config, hover_flight(config)).energy_efficiency, rel=1e-12)
        assert lam == pytest.approx(episode.energy_efficiency, rel=1e-6) and episode.feasible
        best = dp_energy.solve_ee(config, resolution=5.0).info["lambda"]  # EE* on the DP grid
        model = config.propulsion
        p_min = propulsion_power(ios_uav_env.min_power_speed(model), model)
        upper = config.bandwidth_hz * config.N * rate_peak(config).rate / ((config.N - 1) * p_min)
        assert optimistic_efficiency(config) == pytest.approx(upper, rel=RTOL)
        assert lam < best < upper
    fixed = IOSUAVEnv(SHORT, energy_reference=1234.5)
    assert fixed.reference_efficiency == 1234.5


def test_the_loiter_reference_is_the_loiter_flights_ee_above_hovering_below_the_best():
    """energy_reference="loiter": lambda_ref is the better EE of the loiter heuristic's flight (the
    one implementation baselines.loiter flies) and the hover plan's: at most EE*, at least the
    default reference; the space is the default reference's (both are feasible plans' EE)."""
    from ios_uav_env.envs.loiter_flight import loiter_path

    dp_energy = pytest.importorskip("baselines.dp_energy")
    loiter = pytest.importorskip("baselines.loiter")
    assert loiter.loiter_path is loiter_path
    lams = []
    for config in (SHORT, SHORT.replace(surface="ris", T=50.0), SHORT.replace(T=150.0)):
        env = IOSUAVEnv(config, energy_reference="loiter")
        env.reset(seed=0)
        lam = env.unwrapped.reference_efficiency
        plan = loiter.loiter(config)
        assert plan.feasible and lam == loiter_efficiency(config)
        assert lam == max(plan.energy_efficiency, reference_efficiency(config))
        best = dp_energy.solve_ee(config, resolution=5.0).info["lambda"]
        assert reference_efficiency(config) <= lam <= best * (1 + 1e-9)
        lams.append(lam / reference_efficiency(config))
        assert env.observation_space == IOSUAVEnv(config).observation_space
    assert max(lams) > 1.2  # on the long horizon loitering is far better than hovering
    drawn = RandomIOSUAVEnv(objective="energy_efficiency", energy_reference="loiter")
    drawn.reset(seed=3)
    assert drawn.reference_efficiency == loiter_efficiency(drawn.config)


def plans(config: ScenarioConfig) -> list[np.ndarray]:
    """A handful of feasible plans of ``config``: the guard's flights of a few action sequences
    (straight on, hover at the peak, loiters at about the minimum-power speed, random)."""
    env = IOSUAVEnv(config, peak_hint=True)
    out = [play(env, [np.array([1.0, 0.0])])["trajectory"]]
    out.append(run_episode(env, HoverAt("peak"), seed=0).trajectory)
    step = min_power_move(config)
    for sides in (2, 3, 6):  # circles of `sides` moves of V_mp dt, after flying to the peak
        turn = [
            step * np.array([np.cos(2 * np.pi * k / sides), np.sin(2 * np.pi * k / sides)])
            for k in range(sides)
        ]
        peak = np.array(rate_peak(config)[:2])
        approach = int(np.ceil(np.linalg.norm(peak - np.array(config.q0)) / config.D))
        head = (peak - np.array(config.q0)) / (approach * config.D)
        out.append(play(env, [head] * approach + turn * config.N)["trajectory"])
    for seed in range(3):
        out.append(play(env, np.random.default_rng(seed).uniform(-1, 1, (config.N, 2)))["trajectory"])
    return out


def test_return_ranks_plans_as_ee_at_the_best_ee():
    """At lambda_ref = the best EE of a set of plans, the return's argmax is the EE argmax, and a
    plan's return (+ r(q0)) is >= 0 only for it; at any lambda_ref below it the return's argmax
    has EE >= lambda_ref (the bound of IOSUAVEnv's docstring)."""
    config = SHORT.replace(T=60.0)
    flights = plans(config)
    ee = np.array([score_plan(config, q).energy_efficiency for q in flights])
    assert len(set(ee.round(6))) == len(flights)  # distinct plans
    best = int(np.argmax(ee))
    default = IOSUAVEnv(config).reference_efficiency  # the hover plan's EE, one of the plans
    assert default == pytest.approx(ee[1], rel=1e-6)  # HoverAt reads P in float32
    for lam in (ee[best], 0.9 * ee[best], 0.5 * ee[best], default):
        env = IOSUAVEnv(config, arrival_guard=False, energy_reference=float(lam))
        returns = []
        for q in flights:
            out = play(env, moves_of(config, q))
            np.testing.assert_allclose(out["trajectory"], q, atol=1e-9)
            assert all(i["reward_reach"] == 0 and i["reward_terminal"] == 0 for i in out["infos"][1:])
            returns.append(sum(out["rewards"]) + out["infos"][0]["expected_rate"])
        top = int(np.argmax(returns))
        assert ee[top] >= lam * (1 - 1e-12)
        if lam == ee[best]:
            assert top == best and abs(returns[best]) < 1e-9 * max(map(abs, returns))
            assert all(r < 0 for i, r in enumerate(returns) if i != best)


# --- the v0 ids unchanged -------------------------------------------------------------------
# Recorded on the commit before the energy objective (an episode of uniform(-1.3, 1.3) actions
# from default_rng(seed)): the first 6 rewards, the return and the last observation.
V0_RECORDS = {
    ("ios_uav_env/IOSUAV-v0", 0, (("T", 40.0), ("channel", "rician"), ("arrival_guard", False))): (
        [0.12910264280768372, 0.09034428169909484, 0.28578941005912095, 0.036135425747338495,
         0.11508751609190151, 0.21545785240006016], -495.7479681554373,
        [-0.9173198938369751, 0.0841955840587616, 1.917319893836975, -0.03419558331370354, 0.6673198938369751,
         -0.13419558107852936, 0.9173198938369751, -0.0841955840587616, 0.0, -0.9684363603591919,
         0.18241406977176666],
    ),
    ("ios_uav_env/RISUAV-v0", 1, (("T", 40.0),)): (
        [0.14638993809803705, 0.12794887129489457, 0.12173663219409456, 0.1383082711954789,
         0.14751054371037944, 0.16196562073507506], 11.316672384841853,
        [1.0, 0.05000000074505806, 0.0, 0.0, -1.25, -0.10000000149011612, -1.0, -0.05000000074505806, 0.0,
         0.0, 0.00041211475036107004],
    ),
    ("ios_uav_env/IOSUAV-Random-v0", 2, (("peak_hint", True),)): (
        [0.05866832636987807, 0.06762002742315815, 0.06892353558822514, 0.06439947195638004,
         0.05747552440659769, 0.06042281940613601], 31.357639961563926,
        [1.0, -0.22242668271064758, 0.0, 0.0, -1.2979848384857178, 0.07129504531621933, -1.0,
         0.22242668271064758, 0.0, 0.0, 0.35601097345352173, 0.8833333253860474, 1.0, 0.0, 0.7802197933197021,
         0.5899999737739563, 0.0, -0.7524999976158142, 0.21992668509483337, 1.53695547580719],
    ),
}  # fmt: skip


@pytest.mark.parametrize("key", sorted(V0_RECORDS))
def test_v0_episodes_are_unchanged(key):
    env_id, seed, kwargs = key
    first, total, last = V0_RECORDS[key]
    env = gym.make(env_id, **dict(kwargs))
    rng = np.random.default_rng(seed)
    out = play(env, rng.uniform(-1.3, 1.3, (500, 2)), seed=seed)
    np.testing.assert_allclose(out["rewards"][:6], first, rtol=1e-9)
    assert sum(out["rewards"]) == pytest.approx(total, rel=1e-9)
    np.testing.assert_allclose(out["obs"][-1], np.float32(last), rtol=1e-6, atol=1e-7)
    assert env.observation_space.shape == (len(last),)
    assert all(i["reward_energy"] == 0.0 for i in out["infos"])  # no energy term off the energy ids


def test_energy_observation_layout_and_space():
    env = IOSUAVEnv(SHORT)
    assert env.observation_space.shape == (len(OBS_NAMES) + len(ENERGY_NAMES),)
    rate_env = IOSUAVEnv(SHORT.replace(objective="rate"))
    np.testing.assert_array_equal(env.observation_space.low[:11], rate_env.observation_space.low)
    actions = np.random.default_rng(5).uniform(-1.3, 1.3, (SHORT.N - 1, 2))
    out = play(env, actions)
    obs = np.array(out["obs"])
    q = out["trajectory"]
    np.testing.assert_array_equal(obs[0, 11:13], [0.0, 0.0])
    np.testing.assert_allclose(obs[1:, 11:13], np.diff(q, axis=0) / SHORT.D, rtol=1e-6, atol=1e-7)
    weight = env.reference_efficiency * SHORT.propulsion.hover_power / SHORT.bandwidth_hz
    np.testing.assert_allclose(obs[:, 13], np.float32(weight), rtol=1e-6)
    np.testing.assert_allclose(obs[:, 14], np.float32(min_power_move(SHORT)), rtol=1e-6)
    assert all(env.observation_space.contains(o) for o in obs)
    # the rate part of the observation is the rate env's, bit for bit, on the same actions
    rate_out = play(rate_env, actions)
    np.testing.assert_array_equal(rate_out["trajectory"], q)
    np.testing.assert_array_equal(obs[:, :11], np.array(rate_out["obs"]))
    np.testing.assert_array_equal(
        [i["reward_rate"] for i in out["infos"]], [i["reward_rate"] for i in rate_out["infos"]]
    )


def test_objective_mismatch_and_bad_reference_are_refused():
    env = IOSUAVEnv(SHORT)
    with pytest.raises(ValueError, match="objective='rate'"):
        env.reset(options={"config": SHORT.replace(objective="rate")})
    with pytest.raises(ValueError, match="objective='energy_efficiency'"):
        IOSUAVEnv(SHORT.replace(objective="rate")).reset(options={"config": SHORT})
    with pytest.raises(ValueError, match="energy_reference"):
        IOSUAVEnv(SHORT, energy_reference=-1.0)
    with pytest.raises(ValueError, match="energy_reference must be None, 'loiter' or a number"):
        IOSUAVEnv(SHORT, energy_reference="dp")
    with pytest.raises(ValueError, match="energy_reference.*objective='rate'"):
        gym.make("ios_uav_env/IOSUAV-v0", energy_reference=1e4)
    with pytest.raises(ValueError, match="objective"):
        RandomIOSUAVEnv(objective="energy_efficiency", config=ScenarioConfig(T=60.0))


# --- ids, checkers, seeding, the batched form ------------------------------------------------
def test_ids_are_registered_with_their_scenarios():
    assert set(ENERGY_IDS) == {ENERGY_ID, ENERGY_RANDOM_ID} and not set(ENERGY_IDS) & set(ios_uav_env.ENV_IDS)
    fixed = gym.make(ENERGY_ID)
    assert fixed.unwrapped.config == ScenarioConfig(objective="energy_efficiency")
    assert fixed.unwrapped.config.to_dict() != ScenarioConfig().to_dict()
    random_env = gym.make(ENERGY_RANDOM_ID)
    assert isinstance(random_env.unwrapped, UAVEnv) and random_env.unwrapped.draws
    random_env.reset(seed=0)
    assert random_env.unwrapped.config.objective == "energy_efficiency"
    assert random_env.observation_space.shape == (11 + 6 + 4,)
    vec = gym.make_vec(ENERGY_ID, 2, vectorization_mode="vector_entry_point")
    assert type(vec) is UAVVectorEnv and not vec.envs[0].draws
    vec = gym.make_vec(ENERGY_RANDOM_ID, 2, vectorization_mode="vector_entry_point")
    assert type(vec) is UAVVectorEnv and vec.envs[0].draws


def test_seeded_episodes_reproduce():
    ranges = {"T": (40.0, 60.0)}
    actions = np.random.default_rng(7).uniform(-1.2, 1.2, (80, 2))
    a, b = (play(RandomIOSUAVEnv(ranges, objective="energy_efficiency"), actions, seed=9) for _ in range(2))
    np.testing.assert_array_equal(np.array(a["obs"]), np.array(b["obs"]))
    assert a["rewards"] == b["rewards"]
    assert [i["energy_efficiency"] for i in a["infos"]] == [i["energy_efficiency"] for i in b["infos"]]


def test_batch_matches_single_envs_row_for_row():
    ranges = {"T": (40.0, 50.0)}
    kwargs = {"objective": "energy_efficiency", "peak_hint": True}
    b, steps = 2, 95
    actions = np.random.default_rng(2).uniform(-1.2, 1.2, (steps, b, 2))
    vec = RandomIOSUAVVectorEnv(b, ranges, **kwargs)
    singles = [RandomIOSUAVEnv(ranges, **kwargs) for _ in range(b)]
    obs, info = vec.reset(seed=11)
    firsts = [env.reset(seed=11 + i) for i, env in enumerate(singles)]
    np.testing.assert_array_equal(obs, np.stack([o for o, _ in firsts]))
    ended = np.zeros(b, dtype=bool)
    for t in range(steps):
        obs, reward, terminated, _, info = vec.step(actions[t])
        for i, env in enumerate(singles):
            if ended[i]:  # next-step autoreset: the row starts its next episode
                one, _ = env.reset()
                np.testing.assert_array_equal(obs[i], one)
                continue
            one, r, term, _, inf = env.step(actions[t, i])
            np.testing.assert_allclose(obs[i], one, rtol=1e-6, atol=1e-6)
            assert r == pytest.approx(reward[i], rel=1e-9, abs=1e-9) and term == terminated[i]
            for key in ("power", "energy", "energy_efficiency", "reward_energy"):
                assert inf[key] == pytest.approx(info[key][i], rel=1e-9, abs=1e-9), key
        ended = terminated.copy()


def test_fixed_batch_restarts_with_the_energy_reset_and_pickles():
    """Two episodes per row on the fixed scenario (the batched env's quick restart of its own
    scenario): each row's energy and EE equal the single env's; a pickled env steps alike."""
    actions = np.random.default_rng(4).uniform(-1.2, 1.2, (2 * (SHORT.N - 1) + 1, 2, 2))
    vec = IOSUAVVectorEnv(2, SHORT)
    vec.reset(seed=0)
    singles = [IOSUAVEnv(SHORT) for _ in range(2)]
    for i, env in enumerate(singles):
        env.reset(seed=i)
    for t, action in enumerate(actions):
        obs, reward, terminated, _, info = vec.step(action)
        for i, env in enumerate(singles):
            if t == SHORT.N - 1:  # the reset step of the next-step autoreset
                one, inf = env.reset()
                assert info["energy"][i] == inf["energy"] == 0.0
            else:
                one, r, _, _, inf = env.step(action[i])
                assert r == pytest.approx(reward[i], rel=1e-9, abs=1e-12)
            np.testing.assert_allclose(obs[i], one, rtol=1e-6, atol=1e-6)
            for key in ("power", "energy", "energy_efficiency"):
                assert inf[key] == pytest.approx(info[key][i], rel=1e-9, abs=1e-12), key
    env = IOSUAVEnv(SHORT)
    env.reset(seed=0)
    env.step(np.array([0.3, 0.4]))
    twin = pickle.loads(pickle.dumps(env))
    a, b = env.step(np.array([0.5, -0.2])), twin.step(np.array([0.5, -0.2]))
    np.testing.assert_array_equal(a[0], b[0])
    assert a[1] == b[1] and a[4]["energy"] == b[4]["energy"]
