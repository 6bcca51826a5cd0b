"""Fault injection for the planners: a node far out of reach, SCA iterates that must not be
accepted, the per-cell rate bound the certificate rests on, and the tour's order of visits."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import ios_uav_env as ie
from baselines import dp, dp_bound, grid, tour
from baselines.dp_bound import RelaxedDP
from baselines.fixed import fly_hover_fly, straight_line
from ios_uav_env import ScenarioConfig, moves_needed, scene_box
from ios_uav_env.model.peak import reachable
from ios_uav_env.model.schedule import dual_value

FAR = (1e6, 1e6)  # a ground node no trajectory comes anywhere near
SILENT = (1e8, 1e8)  # so far that its rate is exactly 0 wherever the UAV can be
NODES = ((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0))


# --- a node far out of reach: the grids are bounded by what the UAV can reach ----------------


@pytest.fixture(scope="module")
def far_config() -> ScenarioConfig:
    return ScenarioConfig(ground_nodes=((-100.0, -20.0), FAR), ios_shape=(10, 6), T=40.0)


def _inside(q: np.ndarray, box) -> bool:
    x_lo, x_hi, y_lo, y_hi = box
    return bool(np.all((q[:, 0] >= x_lo) & (q[:, 0] <= x_hi) & (q[:, 1] >= y_lo) & (q[:, 1] <= y_hi)))


def test_grid_box_is_clipped_to_the_reachable_region_and_keeps_every_feasible_point(far_config):
    c, margin = far_config, grid.DEFAULT_MARGIN
    box, reach, scene = grid.grid_box(c), grid.reach_box(c), scene_box(c, margin)
    span = (c.N - 1) * c.D + 2 * margin + 2 * c.D
    assert box[1] - box[0] <= span and box[3] - box[2] <= span  # not the 1e6 m of the scene's box
    assert grid.grid_shape(c, 2.5) == tuple(len(a) for a in grid.grid_axes(c, 2.5)[1::-1])
    rng = np.random.default_rng(0)
    points = rng.uniform([-800.0, -800.0], [800.0, 800.0], size=(20000, 2))
    points = points[reachable(c, points)]
    far_out = np.argsort(-np.abs(points - np.asarray(c.q0) / 2 - np.asarray(c.qF) / 2).max(axis=1))
    for p in points[np.concatenate([far_out[:40], far_out[-10:]])]:  # the extremes and the middle
        q = fly_hover_fly(c, p).trajectory
        assert ie.check_trajectory(c, q).feasible
        assert _inside(q, reach)  # no feasible trajectory leaves the reach box
        inner = q[[_inside(p[None], scene) for p in q]]  # the points the scene's box held
        assert _inside(inner, box)  # the clip keeps all of them


@pytest.mark.filterwarnings("error")  # no 0 / 0 for a node no point serves
@pytest.mark.parametrize("far", [FAR, SILENT])
def test_tour_with_a_far_node_plans_instead_of_running_out_of_memory(far):
    config = ScenarioConfig(ground_nodes=((-100.0, -20.0), far), ios_shape=(10, 6), T=40.0)
    plan = tour.solve(config)
    assert plan.feasible and plan.mean_rate == ie.maxmin_rate(config, plan.trajectory)
    assert all(np.all(np.isfinite(p)) for p in plan.info["candidates"].values())


@pytest.mark.filterwarnings("error")  # no division by a plan's zero rate either
@pytest.mark.parametrize("far", [FAR, SILENT])
def test_dp_bound_with_a_far_node_certifies_a_bound_above_its_plan(far):
    config = ScenarioConfig(ground_nodes=((-100.0, -20.0), far), ios_shape=(10, 6), T=40.0)
    plan = dp_bound.solve_multinode(config, resolution=5.0, max_cuts=8)
    ub = plan.info["upper_bound"]
    assert plan.feasible and 0.0 <= plan.mean_rate <= ub
    # the far node gets (almost) nothing anywhere the UAV can be: the bound knows it
    assert ub < 1e-9
    if plan.mean_rate > 0:
        assert plan.info["gap"] == pytest.approx(ub / plan.mean_rate - 1, rel=1e-12)
    else:
        assert plan.info["gap"] == (0.0 if ub == 0 else math.inf)


def test_clipping_the_grid_changes_no_dp_plan(monkeypatch):
    """The clipped box removes only points no feasible trajectory reaches: the single-node DP's
    plan and value are those of the unclipped grid."""
    c = ScenarioConfig(ground_node=(30.0, 700.0), ios_shape=(10, 6), T=40.0)
    assert grid.grid_box(c) != scene_box(c, grid.DEFAULT_MARGIN)  # the clip is active here
    clipped = dp.solve(c, resolution=5.0)
    monkeypatch.setattr(
        grid, "grid_box", lambda config, margin=grid.DEFAULT_MARGIN: scene_box(config, margin)
    )
    full = dp.solve(c, resolution=5.0)
    assert clipped.info["grid_shape"] != full.info["grid_shape"]
    np.testing.assert_array_equal(clipped.trajectory, full.trajectory)
    assert clipped.info["dp_objective"] == full.info["dp_objective"]


def test_relaxed_bound_on_a_clipped_box_holds_for_feasible_trajectories():
    c = ScenarioConfig(ground_nodes=((-100.0, -20.0), (30.0, 700.0)), ios_shape=(10, 6), T=40.0)
    relaxed = RelaxedDP(c, 5.0)
    assert not relaxed.open_sides.all()  # a side of B is closed to the outside state
    rng = np.random.default_rng(1)
    points = rng.uniform([-600.0, -400.0], [600.0, 400.0], size=(2000, 2))
    trajectories = [straight_line(c).trajectory]
    trajectories += [fly_hover_fly(c, p).trajectory for p in points[reachable(c, points)][:30]]
    for w in (np.array([0.5, 0.5]), np.array([0.0, 1.0]), np.array([0.9, 0.1])):
        ub, _ = relaxed.value(w)
        for q in trajectories:
            assert ub >= dual_value(ie.node_rates(c, q), w) - 1e-12


def test_grids_too_large_even_when_clipped_are_refused_with_the_limit(monkeypatch):
    """A far node and a long horizon: the reachable region itself is too big for the grids.
    The planners refuse before computing anything, naming the argument and the limit."""
    c = ScenarioConfig(ground_nodes=((-100.0, -20.0), FAR), ios_shape=(10, 6), T=2000.0)

    def must_not_run(*args, **kwargs):
        raise AssertionError("computed before the grid was sized")

    monkeypatch.setattr(ie, "rate_peak", must_not_run)
    limit = r" .* above MAX_TABLE_BYTES=2 GiB: "
    with pytest.raises(ValueError, match="resolution=5 m" + limit + "resolution must be at least about"):
        tour.solve(c)
    monkeypatch.setattr(tour, "solve", must_not_run)
    no_fit = r"no resolution in its range \(0, 25\] m fits: use a shorter T"
    with pytest.raises(ValueError, match="resolution=2.5 m" + limit + no_fit):
        dp_bound.solve_multinode(c)
    with pytest.raises(ValueError, match="resolution=2.5 m" + limit + no_fit):
        dp.solve(c.node_config(1), resolution=2.5)
    short = c.replace(T=40.0)  # the plain DPs fit; the relaxed DP's cells are too fine
    with pytest.raises(ValueError, match="bound_resolution=0.1 m" + limit + "bound_resolution must be at"):
        dp_bound.solve_multinode(short, resolution=5.0, bound_resolution=0.1)


# --- SCA: an iterate that lowers the exact rate, or breaks eq. (10), is never kept -----------

SMALL = ScenarioConfig(T=30, q0=(-150.0, 20.0), qF=(150.0, 20.0), ios_shape=(10, 6), g_element=1e4)
BEHIND = (100.0, 0.0)


def _scripted_solver(monkeypatch, iterates: list[np.ndarray]) -> None:
    """Surrogate.solve returns ``iterates`` in turn (the last one again once they run out)."""
    pytest.importorskip("cvxpy")
    from baselines.sca_problem import Surrogate

    calls = {"n": 0}

    def scripted(self, lin, verbose=False):
        q = iterates[min(calls["n"], len(iterates) - 1)]
        calls["n"] += 1
        return q.copy(), ie.average_rate(self.config, q), "optimal", 0.0

    monkeypatch.setattr(Surrogate, "solve", scripted)


@pytest.mark.parametrize(("eps", "stop"), [(1e-5, "decrease"), (5e-10, "converged")])
def test_sca_keeps_the_better_iterate_when_the_next_is_slightly_worse(monkeypatch, eps, stop):
    from baselines import sca

    line = straight_line(SMALL).trajectory
    better = fly_hover_fly(SMALL, BEHIND).trajectory
    worse = (1 - eps) * better + eps * line  # feasible (a convex combination), a hair lower
    rel = ie.average_rate(SMALL, worse) / ie.average_rate(SMALL, better) - 1
    assert -1e-4 < rel < 0  # inside the stopping tolerance: only the sign says "worse"
    _scripted_solver(monkeypatch, [better, worse])
    plan = sca.solve(SMALL, init=line, tol=1e-4, max_iters=10)
    np.testing.assert_array_equal(plan.trajectory, better)
    assert plan.mean_rate == ie.average_rate(SMALL, better)
    assert plan.info["starts"][0]["stop"] == stop
    assert [h["accepted"] for h in plan.history] == [True, True, False]


def test_sca_never_returns_an_infeasible_iterate(monkeypatch):
    from baselines import sca

    line = straight_line(SMALL).trajectory
    better = fly_hover_fly(SMALL, BEHIND).trajectory
    teleport = better.copy()
    teleport[1:-1] = BEHIND  # hovers at the peak from slot 2 to N - 1: a higher rate, jumps > D
    assert not ie.check_trajectory(SMALL, teleport).feasible
    assert ie.average_rate(SMALL, teleport) > ie.average_rate(SMALL, better)
    _scripted_solver(monkeypatch, [better, teleport])
    with pytest.warns(RuntimeWarning, match="infeasible_iterate"):
        plan = sca.solve(SMALL, init=line, max_iters=10)
    assert plan.feasible
    np.testing.assert_array_equal(plan.trajectory, better)
    assert plan.info["starts"][0]["stop"] == "infeasible_iterate"
    assert plan.history[-1]["status"].startswith("infeasible_iterate") and not plan.history[-1]["accepted"]


# --- the certified bound rests on a bound of the rate over each whole cell -------------------


@pytest.mark.parametrize("surface", ["ios", "none"])
def test_relaxed_bound_is_above_hovering_at_each_nodes_own_peak_on_coarse_cells(surface):
    """UB(w) >= (1/N) sum_n f_w(q[n]) for every feasible q: at w = e_k and 20 m cells, hovering
    at node k's peak (between cell centres) must not beat it. A bound read at the cell centres
    is beaten by up to about 1e-2 bps/Hz here."""
    c = ScenarioConfig(ground_nodes=NODES, T=300.0, ios_shape=(10, 6), quadrature_nodes=4, surface=surface)
    relaxed = RelaxedDP(c, 20.0)
    for k in range(c.K):
        peak = ie.rate_peak(c.node_config(k))
        q = fly_hover_fly(c, (peak.x, peak.y)).trajectory
        w = np.eye(c.K)[k]
        ub, _ = relaxed.value(w)
        assert ub >= ie.node_rates(c, q)[k].mean(), k


# --- the tour: the orders tried are those with the fewest moves ------------------------------


def _moves(config: ScenarioConfig, points) -> int:
    stops = [config.q0, *points, config.qF]
    return sum(moves_needed(math.dist(a, b), config.D) for a, b in itertools.pairwise(stops))


@pytest.mark.parametrize(("T", "orders"), [(60.0, 1), (80.0, 2)])
def test_tour_visits_its_hover_points_in_one_of_the_shortest_orders(T, orders):
    c = ScenarioConfig(ground_nodes=NODES, ios_shape=(10, 6), T=T)
    plan = tour.solve(c, orders=orders)
    points = plan.info["hover_points"]
    assert len(points) >= 2  # the order matters
    ranked = sorted(_moves(c, perm) for perm in itertools.permutations(points))
    assert _moves(c, points) <= ranked[orders - 1]
