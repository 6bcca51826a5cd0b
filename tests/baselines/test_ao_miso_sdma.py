"""dp-miso-sdma's plan polished by AO with a trust-region SCA step (``baselines.ao_miso_sdma``):
feasible by the project's check, never below its start, never above the certified bound, for two
and three users; its gradients are the scorer's own slot function; the K-user bound is the
weighted-sum maximum; bad inputs and configs refused by name."""

from __future__ import annotations

import numpy as np
import pytest

from baselines import registry
from baselines.ao_miso_sdma import active_settings, gradients, solve
from baselines.dp_miso_sdma import sdma_bound, water_filling_bound
from baselines.dp_miso_sdma import solve as dp_miso_sdma
from baselines.registry import PlannerMismatch
from ios_uav_env import check_trajectory, score_plan
from ios_uav_env.envs.miso_sdma import SDMA_CONFIG
from ios_uav_env.model.miso import weighted_sum_bound
from ios_uav_env.model.miso_sdma import sdma_pricer, slot_points
from ios_uav_env.model.regions import maxmin_regions
from tests.tolerances import PLANNER_REL, RATE_REL

#: The SDMA ids' scenario on a short flight (5 slots) and a coarse grid (as test_dp_miso_sdma.py).
SMALL = SDMA_CONFIG.replace(T=5.0, q0=(-250.0, -40.0), qF=(-250.0, 40.0))
#: The same with a third user between the two.
THREE = SMALL.replace(ground_nodes=(*SMALL.ground_nodes, (-60.0, 30.0)))
RESOLUTION = 12.5


@pytest.fixture(scope="module")
def start():
    return dp_miso_sdma(SMALL, resolution=RESOLUTION)


@pytest.fixture(scope="module")
def plan(start):
    return solve(SMALL, start, max_rounds=3)


@pytest.fixture(scope="module")
def start3():
    return dp_miso_sdma(THREE, resolution=2 * RESOLUTION)  # a coarser grid: three users cost more


def _check_plan(config, start_rate, plan, upper):
    assert plan.feasible and check_trajectory(config, plan.trajectory).feasible
    assert plan.mean_rate == pytest.approx(score_plan(config, plan.trajectory).rate, rel=1e-12)
    assert plan.info["start_rate"] == pytest.approx(start_rate, rel=1e-12)
    assert plan.mean_rate >= start_rate
    assert plan.mean_rate <= plan.info["upper_bound"] == pytest.approx(upper, rel=1e-12)
    assert plan.info["gap"] == pytest.approx(upper / plan.mean_rate - 1, rel=1e-12)
    accepted = [r for r in plan.history if r["accepted"]]
    assert plan.info["accepted"] == len(accepted) and plan.info["rounds"] == len(plan.history)
    scores = [start_rate] + [r["score"] for r in accepted]
    assert all(b > a for a, b in zip(scores, scores[1:], strict=False))  # each accepted step gains
    assert plan.mean_rate == (scores[-1] if accepted else start_rate)


def test_two_users_feasible_not_below_dp_miso_sdma_and_below_its_bound(start, plan):
    assert plan.scheme == "ao-miso-sdma" and 1 <= plan.info["rounds"] <= 3
    _check_plan(SMALL, start.mean_rate, plan, start.info["upper_bound"])
    # on this scenario the first-order steps gain over the grid plan and leave the grid
    assert plan.info["accepted"] >= 1 and plan.mean_rate > start.mean_rate * (1 + 1e-3)
    off = np.abs(plan.trajectory / RESOLUTION - np.round(plan.trajectory / RESOLUTION)).max(axis=1)
    assert np.any(off > 1e-3)


def test_three_users_from_the_grid_plan(start3):
    plan = solve(THREE, start3, max_rounds=1)
    _check_plan(THREE, start3.mean_rate, plan, start3.info["upper_bound"])
    assert start3.mean_rate <= start3.info["upper_bound"] and len(plan.info["bound_weights"]) == 3
    assert start3.info["grid_dual"] >= start3.mean_rate * (1 - PLANNER_REL)  # no grid path beats the dual


@pytest.mark.parametrize("users", [3, 4])
def test_three_and_four_users_from_the_straight_line_with_sdma_bound(users):
    config = THREE if users == 3 else THREE.replace(ground_nodes=(*THREE.ground_nodes, (-150.0, 60.0)))
    line = np.linspace(config.q0, config.qF, config.N)
    from_line = solve(config, line, max_rounds=1, bound_resolution=6.25)
    # no bound carried by a bare flight: sdma_bound at 6.25 m (computed apart), above the plan
    _check_plan(config, score_plan(config, line).rate, from_line, sdma_bound(config, 6.25)[0])
    assert from_line.info["bound_seconds"] > 0 and len(from_line.info["bound_weights"]) == users


def test_the_gradients_are_the_slot_values_the_scorer_computes(start):
    q = start.trajectory
    points, _ = slot_points(SMALL, q)
    w = maxmin_regions(sdma_pricer(points), 2, tol=1e-9).dual_weights
    active = active_settings(points, w)
    assert np.all(points[np.arange(len(q)), active] @ w == (points @ w).max(axis=1))
    h = 0.5
    grad = gradients(SMALL, q, w, active, h)
    assert np.all(grad[[0, -1]] == 0)
    shift = np.array([h, 0.0])
    plus, _ = slot_points(SMALL, q + shift)
    minus, _ = slot_points(SMALL, q - shift)
    same = (active_settings(plus, w) == active) & (active_settings(minus, w) == active)
    fd = ((plus @ w).max(axis=1) - (minus @ w).max(axis=1)) / (2 * h)
    assert same[1:-1].any()
    np.testing.assert_allclose(grad[1:-1, 0][same[1:-1]], fd[1:-1][same[1:-1]], rtol=1e-9, atol=1e-12)


def test_the_k_user_bound_is_the_weighted_sum_maximum():
    rng = np.random.default_rng(0)
    for k in (2, 3, 4):
        for _ in range(100):
            g = rng.exponential(size=k) * 10 ** rng.uniform(-2, 4, k)
            w = rng.dirichlet(np.ones(k))
            value, rates = water_filling_bound(g, w)
            assert value == pytest.approx(weighted_sum_bound(g, w), rel=1e-9)
            assert w @ rates <= value  # a feasible point: a valid cut
            powers = rng.dirichlet(np.ones(k), size=200)  # every split of the power is below it
            assert value >= np.max(np.log2(1 + powers * g) @ w)
    grid = water_filling_bound(np.array([[1.0, 0.0], [4.0, 0.0], [0.0, 0.0]]), np.full(3, 1 / 3))
    assert grid[0][1] == 0.0 and np.all(grid[1][:, 1] == 0)  # no gain anywhere: nothing


def test_the_budget_stops_it_and_the_registry_dispatches(start):
    plan = registry.solve("ao-miso-sdma", SMALL, start=start, max_seconds=1e-9)
    assert plan.info["stop"] == "max_seconds" and plan.info["rounds"] == 0
    assert np.array_equal(plan.trajectory, start.trajectory)
    assert plan.mean_rate == pytest.approx(start.mean_rate, rel=PLANNER_REL)


def test_what_it_does_not_plan_is_refused_naming_the_field():
    with pytest.raises(PlannerMismatch, match=r"planner 'ao-miso-sdma'.*antennas=1 \(it plans a UAV of >= 2"):
        registry.solve("ao-miso-sdma", SMALL.replace(antennas=1))
    with pytest.raises(PlannerMismatch, match=r"antennas=1.*; use .*sca \(baselines\.sca:solve\)"):
        solve(SMALL.replace(antennas=1))
    five = (*THREE.ground_nodes, (-60.0, -30.0), (-30.0, 0.0))
    with pytest.raises(PlannerMismatch, match=r"5 ground node\(s\) \(it takes 2 <= K <= 4\)"):
        solve(SMALL.replace(ground_nodes=five))
    with pytest.raises(ValueError, match=r"ao-miso-sdma: config: surface must be 'ios' for SDMA"):
        solve(SMALL.replace(surface="ris"))
    with pytest.raises(
        ValueError, match=r"ao-miso-sdma: config: ios_shape must have M = M_y M_z in \[1, 256\]"
    ):
        solve(SMALL.replace(ios_shape=(20, 20)))


def test_bad_arguments_are_refused_by_name():
    line = np.linspace(SMALL.q0, SMALL.qF, SMALL.N)
    for kwargs, field in [({"max_rounds": 0}, "max_rounds"), ({"patience": 0}, "patience"),
                          ({"max_seconds": 0.0}, "max_seconds"), ({"fd_step": -1.0}, "fd_step"),
                          ({"radius": 30.0}, "radius must be <= max_radius"),
                          ({"min_radius": 10.0}, "min_radius")]:  # fmt: skip
        with pytest.raises(ValueError, match=field):
            solve(SMALL, line, **kwargs)
    with pytest.raises(ValueError, match=r"start must be a feasible \(N = 5, 2\) flight"):
        solve(SMALL, line * 3)


def test_a_plan_of_another_config_carries_no_bound(start):
    """Only dp-miso-sdma's plan of this very config certifies it: a start planned on another config
    (here 3 dB more noise, the same geometry) has its bound recomputed, not copied."""
    noisier = SMALL.replace(noise_dbm=SMALL.noise_dbm + 3.0)
    plan = solve(noisier, start, max_rounds=1, bound_resolution=12.5)
    assert plan.info["bound_seconds"] > 0
    assert plan.info["upper_bound"] == pytest.approx(sdma_bound(noisier, 12.5)[0], rel=RATE_REL)
    assert plan.info["upper_bound"] < start.info["upper_bound"]  # the noisier config's bound is lower
