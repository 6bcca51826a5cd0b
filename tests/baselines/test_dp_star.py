"""The planner and the certified bound of a STAR surface serving a user on each side at once
(``baselines.dp_star``): plans feasible and below the bound, never below the TDMA plan, the grid DP
against a brute force over grid paths, the bound above random flights and, per cell, above the
pricer's slot optimum; bad inputs refused by name."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from baselines import registry, schemes
from baselines.dp_star import NomaRelaxedDP, noma_bound, refine_plan, solve
from baselines.grid import disk_offsets, grid_axes, grid_path
from baselines.registry import PlannerMismatch
from ios_uav_env import ScenarioConfig, check_trajectory, score_plan
from ios_uav_env.model.star import StarSurface
from ios_uav_env.model.star_maps import frontier_maps
from ios_uav_env.model.star_regions import star_pricer

#: The STARControl scenario's surface and radio (a small surface low on a facade, plane x = 0,
#: -110 dBm), on a short flight past it.
SMALL = ScenarioConfig(
    surface="star", star_access="noma", ground_nodes=((-5.0, 2.0), (5.0, -2.0)), ios_center=(0.0, 0.0, 5.0),
    ios_shape=(4, 4), noise_dbm=-110.0, T=8.0, q0=(-150.0, -75.0), qF=(-150.0, 75.0),
)  # fmt: skip
#: A user near the flight and one behind the surface: unequal SNRs, where NOMA gains over TDMA.
UNEQUAL = SMALL.replace(ground_nodes=((-120.0, 10.0), (5.0, -2.0)))
#: Four slots on a grid of D / 2: few enough grid paths for a brute force.
TINY = SMALL.replace(T=4.0, q0=(-60.0, -20.0), qF=(-60.0, 20.0))


def _random_flights(config: ScenarioConfig, count: int, seed: int) -> list[np.ndarray]:
    """Feasible flights: the straight line plus a random-walk bridge (0 at both ends) whose steps
    keep every move within D."""
    rng = np.random.default_rng(seed)
    line = np.linspace(config.q0, config.qF, config.N)
    spare = (config.D - np.linalg.norm(line[1] - line[0])) / 2 * (1 - 1e-9)
    flights = []
    for _ in range(count):
        angle, size = rng.uniform(0, 2 * np.pi, config.N - 1), spare * rng.uniform(0, 1, config.N - 1)
        walk = np.vstack(
            [[0.0, 0.0], np.cumsum(size[:, None] * np.column_stack([np.cos(angle), np.sin(angle)]), 0)]
        )
        bridge = walk - np.linspace(0, 1, config.N)[:, None] * walk[-1]
        flights.append(line + bridge)
    return flights


@pytest.fixture(scope="module")
def small_plan():
    return solve(SMALL, resolution=12.5)


def test_the_plan_is_feasible_below_its_bound_and_not_below_tdma(small_plan):
    plan = small_plan
    assert plan.scheme == "dp-star" and plan.feasible and check_trajectory(SMALL, plan.trajectory).feasible
    assert plan.mean_rate == pytest.approx(score_plan(SMALL, plan.trajectory).rate, rel=1e-12)
    assert plan.mean_rate <= plan.info["upper_bound"]
    assert plan.info["gap"] == pytest.approx(plan.info["upper_bound"] / plan.mean_rate - 1)
    # the TDMA scenario's DP plan, scored on the NOMA model: NOMA's region holds TDMA's vertices
    tdma = registry.solve("dp", SMALL.replace(star_access="tdma"), resolution=12.5)
    on_noma = score_plan(SMALL, tdma.trajectory).rate
    assert plan.info["tdma_rate"] == pytest.approx(tdma.mean_rate, rel=1e-12)
    assert plan.mean_rate >= on_noma >= tdma.mean_rate * (1 - 1e-9)
    # every candidate was scored by the one scorer; the best, refined, never scores less
    assert plan.info["candidate_rate"] == max(plan.info["candidates"].values())
    assert plan.mean_rate >= plan.info["candidate_rate"]
    assert all(r["score"] <= plan.mean_rate for r in plan.info["refine"])


def test_the_bound_is_above_random_flights_and_the_grid_dual(small_plan):
    ub = small_plan.info["upper_bound"]
    for q in _random_flights(SMALL, 6, seed=0):
        assert check_trajectory(SMALL, q).feasible
        assert score_plan(SMALL, q).rate <= ub
    # any w gives a bound, and Kelley's best is below the ends of the simplex
    assert noma_bound(SMALL, 6.25, max_cuts=1, start_weights=np.array([0.9, 0.1]))[0] >= ub * (1 - 1e-12)
    assert small_plan.info["bound_lower"] <= ub


@pytest.mark.parametrize("config", [SMALL, UNEQUAL], ids=["small", "unequal"])
def test_a_cells_reward_bounds_the_slot_optimum_at_every_point_of_it(config):
    h = 12.5
    relaxed = NomaRelaxedDP(config, h)
    rng = np.random.default_rng(1)
    users = np.array(config.nodes)
    for w_0 in (0.2, 0.5, 0.7):
        w = np.array([w_0, 1 - w_0])
        rewards = relaxed.reward(w, np.moveaxis(relaxed.cell_bounds, 1, 0))[0]
        for _ in range(12):
            iy, ix = rng.integers(0, len(relaxed.ys)), rng.integers(0, len(relaxed.xs))
            q = np.array([relaxed.xs[ix], relaxed.ys[iy]]) + rng.uniform(-h / 2, h / 2, 2)
            if abs(q[0]) < 1e-6:
                continue  # the plane itself: the pricer's roles need a side
            _, f_w = star_pricer(config, q[None], users, StarSurface("es"), "noma")(w)
            assert f_w <= rewards[iy, ix]


def test_the_refinement_keeps_a_flight_feasible_and_never_loses():
    line = np.linspace(UNEQUAL.q0, UNEQUAL.qF, UNEQUAL.N)
    start = score_plan(UNEQUAL, line).rate
    q, score, records = refine_plan(UNEQUAL, line, start, 12.5, levels=2, rounds=2)
    assert check_trajectory(UNEQUAL, q).feasible and score == score_plan(UNEQUAL, q).rate
    assert score > start  # the straight line is no local optimum here
    assert max(r["score"] for r in records) == score  # the rounds kept are those that gained
    same, same_score, tried = refine_plan(UNEQUAL, line, start, 12.5, levels=0)  # nothing to try
    assert np.array_equal(same, line) and same_score == start and tried == []


def test_the_grid_dp_against_a_brute_force_of_grid_paths():
    h = 12.5
    plan = solve(TINY, resolution=h, margin=0.0, tdma_plan=False, refine=0)  # a grid path
    xs, ys, (iy0, ix0) = grid_axes(TINY, h, 0.0)
    users = np.array(TINY.nodes)
    offsets = disk_offsets(h, TINY.D)
    paths = []
    for a, b in itertools.product(offsets, offsets):  # slots 2 and 3; slot 4 is qF
        cells = [(iy0, ix0), (iy0 + a[0], ix0 + a[1]), (iy0 + a[0] + b[0], ix0 + a[1] + b[1])]
        if all(0 <= y < len(ys) and 0 <= x < len(xs) for y, x in cells):
            q = np.array([[xs[x], ys[y]] for y, x in cells] + [list(TINY.qF)])
            if check_trajectory(TINY, q).feasible:
                paths.append(q)
    assert len(paths) >= 10
    # the DP at a w is the best grid path for the per-slot reward f_w (the frontier maps' values)
    w = np.array([0.3, 0.7])
    xx, yy = np.meshgrid(xs, ys)
    value = frontier_maps(TINY, np.column_stack([xx.ravel(), yy.ravel()]), users).weighted_sum(w)[0]
    final = frontier_maps(TINY, np.array([TINY.qF]), users).weighted_sum(w)[0][0]
    _, d_w = grid_path(TINY, value.reshape(xx.shape), final, h, 0.0)
    brute = max(frontier_maps(TINY, q, users).weighted_sum(w)[0].mean() for q in paths)
    assert d_w == pytest.approx(brute, rel=1e-12)
    # no grid path's max-min beats the grid's dual or the certified bound; the plan is a grid path
    best = max(score_plan(TINY, q).rate for q in paths)
    assert plan.mean_rate <= best <= plan.info["upper_bound"]
    assert best <= plan.info["grid_dual"] * (1 + 1e-5)  # the maps' values are f_w to ~1e-6


def test_the_registry_dispatches_a_noma_config_to_it_and_the_others_name_it():
    assert "dp-star" in [p.name for p in registry.handlers(SMALL)]
    for name in ("dp", "sca", "dp-bound", "dp-clairvoyant"):
        with pytest.raises(
            PlannerMismatch, match=r"star_access='noma'.*dp-star \(baselines\.dp_star:solve\)"
        ):
            registry.check(name, SMALL)
    with pytest.raises(PlannerMismatch, match=r"planner 'dp-star'.*star_access='tdma'.*star_access='noma'"):
        solve(SMALL.replace(star_access="tdma"))
    with pytest.raises(PlannerMismatch, match=r"planner 'dp-star'.*surface='ios'"):
        solve(SMALL.replace(surface="ios"))
    with pytest.raises(PlannerMismatch, match=r"planner 'dp-star'.*3 ground node"):
        solve(SMALL.replace(ground_nodes=((-5.0, 2.0), (5.0, -2.0), (8.0, 1.0))))
    plan = schemes.run_scheme("dp-star", SMALL.replace(star_access="tdma"), resolution=12.5, tdma_plan=False)
    assert plan.scheme == "dp-star" and plan.config.star_access == "noma"


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"resolution": 0.0}, "resolution must be"),
        ({"resolution": 30.0}, "resolution must be"),
        ({"margin": -1.0}, "margin must be"),
        ({"bound_resolution": float("nan")}, "bound_resolution must be"),
        ({"max_cuts": 0}, "max_cuts must be"),
        ({"tol": 1.5}, "tol must be"),
        ({"frontier_points": 1}, "frontier angles"),
        ({"refine": -1}, "refine must be"),
        ({"refine_rounds": 1.5}, "refine_rounds must be"),
    ],
)
def test_bad_arguments_are_refused_by_name(kwargs, match):
    with pytest.raises(ValueError, match=match):
        solve(SMALL, **kwargs)


def test_users_on_one_side_are_refused():
    with pytest.raises(ValueError, match="ground_nodes must lie on opposite sides"):
        solve(SMALL.replace(ground_nodes=((-5.0, 2.0), (-8.0, -2.0))))
    with pytest.raises(ValueError, match="start_weights must be K = 2 finite numbers"):
        noma_bound(SMALL, 12.5, start_weights=np.array([0.5, 0.6]))
