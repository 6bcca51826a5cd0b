"""The energy objective with a moving, roughly known node (single-node env, single and batched):
lambda_ref is the reference flights' EE on the drawn truth (the reward only, never the
observation), the return identity, info against score_plan on the true path, the energy budget,
the batch row for row, seeding, the checkers and what stays refused."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env, data_equivalence

from ios_uav_env import MOBILE_ID, ScenarioConfig, score_plan
from ios_uav_env.envs.core.vector import UAVVectorEnv
from ios_uav_env.envs.observation import (
    ENERGY_NAMES,
    flights_efficiency,
    hover_flight,
    loiter_efficiency,
    reference_efficiency,
    reference_flights,
)
from ios_uav_env.envs.random_env import RandomIOSUAVEnv
from ios_uav_env.envs.single import IOSUAVEnv
from ios_uav_env.envs.single_vector import IOSUAVVectorEnv, RandomIOSUAVVectorEnv
from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model.mobility import GaussMarkov
from ios_uav_env.model.peak import rate_peak
from ios_uav_env.model.scenarios import ScenarioRanges
from ios_uav_env.model.schedule import node_rates
from tests.envs.test_energy_env import play as play_actions

ENERGY = {"objective": "energy_efficiency"}
SHORT = ScenarioConfig(T=40.0, ios_shape=(100, 20), motion=GaussMarkov(speed=3.0), **ENERGY)
RANGES = ScenarioRanges(
    T=(40.0, 50.0), ios_rows=(20, 20), base=ScenarioConfig(motion=GaussMarkov(), **ENERGY)
)
KNOWLEDGE = ["exact", "reports", "rates"]
ACTIONS = np.random.default_rng(5).uniform(-1.2, 1.2, (64, 2))
WEIGHT = ENERGY_NAMES.index("energy_weight")


def play(env: gym.Env, seed: int | None, actions: np.ndarray = ACTIONS) -> dict:
    """One episode of ``env`` on ``actions`` (cycled): observations, rewards, infos, trajectory
    (``test_energy_env.play``, seeded ``seed``)."""
    return play_actions(env, actions, seed)


def own_reference(env: IOSUAVEnv) -> float:
    """The episode's lambda_ref recomputed from the model: the scenario's hover flight (with
    ``"loiter"``, and its loiter flight) scored on the episode's true path."""
    cfg = env.config
    flights = reference_flights(
        cfg, rate_peak(cfg, compiled=HAVE_NUMBA), env.options.energy_reference == "loiter"
    )
    return flights_efficiency(cfg, flights, env.paths)


def energy_weight(env: IOSUAVEnv, obs: np.ndarray) -> float:
    return float(obs[env.observation_names.index(ENERGY_NAMES[WEIGHT])])


# --- lambda_ref: the reference flights on the truth; the observation: the scenario's ----------
@pytest.mark.parametrize("knowledge", KNOWLEDGE)
def test_lambda_ref_is_the_hover_flights_ee_on_the_drawn_path(knowledge):
    env = IOSUAVEnv(SHORT, knowledge=knowledge)
    peak = rate_peak(SHORT, compiled=HAVE_NUMBA)
    static = reference_efficiency(SHORT, peak)  # the node at its configured position, the energy id's
    lams = []
    for seed in (1, 2):
        env.reset(seed=seed)
        lam = env.reference_efficiency
        flight = score_plan(SHORT, hover_flight(SHORT, peak), paths=env.paths)
        assert lam == own_reference(env) == flight.energy_efficiency and flight.feasible
        assert not np.array_equal(env.paths, np.repeat(env.paths[:1], SHORT.N, axis=0))  # it moved
        lams.append(lam)
    assert lams[0] != lams[1] and static not in lams  # drawn from each episode's truth


def test_flying_the_reference_flight_scores_lambda_ref_and_returns_the_start_term():
    """The hover flight flown in the env on the episode's path: its EE is lambda_ref (a feasible
    plan's EE on the truth, so lambda_ref <= the best EE) and G = bits - lambda_ref E = 0."""
    env = IOSUAVEnv(SHORT, knowledge="reports")
    env.reset(seed=3)
    lam = env.reference_efficiency
    flight = hover_flight(SHORT, rate_peak(SHORT, compiled=HAVE_NUMBA))
    out = play(env, 3, np.diff(flight, axis=0) / SHORT.D)
    last = out["infos"][-1]
    assert env.reference_efficiency == lam and last["feasible"]
    assert last["energy_efficiency"] == pytest.approx(lam, rel=1e-9)
    start = node_rates(SHORT, np.array([SHORT.q0]), env.paths[:1])[0, 0]
    assert sum(out["rewards"]) == pytest.approx(-start, rel=1e-6, abs=1e-9)


def test_the_observation_shows_the_scenarios_weight_never_the_episodes():
    """``energy_weight`` is the scenario's static reference's weight, the same whatever the drawn
    path, while the reward's lambda_ref follows the truth: the observation does not tell it."""
    env = IOSUAVEnv(SHORT, knowledge="exact")
    static = reference_efficiency(SHORT, rate_peak(SHORT, compiled=HAVE_NUMBA))
    weights, lams = set(), set()
    for seed in (1, 2, 3):
        obs, _ = env.reset(seed=seed)
        weights.add(energy_weight(env, obs))
        lams.add(env.reference_efficiency)
    assert len(lams) == 3
    assert weights == {np.float32(static * SHORT.propulsion.hover_power / SHORT.bandwidth_hz)}
    assert env.observation_space.shape == (15,) and env.observation_names[11:] == ENERGY_NAMES


def test_loiter_and_a_fixed_reference():
    loiter = IOSUAVEnv(SHORT, knowledge="reports", energy_reference="loiter")
    hover = IOSUAVEnv(SHORT, knowledge="reports")
    obs, _ = loiter.reset(seed=4)
    hover.reset(seed=4)
    np.testing.assert_array_equal(loiter.paths, hover.paths)
    assert loiter.reference_efficiency == own_reference(loiter) >= hover.reference_efficiency
    static = loiter_efficiency(SHORT, rate_peak(SHORT, compiled=HAVE_NUMBA))
    assert energy_weight(loiter, obs) == np.float32(
        static * SHORT.propulsion.hover_power / SHORT.bandwidth_hz
    )
    fixed = IOSUAVEnv(SHORT, knowledge="rates", energy_reference=1234.5)
    obs, _ = fixed.reset(seed=4)
    assert fixed.reference_efficiency == 1234.5
    assert energy_weight(fixed, obs) == np.float32(1234.5 * SHORT.propulsion.hover_power / SHORT.bandwidth_hz)
    out = play(fixed, 4)
    assert all(
        i["reward_energy"] == pytest.approx(-1234.5 / SHORT.bandwidth_hz * i["power"]) for i in out["infos"]
    )


def test_a_static_node_with_reports_is_the_energy_id():
    """No motion, knowledge "reports": lambda_ref is the energy id's, bit for bit, and so are the
    rewards and the EE (the node does not move; only what the UAV is told differs)."""
    static = SHORT.replace(motion=None)
    told, known = IOSUAVEnv(static, knowledge="reports"), IOSUAVEnv(static)
    a, b = play(told, 6), play(known, 6)
    assert told.reference_efficiency == known.reference_efficiency
    np.testing.assert_allclose(a["rewards"], b["rewards"], rtol=1e-12, atol=1e-12)
    assert a["infos"][-1]["energy_efficiency"] == pytest.approx(
        b["infos"][-1]["energy_efficiency"], rel=1e-12
    )


# --- the reward and the score ----------------------------------------------------------------
@pytest.mark.parametrize("knowledge", KNOWLEDGE)
def test_the_return_is_dinkelbachs_objective_on_the_truth(knowledge):
    """With the guard, sum of rewards = (bits - lambda_ref E) / (B dt) - r(q[1]; w[1]), bits and E
    of the flown trajectory on the true path; each step's energy term is -(lambda_ref / B) P."""
    env = IOSUAVEnv(SHORT, knowledge=knowledge, channel="expected")
    out = play(env, 8)
    q, paths, lam = env.trajectory, env.paths, env.reference_efficiency
    rates = node_rates(SHORT, q, paths)[0]
    score = score_plan(SHORT, q, paths=paths)
    scale = SHORT.bandwidth_hz * SHORT.dt
    bits = scale * rates.sum()
    assert bits == pytest.approx(score.energy_efficiency * score.energy, rel=1e-12)
    expected = (bits - lam * score.energy) / scale - rates[0]
    assert sum(out["rewards"]) == pytest.approx(expected, rel=1e-10, abs=1e-10)
    assert lam * score.energy / scale > 1.0  # the energy term is not negligible here
    for info in out["infos"][1:]:
        assert info["reward_energy"] == pytest.approx(-lam / SHORT.bandwidth_hz * info["power"], rel=1e-12)
        assert info["reward_energy"] < 0.0


@pytest.mark.parametrize("budget", [None, 1.0 + 1e-6, 3.0])
@pytest.mark.parametrize("knowledge", KNOWLEDGE)
def test_the_final_info_is_score_plan_on_the_true_path_with_the_budget(knowledge, budget):
    cfg = SHORT if budget is None else SHORT.replace(energy_budget_j=budget * SHORT.least_energy())
    env = IOSUAVEnv(cfg, knowledge=knowledge)
    last = play(env, 9)["infos"][-1]
    score = score_plan(cfg, env.trajectory, paths=env.paths)
    assert last["energy_efficiency"] == pytest.approx(score.energy_efficiency, rel=1e-9)
    assert last["energy_efficiency"] == pytest.approx(score.objective_value, rel=1e-9)
    assert last["energy"] == pytest.approx(score.energy, rel=1e-9)
    assert bool(last["feasible"]) == score.feasible == (budget != 1.0 + 1e-6)
    static = score_plan(cfg, env.trajectory)  # (the configured node would score otherwise)
    assert static.energy_efficiency != pytest.approx(score.energy_efficiency, rel=1e-6)


# --- the batch, seeding, checkers ------------------------------------------------------------
def _replay(vec, singles, actions: np.ndarray, seed: int) -> int:
    """Step the batch and the single envs alike (the singles reset when the batch's NEXT_STEP
    autoreset does); every row equals its single env (to the kernels' ulps; lambda_ref, the truth
    and the flags exactly). Returns the number of episodes started."""
    obs, _ = vec.reset(seed=seed)
    for i, env in enumerate(singles):
        one, _ = env.reset(seed=seed + i)
        np.testing.assert_array_equal(obs[i], one)
    pending, episodes = [False] * len(singles), len(singles)
    for t in range(actions.shape[0]):
        obs, reward, terminated, _, info = vec.step(actions[t])
        for i, env in enumerate(singles):
            row = vec.envs[i]
            if pending[i]:
                one, inf = env.reset()
                r, term, pending[i], episodes = 0.0, False, False, episodes + 1
            else:
                one, r, term, _, inf = env.step(actions[t, i])
                pending[i] = term
            assert row.reference_efficiency == env.reference_efficiency
            np.testing.assert_array_equal(row.paths, env.paths)
            np.testing.assert_allclose(obs[i], one, rtol=1e-6, atol=1e-6)
            assert r == pytest.approx(reward[i], rel=1e-9, abs=1e-9) and term == terminated[i]
            for key in ("power", "energy", "energy_efficiency", "reward_energy", "average_rate"):
                assert inf[key] == pytest.approx(info[key][i], rel=1e-9, abs=1e-9), key
            assert inf["feasible"] == info["feasible"][i] and inf["slot"] == info["slot"][i]
    return episodes


def test_the_random_batch_is_the_single_envs_row_for_row():
    kwargs = {"knowledge": "reports", "energy_reference": "loiter"}
    vec = RandomIOSUAVVectorEnv(3, RANGES, **kwargs)
    singles = [RandomIOSUAVEnv(RANGES, **kwargs) for _ in range(3)]
    actions = np.random.default_rng(1).uniform(-1.3, 1.3, (100, 3, 2))
    assert _replay(vec, singles, actions, seed=7) >= 5


def test_the_fixed_batch_is_the_single_envs_row_for_row():
    vec = IOSUAVVectorEnv(2, SHORT, knowledge="rates", energy_budget_j=2.0 * SHORT.least_energy())
    singles = [
        IOSUAVEnv(SHORT, knowledge="rates", energy_budget_j=2.0 * SHORT.least_energy()) for _ in range(2)
    ]
    actions = np.random.default_rng(2).uniform(-1.3, 1.3, (2 * SHORT.N, 2, 2))
    assert _replay(vec, singles, actions, seed=3) >= 4


def test_a_seed_gives_the_same_episode_bit_for_bit_single_and_batched():
    a, b = (play(RandomIOSUAVEnv(RANGES, knowledge="reports"), 11) for _ in range(2))
    assert data_equivalence(a, b, exact=True)
    runs = []
    for _ in range(2):
        vec = gym.make_vec(
            MOBILE_ID, num_envs=2, vectorization_mode="vector_entry_point", ranges=RANGES, **ENERGY
        )
        steps = [vec.reset(seed=5)]
        rng = np.random.default_rng(0)
        steps += [vec.step(rng.uniform(-1, 1, (2, 2))) for _ in range(60)]  # past an autoreset
        runs.append((steps, [env.reference_efficiency for env in vec.unwrapped.envs]))
    assert data_equivalence(runs[0], runs[1], exact=True)
    other = play(RandomIOSUAVEnv(RANGES, knowledge="reports"), 12)
    assert not data_equivalence(a, other)


def test_checkers_pass_single_and_batched():
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make(MOBILE_ID, **ENERGY)
        check_env(env.unwrapped, skip_render_check=True)
        sb3_checker.check_env(gym.make(MOBILE_ID, **ENERGY).unwrapped, warn=True)
        for knowledge in KNOWLEDGE:
            check_env(IOSUAVEnv(SHORT, knowledge=knowledge), skip_render_check=True)
        check_env(IOSUAVEnv(SHORT.replace(motion=None), knowledge="rates"), skip_render_check=True)
        vec = gym.make_vec(MOBILE_ID, num_envs=3, vectorization_mode="vector_entry_point", **ENERGY)
    assert isinstance(vec, UAVVectorEnv) and vec.envs[0].draws
    assert vec.single_observation_space == env.observation_space and env.observation_space.shape == (21,)
    assert env.unwrapped.observation_names[17:] == ENERGY_NAMES
    obs, info = vec.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(80):  # past autoresets: every batch of observations lies in the space
        assert vec.observation_space.contains(obs) and obs.dtype == np.float32
        assert set(info) >= {"energy", "energy_efficiency", "reward_energy"}
        obs, reward, _, _, info = vec.step(rng.uniform(-1, 1, (3, 2)))
        assert reward.dtype == np.float64 and info["reward_energy"].shape == (3,)
        assert np.all(info["reward_energy"] <= 0.0) and np.any(info["reward_energy"] < 0.0)  # (0: a reset)


def test_a_pinned_scenario_takes_its_own_reference_flights():
    env = IOSUAVEnv(SHORT, knowledge="exact")
    other = SHORT.replace(T=36.0)
    env.reset(seed=1, options={"config": other})
    assert env.config == other and env.reference_efficiency == own_reference(env)
    env.reset(seed=1)
    assert env.config is SHORT and env.reference_efficiency == own_reference(env)


def test_the_peak_hint_stays_refused_with_motion():
    with pytest.raises(ValueError, match="peak_hint"):
        IOSUAVEnv(SHORT, peak_hint=True)
    with pytest.raises(ValueError, match="peak_hint"):
        gym.make(MOBILE_ID, peak_hint=True, **ENERGY)


def test_a_pickled_env_steps_and_resets_alike():
    import pickle

    env = IOSUAVEnv(SHORT, knowledge="reports", energy_reference="loiter")
    env.reset(seed=2)
    env.step(np.array([0.3, 0.4]))
    twin = pickle.loads(pickle.dumps(env))
    a, b = env.step(np.array([0.5, -0.2])), twin.step(np.array([0.5, -0.2]))
    assert data_equivalence(a, b, exact=True) and twin.reference_efficiency == env.reference_efficiency
    a, b = play(env, 3), play(twin, 3)
    assert data_equivalence(a, b, exact=True) and twin.reference_efficiency == env.reference_efficiency
