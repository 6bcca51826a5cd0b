"""The multi-node env with the energy objective (``objective="energy_efficiency"``, K >= 1 nodes):
the reward's energy term and the return's identity, the final info against ``score_plan``, the
reference efficiency, the observation's energy features, the rate ids unchanged, the batched
form row for row, seeding, the energy budget, the checker and the refused combinations."""

from __future__ import annotations

import dataclasses
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env, data_equivalence

from ios_uav_env import ScenarioConfig, propulsion_power, score_plan
from ios_uav_env.envs.multi import (
    BASE_FEATURES,
    DEFAULT_NODES,
    MULTI_INFO_KEYS,
    MULTINODE_RANGES,
    MultiNodeEnv,
)
from ios_uav_env.envs.multi_energy import (
    ENERGY_NAMES,
    least_energy_flight,
    reference_efficiency,
    reference_shares,
    straight_flight,
)
from ios_uav_env.envs.multi_table import ENERGY_INFO_KEYS
from ios_uav_env.model.schedule import node_rates, scheduled_rates
from tests.envs.test_multi_vector import replay_gap

FIXED, RANDOM = "ios_uav_env/IOSUAV-MultiNode-v0", "ios_uav_env/IOSUAV-MultiNode-Random-v0"
MOBILE = "ios_uav_env/IOSUAV-MultiNode-Mobile-v0"
ENERGY = {"objective": "energy_efficiency"}
SHORT_RANGES = dataclasses.replace(MULTINODE_RANGES, T=(40.0, 50.0))
#: Short episodes of each id (39 to 49 moves), with the energy objective.
KWARGS = {FIXED: {"T": 40.0, **ENERGY}, RANDOM: {"ranges": SHORT_RANGES, **ENERGY},
          MOBILE: {"ranges": SHORT_RANGES, **ENERGY}}  # fmt: skip
SHORT = ScenarioConfig(T=40.0, ground_nodes=DEFAULT_NODES, **ENERGY)
RTOL = 1e-9  # the kernel's float64 sums against the model's, in another order


def play(env: gym.Env, seed: int = 0, scale: float = 1.3) -> dict:
    """One episode of seeded random moves and node scores."""
    obs, info = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    out = {"obs": [obs], "rewards": [], "infos": [info]}
    done = False
    while not done:
        obs, reward, terminated, truncated, info = env.step(
            rng.uniform(-scale, scale, env.action_space.shape)
        )
        out["obs"].append(obs)
        out["rewards"].append(reward)
        out["infos"].append(info)
        done = terminated or truncated
    return out


# --- the reward and the score ---------------------------------------------------------------
@pytest.mark.parametrize("guard", [True, False])
def test_the_return_is_bits_minus_lambda_energy_over_b_dt(guard):
    """sum of the rewards = (bits - lambda_ref E) / (B dt) + the penalties, bits = B T min_k R_k of
    the agent's own shares: every step's energy term is -(lambda_ref / B) P(V_n)."""
    env = MultiNodeEnv(SHORT, arrival_guard=guard)
    out = play(env, seed=3)
    cfg, q, shares = env.config, env.trajectory, env.shares
    lam = env.reference_efficiency
    assert lam == reference_efficiency(cfg) > 0
    speeds = np.linalg.norm(np.diff(q, axis=0), axis=1) / cfg.dt
    powers = propulsion_power(speeds, cfg.propulsion)
    energy_terms = np.array([i["reward_energy"] for i in out["infos"][1:]])
    np.testing.assert_allclose([i["power"] for i in out["infos"][1:]], powers, rtol=1e-12)
    np.testing.assert_allclose(energy_terms, -lam / cfg.bandwidth_hz * powers, rtol=1e-12)
    own = scheduled_rates(cfg, q, shares).min()
    energy = score_plan(cfg, q, shares).energy
    bits = cfg.bandwidth_hz * cfg.T * own
    penalties = sum(i["reward_reach"] + i["reward_terminal"] for i in out["infos"][1:])
    assert (penalties == 0.0) == guard
    expected = (bits - lam * energy) / (cfg.bandwidth_hz * cfg.dt) + penalties
    assert sum(out["rewards"]) == pytest.approx(expected, rel=RTOL)
    for info, reward in zip(out["infos"][1:], out["rewards"], strict=True):  # the terms sum to the reward
        terms = info["reward_rate"] + info["reward_energy"] + info["reward_reach"] + info["reward_terminal"]
        assert reward == pytest.approx(terms, rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("env_id", [FIXED, RANDOM, MOBILE])
def test_the_final_info_is_score_plans_energy_efficiency(env_id):
    env = gym.make(env_id, **KWARGS[env_id])
    info = play(env, seed=1)["infos"][-1]
    u = env.unwrapped
    score = score_plan(u.config, u.trajectory, u.shares if u.config.K > 1 else None, u.paths)
    assert info["energy_efficiency"] == pytest.approx(score.energy_efficiency, rel=RTOL)
    assert info["energy_efficiency"] == pytest.approx(score.objective_value, rel=RTOL)
    assert info["energy"] == pytest.approx(score.energy, rel=RTOL)
    assert info["min_rate"] == pytest.approx(score.rate, rel=RTOL) and info["feasible"] == score.feasible


def _efficiency(cfg: ScenarioConfig, q: np.ndarray) -> float:
    return score_plan(cfg, q, reference_shares(node_rates(cfg, q)), best_schedule=False).energy_efficiency


@pytest.mark.parametrize("t", [40.0, 150.0])
def test_the_reference_is_the_better_of_the_straight_and_the_least_energy_flights(t):
    cfg = SHORT.replace(T=t)
    straight, least = straight_flight(cfg), least_energy_flight(cfg)
    assert score_plan(cfg, straight).feasible and score_plan(cfg, least).feasible
    np.testing.assert_allclose(
        np.diff(straight, axis=0), (cfg.qF - straight[0]) / (cfg.N - 1) + 0 * straight[1:]
    )
    lam = reference_efficiency(cfg)
    assert lam == max(_efficiency(cfg, straight), _efficiency(cfg, least)) > 0
    # the best schedule: as good as score_plan's own (certified) one, better than equal shares
    best = max(score_plan(cfg, straight).energy_efficiency, score_plan(cfg, least).energy_efficiency)
    assert lam == pytest.approx(best, rel=1e-9)
    equal = np.full((cfg.K, cfg.N), 1.0 / cfg.K)
    assert lam > score_plan(cfg, straight, equal).energy_efficiency
    # under a budget the straight flight exceeds, only the least-energy flight counts
    tight = cfg.replace(energy_budget_j=cfg.least_energy() * (1.0 + 1e-9))
    if not score_plan(tight, straight).feasible:
        assert score_plan(tight, least).feasible
        assert reference_efficiency(tight) == _efficiency(tight, least) != lam
    else:  # (the straight flight is the least-energy one: fast enough)
        np.testing.assert_allclose(least, straight)


@pytest.mark.parametrize(
    "changes",
    [{"T": 150.0}, {"T": 151.0}, {"T": 60.0, "qF": (-390.0, 0.0)}, {"T": 61.0, "qF": (-400.0, 0.0)},
     {"T": 40.0}, {"T": 2.0, "qF": (-399.0, 0.0)}],
    ids=["even", "odd", "near-even", "near-odd", "fast", "one-move"],
)  # fmt: skip
def test_the_least_energy_flight_has_the_least_energy(changes):
    """N - 1 moves of one length c* dt from q0 to qF, so its energy is ``least_energy()`` (a detour
    of an even or odd number of moves, qF far or near, or the straight flight)."""
    cfg = SHORT.replace(**changes)
    q = least_energy_flight(cfg)
    steps = np.linalg.norm(np.diff(q, axis=0), axis=1)
    assert q.shape == (cfg.N, 2) and np.array_equal(q[0], cfg.q0) and np.array_equal(q[-1], cfg.qF)
    np.testing.assert_allclose(steps, cfg.least_energy_speed() * cfg.dt, rtol=1e-9)
    assert score_plan(cfg, q).energy == pytest.approx(cfg.least_energy(), rel=1e-12)


def test_a_given_energy_reference_is_lambda_ref():
    env = MultiNodeEnv(SHORT, energy_reference=500.0)
    obs, _ = env.reset(seed=0)
    assert env.reference_efficiency == 500.0
    names = env.observation_names
    weight = 500.0 * SHORT.propulsion.hover_power / SHORT.bandwidth_hz
    assert obs[names.index("energy_weight")] == np.float32(weight)
    _, _, _, _, info = env.step(np.zeros(env.action_space.shape))
    assert info["reward_energy"] == pytest.approx(-500.0 / SHORT.bandwidth_hz * info["power"], rel=1e-12)


def test_moving_nodes_take_the_reference_on_the_true_paths():
    env = gym.make(MOBILE, **KWARGS[MOBILE])
    play(env, seed=2)
    u = env.unwrapped
    assert u.truth is not None
    assert u.reference_efficiency == pytest.approx(reference_efficiency(u.config, u.paths), rel=1e-12)
    flights = (least_energy_flight(u.config), straight_flight(u.config))  # score_plan's EE on the truth
    best = max(
        score_plan(u.config, q, reference_shares(node_rates(u.config, q, u.paths)), u.paths).energy_efficiency
        for q in flights
    )
    assert u.reference_efficiency == pytest.approx(best, rel=1e-12)
    assert u.reference_efficiency != reference_efficiency(u.config)  # (the static nodes' differs)
    # the reward takes the truth's lambda_ref, the observation the configured nodes' (no truth)
    cfg = u.config
    obs = env.reset(seed=2)[0]
    weight = reference_efficiency(cfg) * cfg.propulsion.hover_power / cfg.bandwidth_hz
    assert obs[u.observation_names.index("energy_weight")] == np.float32(weight)
    info = env.step(np.zeros(env.action_space.shape))[4]
    assert info["reward_energy"] == pytest.approx(-u.reference_efficiency / cfg.bandwidth_hz * info["power"])


# --- observation and info layout ------------------------------------------------------------
@pytest.mark.parametrize("env_id", [FIXED, RANDOM, MOBILE])
def test_the_energy_features_and_info_keys_come_only_with_the_objective(env_id):
    kwargs = KWARGS[env_id]
    rate = gym.make(env_id, **{k: v for k, v in kwargs.items() if k != "objective"}).unwrapped
    env = gym.make(env_id, **kwargs).unwrapped
    assert env.observation_names == rate.observation_names + ENERGY_NAMES
    assert env.observation_space.shape[0] == rate.observation_space.shape[0] + 4
    np.testing.assert_array_equal(env.observation_space.low[:-4], rate.observation_space.low)
    assert tuple(rate.reset(seed=0)[1]) == MULTI_INFO_KEYS
    assert tuple(env.reset(seed=0)[1]) == MULTI_INFO_KEYS + ENERGY_INFO_KEYS
    assert len(BASE_FEATURES) == 12 and env.observation_names[:12] == BASE_FEATURES


def test_the_energy_features_are_the_last_move_the_weight_and_the_min_power_move():
    env = MultiNodeEnv(SHORT)
    out = play(env, seed=4)
    names = env.observation_names
    cols = [names.index(n) for n in ENERGY_NAMES]
    moves = np.diff(env.trajectory, axis=0) / SHORT.D
    features = np.array(out["obs"])[:, cols]
    np.testing.assert_array_equal(features[0, :2], 0.0)
    np.testing.assert_allclose(features[1:, :2], moves, atol=1e-6)
    weight = env.reference_efficiency * SHORT.propulsion.hover_power / SHORT.bandwidth_hz
    np.testing.assert_allclose(features[:, 2], weight, rtol=1e-6)
    from ios_uav_env.envs.observation import min_power_move

    np.testing.assert_allclose(features[:, 3], min_power_move(SHORT), rtol=1e-6)


# --- checker, seeding, the batched form -----------------------------------------------------
@pytest.mark.parametrize("env_id", [FIXED, RANDOM, MOBILE])
def test_gymnasiums_checker_passes(env_id):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(env_id, **KWARGS[env_id]).unwrapped, skip_render_check=True)
        check_env(MultiNodeEnv(SHORT, energy_reference=300.0, peak_hint=True), skip_render_check=True)


@pytest.mark.parametrize("env_id", [FIXED, RANDOM])
def test_sb3s_checker_passes(env_id):
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    sb3_checker.check_env(gym.make(env_id, **KWARGS[env_id]).unwrapped, warn=True)


@pytest.mark.parametrize("env_id", [RANDOM, MOBILE])
def test_a_seed_reproduces_an_episode_bit_for_bit(env_id):
    a, b = (play(gym.make(env_id, **KWARGS[env_id]), seed=5) for _ in range(2))
    assert data_equivalence(a, b, exact=True)
    c = play(gym.make(env_id, **KWARGS[env_id]), seed=6)
    assert not data_equivalence(a["rewards"], c["rewards"])


def _replay(env_id: str, mode: str, n: int = 3, steps: int = 110) -> float:
    """The batched env and SyncVectorEnv of single envs side by side (``replay_gap``: the largest
    gap of observations, rewards and every info key, final ones included; flags equal), after
    checking that info has this objective's and channel's keys."""
    vec = gym.make_vec(env_id, n, vectorization_mode="vector_entry_point", **KWARGS[env_id])
    assert vec.unwrapped.info_keys == MULTI_INFO_KEYS + ENERGY_INFO_KEYS
    return replay_gap(env_id, mode, steps=steps, n=n, seed=11, kwargs=KWARGS[env_id])


@pytest.mark.parametrize(
    ("env_id", "mode"), [(FIXED, "next_step"), (RANDOM, "same_step"), (MOBILE, "next_step")]
)
def test_the_batch_equals_single_envs_row_for_row(env_id, mode):
    assert _replay(env_id, mode) <= 1e-9


def test_the_batched_env_passes_the_checks_of_a_vector_env():
    """The space holds every observation, info holds (B,) arrays of fixed keys and dtypes, and a
    seeded batch repeats bit for bit (Gymnasium has no checker of vector envs)."""
    runs = []
    for _ in range(2):
        vec = gym.make_vec(RANDOM, 2, vectorization_mode="vector_entry_point", **KWARGS[RANDOM])
        obs, info = vec.reset(seed=0)
        out, rng = [obs, info], np.random.default_rng(0)
        for _ in range(60):
            obs, reward, term, trunc, info = vec.step(rng.uniform(-1, 1, vec.action_space.shape))
            assert vec.observation_space.contains(obs) and obs.dtype == np.float32
            assert all(np.asarray(info[k]).shape[0] == 2 for k in ENERGY_INFO_KEYS)
            assert info["energy"].dtype == np.float64
            out += [obs, reward, term, trunc, {k: info[k] for k in vec.unwrapped.info_keys}]
        runs.append(out)
    assert data_equivalence(runs[0], runs[1], exact=True)


# --- the budget, and what is refused ---------------------------------------------------------
@pytest.mark.parametrize("factor", [1.0 + 1e-6, 3.0])
def test_an_exceeded_budget_makes_the_flight_infeasible(factor):
    cfg = SHORT.replace(energy_budget_j=factor * SHORT.least_energy())
    env = MultiNodeEnv(cfg)
    info = play(env, seed=0)["infos"][-1]
    score = score_plan(cfg, env.trajectory, env.shares)
    assert info["feasible"] == score.feasible == (factor > 2)
    assert info["worst_violation"] <= 1e-6  # (the guard: eq. (10) holds; only the budget fails)


def test_refused_combinations_name_the_field():
    with pytest.raises(ValueError, match="energy_reference='loiter' is the single-node loiter flight"):
        MultiNodeEnv(SHORT, energy_reference="loiter")
    with pytest.raises(ValueError, match="energy_reference .* needs objective='energy_efficiency'"):
        MultiNodeEnv(SHORT.replace(objective="rate"), energy_reference=300.0)
    with pytest.raises(ValueError, match="instance_features"):
        MultiNodeEnv(SHORT, instance_features=True)
    with pytest.raises(ValueError, match="bandwidth_hz is the bandwidth"):
        MultiNodeEnv(T=40.0, bandwidth_hz=2e6)  # the rate objective: inert
    env = MultiNodeEnv(T=40.0, bandwidth_hz=2e6, **ENERGY)  # the energy objective: it counts
    assert env.config.bandwidth_hz == 2e6
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r'options\["config"\] has objective=.rate., but this'):
        env.reset(options={"config": SHORT.replace(objective="rate")})
