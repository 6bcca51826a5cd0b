"""dp-star's plan polished by AO with a trust-region SCA step on a continuous trajectory
(``baselines.ao_star``): feasible by the project's check, never below its start, never above
dp-star's certified bound, off the grid with a gain where the step finds one; bad inputs refused by
name; the registry's refusals name the right planner."""

from __future__ import annotations

import numpy as np
import pytest

from baselines import registry
from baselines.ao_star import gradients, solve, trust_step
from baselines.dp_star import solve as dp_star
from baselines.registry import PlannerMismatch
from ios_uav_env import ScenarioConfig, check_trajectory, score_plan
from ios_uav_env.model.star_maps import frontier_maps

#: dp-star's small scenario (tests/baselines/test_dp_star.py): the STARControl surface and radio
#: (plane x = 0, -110 dBm) with 4 x 4 elements, on a short flight past it.
SMALL = ScenarioConfig(
    surface="star", star_access="noma", ground_nodes=((-5.0, 2.0), (5.0, -2.0)), ios_center=(0.0, 0.0, 5.0),
    ios_shape=(4, 4), noise_dbm=-110.0, T=8.0, q0=(-150.0, -75.0), qF=(-150.0, 75.0),
)  # fmt: skip
RESOLUTION = 12.5


@pytest.fixture(scope="module")
def start():
    return dp_star(SMALL, resolution=RESOLUTION)


@pytest.fixture(scope="module")
def plan(start):
    return solve(SMALL, start, max_rounds=8)


def test_the_plan_is_feasible_not_below_dp_star_and_below_the_bound(start, plan):
    assert plan.scheme == "ao-star" and plan.feasible and check_trajectory(SMALL, plan.trajectory).feasible
    assert plan.mean_rate == pytest.approx(score_plan(SMALL, plan.trajectory).rate, rel=1e-12)
    assert plan.info["start_rate"] == pytest.approx(start.mean_rate, rel=1e-12)
    assert plan.mean_rate >= start.mean_rate
    assert plan.info["upper_bound"] == start.info["upper_bound"]
    assert plan.mean_rate <= plan.info["upper_bound"]
    assert 1 <= plan.info["rounds"] == len(plan.history) <= 8
    accepted = [r for r in plan.history if r["accepted"]]
    assert plan.info["accepted"] == len(accepted)
    scores = [start.mean_rate] + [r["score"] for r in accepted]
    assert all(b > a for a, b in zip(scores, scores[1:], strict=False))  # each accepted step gains
    assert plan.mean_rate == (scores[-1] if accepted else start.mean_rate)


def test_the_step_moves_the_way_points_off_the_grid_and_gains(start, plan):
    # on this scenario the first-order steps gain over dp-star's plan (corridor-refined included)
    assert plan.info["accepted"] >= 1 and plan.mean_rate > start.mean_rate * (1 + 1e-3)
    moved = np.linalg.norm(plan.trajectory - start.trajectory, axis=1)
    assert moved.max() > 0.1
    # the refinement's finest lattice is RESOLUTION / 8 from grid points: ao-star's way-points leave it
    lattice = RESOLUTION / 8
    off = np.abs(plan.trajectory / lattice - np.round(plan.trajectory / lattice)).max(axis=1)
    assert np.any(off > 1e-3)


def test_the_trust_step_keeps_the_radius_the_speed_limit_and_the_ends():
    line = np.linspace(SMALL.q0, SMALL.qF, SMALL.N)
    grad = np.tile([1.0, 0.0], (SMALL.N, 1))  # every way-point pulled towards the surface (+x)
    q, status = trust_step(SMALL, line, grad, 3.0)
    assert status in ("optimal", "optimal_inaccurate") and q is not None
    assert check_trajectory(SMALL, q).feasible
    assert np.array_equal(q[[0, -1]], line[[0, -1]])
    assert np.all(np.linalg.norm(q - line, axis=1) <= 3.0 + 1e-6)
    assert np.all(q[1:-1, 0] > line[1:-1, 0])  # it moved along the gradient


def test_the_gradient_points_uphill():
    q = np.linspace(SMALL.q0, SMALL.qF, SMALL.N)
    w = np.array([0.5, 0.5])
    g = gradients(SMALL, q, w)
    users = np.asarray(SMALL.nodes, dtype=float)
    before = frontier_maps(SMALL, q, users).weighted_sum(w)[0]
    moved = q + 0.5 * g / np.linalg.norm(g, axis=1, keepdims=True)
    after = frontier_maps(SMALL, moved, users).weighted_sum(w)[0]
    assert np.all(after > before)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"max_rounds": 0}, "max_rounds must be an integer >= 1"),
        ({"max_rounds": 2.5}, "max_rounds must be an integer >= 1"),
        ({"patience": 0}, "patience must be an integer >= 1"),
        ({"radius": -1.0}, "radius must be a finite number > 0"),
        ({"radius": float("inf")}, "radius must be a finite number > 0"),
        ({"min_radius": 0.0}, "min_radius must be a finite number > 0"),
        ({"radius": 1.0, "min_radius": 2.0}, r"min_radius must be a finite number > 0 and < 1"),
        ({"radius": 50.0, "max_radius": 10.0}, r"radius must be <= max_radius \(10 m\)"),
        ({"max_radius": True}, "max_radius must be a finite number > 0"),
        ({"fd_step": 0.0}, "fd_step must be a finite number > 0"),
    ],
)
def test_bad_arguments_are_refused_by_name(kwargs, field):
    line = np.linspace(SMALL.q0, SMALL.qF, SMALL.N)
    with pytest.raises(ValueError, match=field):
        solve(SMALL, line, **kwargs)


def test_an_infeasible_start_is_refused():
    line = np.linspace(SMALL.q0, SMALL.qF, SMALL.N)
    line[3] += 100.0
    with pytest.raises(ValueError, match="start must be a feasible flight"):
        solve(SMALL, line)


def test_the_registry_routes_noma_to_it_and_tdma_away_from_it():
    assert registry.get("ao-star").accesses == ("noma",)
    assert "ao-star" in [p.name for p in registry.handlers(SMALL)]
    tdma = SMALL.replace(star_access="tdma")
    with pytest.raises(
        PlannerMismatch, match=r"planner 'ao-star'.*star_access='tdma'.*use sca \(baselines\.sca"
    ):
        solve(tdma, np.linspace(tdma.q0, tdma.qF, tdma.N))
    with pytest.raises(
        PlannerMismatch,
        match=r"planner 'sca'.*star_access='noma'.*use dp-star .*, ao-star \(baselines\.ao_star",
    ):
        registry.check("sca", SMALL)
    with pytest.raises(
        PlannerMismatch,
        match=r"planner 'dp'.*star_access='noma'.*use dp-star \(baselines\.dp_star:solve\), ao-star",
    ):
        registry.check("dp", SMALL)


def test_without_a_start_it_runs_dp_star_and_never_falls_below_it():
    plan = solve(SMALL, resolution=RESOLUTION, max_rounds=2, dp_options={"refine": 0})
    dp = dp_star(SMALL, resolution=RESOLUTION, refine=0)
    assert plan.feasible and plan.info["start_rate"] == pytest.approx(dp.mean_rate, rel=1e-12)
    assert dp.mean_rate <= plan.mean_rate <= dp.info["upper_bound"] == plan.info["upper_bound"]
