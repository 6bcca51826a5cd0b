"""``dp-miso-sdma`` (``baselines.dp_miso_sdma``): a multi-antenna UAV serving two users at once. Its
plan is scored by ``score_plan`` as it reports, feasible, never below the best candidate, and the
certified bound holds: above the plan, above other flights and env episodes, and its premises
checked at points; the plan flown through ``MISOUAV-SDMA-v0`` scores what the planner reports."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from baselines.dp_miso_sdma import SdmaRelaxedDP, sdma_bound, solve, two_user_bound
from baselines.dp_relaxed import region_rate_bound
from baselines.registry import PlannerMismatch
from baselines.registry import solve as solve_registered
from ios_uav_env import MISO_SDMA_ID, score_plan
from ios_uav_env.envs.miso_sdma import SDMA_CONFIG
from ios_uav_env.model.miso import slot_bounds, weighted_sum_bound
from ios_uav_env.model.miso_sdma import slot_channel_at
from tests.tolerances import PLANNER_REL

#: The SDMA ids' scenario on a short flight (5 slots) and a coarse grid: fast to plan.
SMALL = SDMA_CONFIG.replace(T=5.0, q0=(-250.0, -40.0), qF=(-250.0, 40.0))


@pytest.fixture(scope="module")
def plan():
    return solve(SMALL, resolution=12.5)


def test_the_plan_is_scored_as_the_planner_reports_and_is_feasible(plan):
    assert plan.scheme == "dp-miso-sdma" and plan.feasible
    scored = score_plan(SMALL, plan.trajectory)
    # the planner scores its candidates on the cached settings, the scorer recomputes them
    assert scored.rate == pytest.approx(plan.info["candidates"][plan.info["plan_source"]], rel=PLANNER_REL)
    assert plan.mean_rate == scored.rate == max(plan.info["candidates"].values())
    assert plan.info["grid_dual"] >= plan.mean_rate * (1 - PLANNER_REL)  # no grid path beats the dual


def test_the_certified_bound_is_above_the_plan_and_other_flights(plan):
    ub = plan.info["upper_bound"]
    straight = score_plan(SMALL, np.linspace(SMALL.q0, SMALL.qF, SMALL.N)).rate
    assert ub >= plan.mean_rate and ub >= straight and 0 < plan.info["gap"] < 1
    assert plan.mean_rate > straight  # the DP's flight beats the straight line on this scenario


def test_the_two_user_bound_is_the_weighted_sum_maximum():
    rng = np.random.default_rng(0)
    for _ in range(200):
        g = rng.exponential(size=2) * 10 ** rng.uniform(-2, 3, 2)
        w = rng.dirichlet([1.0, 1.0])
        value, r_0, r_1 = two_user_bound(g[0], g[1], w[0], w[1])
        assert value == pytest.approx(weighted_sum_bound(g, w), rel=1e-9)
        grid = np.linspace(0, 1, 1001)
        assert value >= np.max(w[0] * np.log2(1 + grid * g[0]) + w[1] * np.log2(1 + (1 - grid) * g[1]))
        assert w[0] * r_0 + w[1] * r_1 <= value
    assert two_user_bound(0.0, 5.0, 0.5, 0.5)[2] == np.log2(6.0)  # one gain zero: all to the other


def test_the_relaxed_states_bound_the_gains_in_their_cells():
    """The premise of the bound: G_k(q) <= N_t (2^Rbar_k - 1) for the cell's single-antenna bound."""
    relaxed = SdmaRelaxedDP(SMALL, 6.25)
    rng = np.random.default_rng(1)
    for _ in range(20):
        q = rng.uniform([-300.0, -80.0], [-200.0, 80.0])
        gains = slot_bounds(slot_channel_at(SMALL, q)).gains
        for k in range(2):
            single = SMALL.node_config(k).replace(antennas=1)
            rbar = region_rate_bound(single, q[0] - 1.0, q[0] + 1.0, q[1] - 1.0, q[1] + 1.0)
            assert gains[k] <= relaxed.n_t * (np.exp2(rbar) - 1)


def test_what_it_does_not_plan_is_refused_naming_the_field():
    with pytest.raises(PlannerMismatch, match=r"antennas=1 \(it plans a UAV of >= 2 antennas"):
        solve_registered("dp-miso-sdma", SMALL.replace(antennas=1))
    five = (*SMALL.ground_nodes, (-60.0, 30.0), (-60.0, -30.0), (-30.0, 0.0))
    with pytest.raises(PlannerMismatch, match=r"5 ground node\(s\) \(it takes 2 <= K <= 4\)"):
        solve(SMALL.replace(ground_nodes=five))
    with pytest.raises(ValueError, match=r"ios_shape must have M = M_y M_z in \[1, 256\]"):
        solve(SMALL.replace(ios_shape=(20, 20)))


def _fly(env: gym.Env, moves: np.ndarray, weights: np.ndarray) -> dict:
    env.reset(seed=0)
    for move, a_w in zip(moves, weights, strict=True):
        _, _, done, _, info = env.step(np.array([*move, a_w]))
    assert done
    return info


def test_the_plan_flown_through_the_env_scores_what_the_planner_reports(plan):
    """The plan's moves / D as actions (the arrival guard leaves a feasible plan as it is, to
    rounding): the env's score is the planner's rate whatever the weights flown, and no episode
    scores above the certified bound (nor does the env's own max-min)."""
    env = gym.make(MISO_SDMA_ID, config=SMALL)
    q = plan.trajectory
    moves = np.diff(q, axis=0) / SMALL.D
    info = _fly(env, moves, np.random.default_rng(0).uniform(-1, 1, len(moves)))
    assert np.allclose(env.unwrapped.trajectory, q, rtol=0, atol=1e-9)
    assert info["score"] == pytest.approx(plan.mean_rate, rel=PLANNER_REL)
    assert info["min_rate"] <= info["score"] * (1 + PLANNER_REL)
    rng = np.random.default_rng(1)
    for _ in range(2):
        info = _fly(env, rng.uniform(-1, 1, (SMALL.N - 1, 2)), rng.uniform(-1, 1, SMALL.N - 1))
        assert info["min_rate"] <= info["score"] <= plan.info["upper_bound"]


@pytest.mark.parametrize(
    "weights", [[np.nan, np.nan], [0.5, np.inf], [0.6, 0.6], [-0.5, 1.5], [1.0], "ab"], ids=str
)
def test_bad_start_weights_are_refused_before_any_bound(weights):
    """NaN weights passed the sign and sum checks (every comparison with NaN is False) and gave an
    infinite "bound": finite numbers are required too."""
    with pytest.raises(ValueError, match=r"start_weights must be K = 2 finite numbers >= 0 summing to 1"):
        sdma_bound(SMALL, 12.5, start_weights=weights)
