"""The clairvoyant optimum (baselines.dp_moving): the DP on the exact time-varying rate maps."""

from __future__ import annotations

import numpy as np
import pytest

import ios_uav_env as ie
from baselines import dp, dp_moving, tour
from baselines.grid import grid_axes
from baselines.mpc import MPC, run_online
from baselines.references.mobile import track
from baselines.registry import PlannerMismatch
from ios_uav_env import ScenarioConfig
from ios_uav_env.model.mobility import GaussMarkov
from ios_uav_env.model.motion import node_paths, static_paths

FAST = GaussMarkov(speed=6.0, sigma=2.0)  # fast walkers, so that the slot of a map matters
SMALL = {"ios_shape": (10, 6), "quadrature_nodes": 4}
#: Six slots, a 5 x 5 grid at 12.5 m (margin 0): every grid path can be listed.
TINY = ScenarioConfig(
    ground_node=(-10.0, -20.0), T=6.0, q0=(-20.0, 20.0), qF=(20.0, 20.0), motion=FAST, **SMALL
)
#: One walking node and a UAV with room to follow it.
WALK = ScenarioConfig(
    ground_node=(-60.0, -20.0), T=30.0, q0=(-200.0, 20.0), qF=(200.0, 20.0), motion=FAST, **SMALL
)
#: The online rows may beat the grid optimum by this much (relative): they fly off the grid.
GRID_ALLOWANCE = 0.005


def _grid_paths(config: ScenarioConfig, resolution: float, margin: float) -> np.ndarray:
    """Every grid path (P, N, 2) of the DP's grid: moves <= D between grid points, the last onto qF."""
    xs, ys, _ = grid_axes(config, resolution, margin)
    cells = np.array([(x, y) for y in ys for x in xs])
    reach = config.D * (1 + 1e-12)
    near = np.hypot(*(cells[:, None] - cells[None]).transpose(2, 0, 1)) <= reach
    q0, qf = np.asarray(config.q0), np.asarray(config.qF)
    heads = [[c] for c in np.flatnonzero(np.hypot(*(cells - q0).T) <= reach)]
    for _ in range(config.N - 3):
        heads = [h + [c] for h in heads for c in np.flatnonzero(near[h[-1]])]
    done = [h for h in heads if np.hypot(*(cells[h[-1]] - qf)) <= reach]
    return np.array([np.vstack([q0, cells[h], qf]) for h in done])


def test_the_clairvoyant_dp_is_the_brute_force_optimum_of_a_tiny_grid():
    paths = node_paths(TINY, np.random.default_rng(0))
    every = _grid_paths(TINY, 12.5, 0.0)
    assert len(every) > 1000
    flat = every.reshape(-1, 2)
    rates = ie.node_rates(TINY, flat, np.tile(paths, (len(every), 1, 1)))[0].reshape(len(every), TINY.N)
    best = int(np.argmax(rates.mean(axis=1)))
    brute = ie.score_plan(TINY, every[best], paths=paths).rate
    plan = dp_moving.solve(TINY, paths, resolution=12.5, margin=0.0, refine=0, bound=False)
    assert plan.feasible and plan.info["clairvoyant"]
    assert plan.mean_rate == pytest.approx(brute, rel=1e-12)
    assert plan.info["dp_objective"] == pytest.approx(plan.mean_rate, rel=1e-12)
    # the paths matter: the same search on the node standing still picks another flight
    still = ie.node_rates(TINY, flat, np.tile(static_paths(TINY), (len(every), 1, 1)))[0]
    assert int(np.argmax(still.reshape(len(every), TINY.N).mean(axis=1))) != best
    # the corridor refinement starts from the grid optimum and never loses
    refined = dp_moving.solve(TINY, paths, resolution=12.5, margin=0.0, bound=False)
    assert refined.feasible and refined.mean_rate >= plan.mean_rate
    assert refined.info["grid_objective"] == pytest.approx(plan.mean_rate, rel=1e-12)


def test_the_maps_are_the_scorers_rates():
    paths = node_paths(WALK, np.random.default_rng(1))
    xs, ys, _ = grid_axes(WALK, 10.0)
    maps = dp_moving.rate_maps(WALK, paths[:6], xs, ys)
    q = np.array(
        [[xs[4], ys[3]], [xs[9], ys[1]], [xs[0], ys[0]], [xs[4], ys[3]], [xs[2], ys[5]], [xs[7], ys[2]]]
    )
    got = maps[np.arange(6), 0, [3, 1, 0, 3, 5, 2], [4, 9, 0, 4, 2, 7]]
    np.testing.assert_array_equal(got, ie.node_rates(WALK, q, paths[:6])[0])
    assert not np.array_equal(maps[0], maps[5])  # one map per slot's node position


@pytest.fixture(scope="module")
def walk():
    """WALK's episode 3: the true path, the clairvoyant plans and the online rows on it."""
    seed = 3
    paths = node_paths(WALK, np.random.default_rng(seed))
    grid = dp_moving.solve(WALK, paths, resolution=5.0, refine=0, bound_resolution=5.0)
    refined = dp_moving.solve(WALK, paths, resolution=5.0, bound=False)
    online = {p.name: run_online(WALK, p, seed) for p in (MPC(k=1), MPC(k=1, planner="dp", refine=0))}
    tracks = {k: track(WALK, seed, k)[0] for k in ("exact", "reports")}
    assert all(np.array_equal(run.paths, paths) for run in online.values())  # one seed, one truth
    return paths, grid, refined, online, tracks


def test_the_clairvoyant_dp_is_between_every_row_and_the_bound(walk):
    paths, grid, refined, online, tracks = walk
    bound = grid.info["upper_bound"]
    assert grid.info["gap"] == pytest.approx(bound / grid.mean_rate - 1.0, rel=1e-12)
    assert grid.mean_rate <= refined.mean_rate <= bound
    assert refined.mean_rate >= tour.solve(WALK, paths=paths).mean_rate  # the clairvoyant tour
    # MPC-DP on the same grid flies a path of that grid: the grid optimum is above it exactly
    assert grid.mean_rate >= online["mpc-dp-k1"].rate * (1 - 1e-12)
    rows = [run.rate for run in online.values()]
    rows += [ie.score_plan(WALK, q, paths=paths).rate for q in tracks.values()]
    for rate in rows:  # off-grid flights: up to the grid's allowance
        assert refined.mean_rate >= rate * (1 - GRID_ALLOWANCE)


def test_static_paths_give_the_dp_plan():
    config = WALK.replace(motion=None)
    plan = dp.solve(config, resolution=10.0)
    for paths in (None, static_paths(config)):
        same = dp_moving.solve(config, paths, resolution=10.0, refine=0, bound=False)
        assert same.scheme == "dp-clairvoyant" and "clairvoyant" not in same.info
        assert same.mean_rate == pytest.approx(plan.mean_rate, rel=1e-12)
    two = config.replace(ground_nodes=((-60.0, -20.0), (80.0, -40.0)))
    a, b = dp.solve(two, resolution=10.0), dp_moving.solve(two, resolution=10.0)
    assert b.scheme == "dp-clairvoyant" and b.mean_rate == a.mean_rate
    assert b.info["upper_bound"] == a.info["upper_bound"]


def test_several_moving_nodes_plan_under_the_certified_bound():
    config = WALK.replace(
        ground_nodes=((-60.0, -20.0), (80.0, -40.0)), T=20.0, q0=(-100.0, 20.0), qF=(100.0, 20.0)
    )
    paths = node_paths(config, np.random.default_rng(0))
    plan = dp_moving.solve(config, paths, resolution=10.0)
    assert plan.scheme == "dp-clairvoyant" and plan.feasible and plan.info["clairvoyant"]
    assert plan.mean_rate == ie.maxmin_rate(config, plan.trajectory, paths)
    assert tour.solve(config, paths=paths).mean_rate <= plan.mean_rate <= plan.info["upper_bound"]


def test_refine_path_never_loses_and_keeps_an_optimum():
    paths = node_paths(WALK, np.random.default_rng(2))
    q, value = dp_moving.grid_plan(WALK, paths, 10.0)
    new, new_value = dp_moving.refine_path(WALK, paths, q, 5.0)
    assert new_value >= value and ie.check_trajectory(WALK, new).feasible
    assert new_value == pytest.approx(ie.score_plan(WALK, new, paths=paths).rate, rel=1e-12)
    assert not np.array_equal(new, q)  # off the 10 m grid, the flight gains
    final, final_value, sweeps = dp_moving.refine_plan(WALK, paths, q, value, 10.0, 2)
    assert final_value >= new_value and sweeps >= 2
    again, again_value = dp_moving.refine_path(WALK, paths, final, 10.0 / 4)
    np.testing.assert_array_equal(again, final)  # converged at the last level: it stays
    assert again_value == pytest.approx(final_value, rel=1e-12)


def test_bad_input_is_refused():
    paths = node_paths(WALK, np.random.default_rng(0))
    with pytest.raises(PlannerMismatch, match="motion without paths="):
        dp_moving.solve(WALK)
    with pytest.raises(ValueError, match=r"resolution must be a finite number in \(0, D=25\] m"):
        dp_moving.solve(WALK, paths, resolution=30.0)
    with pytest.raises(ValueError, match="refine must be an integer >= 0"):
        dp_moving.solve(WALK, paths, resolution=10.0, refine=-1)
    with pytest.raises(ValueError, match=r"paths must have shape \(N, K, 2\)"):
        dp_moving.solve(WALK, paths[1:], resolution=10.0)
    two = WALK.replace(ground_nodes=((-60.0, -20.0), (80.0, -40.0)))
    two_paths = node_paths(two, np.random.default_rng(0))
    with pytest.raises(ValueError, match=r"refine applies to one node \(K = 1\), got refine=3 with K=2"):
        dp_moving.solve(two, two_paths, resolution=10.0, refine=3)
    with pytest.raises(ValueError, match="weights must be given"):
        dp_moving.grid_plan(two, two_paths, 10.0)
    with pytest.raises(ValueError, match="weights must be K=2 numbers >= 0 summing to 1"):
        dp_moving.grid_plan(two, two_paths, 10.0, weights=np.array([0.7, 0.7]))


def test_refine_path_keeps_the_flight_on_a_tie():
    """Two window points at the same distance from a node with no surface (the direct link
    alone): the rates tie exactly, and the flight stays where it is."""
    config = ScenarioConfig(ground_node=(10.0, 1.0), surface="none", T=3.0, q0=(-10.0, 0.0), qF=(30.0, 0.0))
    q = np.array([config.q0, (10.0, 0.0), config.qF])
    new, value = dp_moving.refine_path(config, static_paths(config), q, 2.0)
    np.testing.assert_array_equal(new, q)
    assert value == pytest.approx(ie.average_rate(config, q), rel=1e-12)
    with pytest.raises(ValueError, match="trajectory must be a feasible flight"):
        dp_moving.refine_path(config, static_paths(config), q + [[0, 0], [0, 30], [0, 0]], 2.0)
