"""The clairvoyant bound and planner: the certified bound and the tour given the true node paths."""

import numpy as np
import pytest

import ios_uav_env as ie
from baselines import tour
from baselines.dp_bound import (
    RelaxedDP,
    clairvoyant_bound,
    moving_dp_path,
    rate_maps,
    region_rate_bound,
    solve_multinode,
)
from baselines.fixed import fly_hover_fly_path, straight_line_path
from baselines.grid import grid_axes, grid_path
from ios_uav_env import ScenarioConfig
from ios_uav_env.model.motion import GaussMarkov, node_config_at, node_paths, static_paths
from ios_uav_env.model.schedule import dual_value

NODES = ((-100.0, -20.0), (150.0, -60.0))
SMALL = {"ios_shape": (10, 6), "quadrature_nodes": 4, "T": 30.0, "q0": (-200.0, 20.0), "qF": (200.0, 20.0)}
H = 10.0  # m, the relaxed DP's cells


@pytest.fixture(scope="module")
def mobile():
    """Two fast walkers (6 m/s), so that the paths matter for the rates."""
    config = ScenarioConfig(ground_nodes=NODES, motion=GaussMarkov(speed=6.0, sigma=2.0), **SMALL)
    paths = node_paths(config, np.random.default_rng(0))
    return config, paths, solve_multinode(config, resolution=H, paths=paths)


def _trajectories(config, rng, count=4):
    out = [straight_line_path(config)]
    for _ in range(count):  # feasible fly-hover-fly flights through random points
        out.append(fly_hover_fly_path(config, rng.uniform([-150, -100], [150, 100]))[0])
    return out


def test_static_paths_give_todays_bound_and_tour():
    config = ScenarioConfig(ground_nodes=NODES, **SMALL)
    still = static_paths(config)
    a, b = RelaxedDP(config, H), RelaxedDP(config, H, paths=still)
    for w in (np.array([0.5, 0.5]), np.array([0.8, 0.2])):
        (ua, ga), (ub, gb) = a.value(w), b.value(w)
        assert ua == ub and np.array_equal(ga, gb)
    t0, t1 = tour.solve(config), tour.solve(config, paths=still)
    assert np.array_equal(t0.trajectory, t1.trajectory) and t0.mean_rate == t1.mean_rate
    assert "clairvoyant" not in t1.info


def test_clairvoyant_bound_is_above_every_flight_on_the_paths(mobile):
    """UB(w) >= (1/N) sum_n max_k w_k r_k(q[n]; w_k[n]) for feasible flights, the cut is a
    minorant, and the certified bound is above every flight's max-min rate on the paths."""
    config, paths, plan = mobile
    relaxed = RelaxedDP(config, H, paths=paths)
    # slot n's cell bounds are those of the nodes where they are in slot n
    xx, yy = np.meshgrid(relaxed.xs, relaxed.ys)
    assert relaxed.cell_bounds.shape == (config.N, 2, *xx.shape)
    for n in (1, config.N // 2, config.N - 2):
        for k in range(2):
            here = node_config_at(config, k, paths[n, k])
            cells = region_rate_bound(here, xx - H / 2, xx + H / 2, yy - H / 2, yy + H / 2)
            assert np.array_equal(relaxed.cell_bounds[n, k], cells)
    assert not np.array_equal(relaxed.cell_bounds[1], relaxed.cell_bounds[-2])
    rng = np.random.default_rng(4)
    rates = [ie.node_rates(config, q, paths) for q in _trajectories(config, rng)]
    for w in (np.array([0.5, 0.5]), rng.dirichlet(np.ones(2))):
        ub, g = relaxed.value(w)
        for r in rates:
            assert ub >= dual_value(r, w) - 1e-12
        w2 = rng.dirichlet(np.ones(2))
        assert relaxed.value(w2)[0] >= g @ w2 - 1e-12
    bound = plan.info["upper_bound"]
    for r in [*rates, ie.node_rates(config, plan.trajectory, paths)]:
        assert ie.maxmin_schedule(r).value <= bound
    assert plan.info["kelley_lower"] <= bound + 1e-12


def test_clairvoyant_plan_is_scored_on_the_paths(mobile):
    config, paths, plan = mobile
    assert plan.feasible and plan.info["clairvoyant"]
    assert plan.info["plan_source"].startswith(("dp", "tour"))
    assert plan.mean_rate == ie.maxmin_rate(config, plan.trajectory, paths)
    assert plan.mean_rate <= plan.info["upper_bound"]
    assert plan.info["gap"] == pytest.approx(plan.info["upper_bound"] / plan.mean_rate - 1, rel=1e-12)
    # the paths matter: the static positions give other rates for the same flight, and the plan
    # on the paths beats the static tour's flight scored on the paths
    static_tour = tour.solve(config.replace(motion=None))
    assert ie.maxmin_rate(config, plan.trajectory) != plan.mean_rate
    assert plan.mean_rate >= ie.maxmin_rate(config, static_tour.trajectory, paths)


def test_moving_dp_is_the_grid_dp_when_the_rewards_stand_still():
    """One reward map repeated in every slot: the per-slot DP flies the plain grid DP's path."""
    config = ScenarioConfig(ground_nodes=NODES, **SMALL)
    xs, ys, _ = grid_axes(config, H)
    xx, yy = np.meshgrid(xs, ys)
    rates = ie.node_rates(config, np.column_stack([xx.ravel(), yy.ravel()])).reshape(2, *xx.shape)
    reward = np.max(np.array([0.3, 0.7])[:, None, None] * rates, axis=0)
    q = moving_dp_path(config, np.repeat(reward[None], config.N, axis=0), H)
    assert np.array_equal(q, grid_path(config, reward, 0.0, H)[0]) and ie.check_trajectory(config, q).feasible
    # the maps are the scorer's per-slot kernels (its rates on paths, bit for bit: test_dp_moving),
    # the static rates to rounding
    maps = rate_maps(config, static_paths(config), xs, ys)
    np.testing.assert_allclose(maps, np.broadcast_to(rates, maps.shape), rtol=1e-12)


def test_one_moving_node():
    """K = 1: the bound is the relaxed DP at w = 1, above the tour on the path and every flight."""
    config = ScenarioConfig(ground_node=NODES[0], motion=GaussMarkov(speed=6.0, sigma=2.0), **SMALL)
    paths = node_paths(config, np.random.default_rng(1))
    bound = clairvoyant_bound(config, paths, resolution=H)
    plan = tour.solve(config, paths=paths)
    assert plan.mean_rate == ie.score_plan(config, plan.trajectory, paths=paths).rate <= bound
    for q in _trajectories(config, np.random.default_rng(2), 3):
        assert ie.score_plan(config, q, paths=paths).rate <= bound
    with pytest.raises(ValueError, match="paths must have shape"):
        clairvoyant_bound(config, paths[:, :, :1], resolution=H)


def test_clairvoyant_sca_climbs_from_the_clairvoyant_tour(mobile):
    """SCA on the paths: every score on the paths, never below its best start (the clairvoyant
    tour), never above the bound; accepted scores never decrease."""
    from baselines import sca_multi

    config, paths, bound_plan = mobile
    plan = sca_multi.solve(config, max_iters=2, paths=paths)
    assert plan.feasible and plan.info["clairvoyant"]
    assert plan.mean_rate == ie.maxmin_rate(config, plan.trajectory, paths)
    assert plan.mean_rate <= bound_plan.info["upper_bound"]
    tour_start = next(s for s in plan.info["starts"] if s["start"] == "tour")
    assert tour_start["init_score"] < tour_start["score"] <= plan.mean_rate  # SCA climbs from the tour
    accepted = [h["score"] for h in plan.history if h["start"] == "tour" and h["accepted"]]
    assert accepted == sorted(accepted)


def test_static_paths_give_todays_sca():
    from baselines import sca_multi

    config = ScenarioConfig(ground_nodes=NODES, **SMALL)
    a = sca_multi.solve(config, max_iters=1)
    b = sca_multi.solve(config, max_iters=1, paths=static_paths(config))
    assert np.array_equal(a.trajectory, b.trajectory) and a.mean_rate == b.mean_rate


def test_a_given_tour_plan_stands_for_solving_it_again(mobile):
    """``tour_plan=``: solve_multinode and SCA on the paths start from the caller's clairvoyant tour
    and give what they give when they solve it themselves; another config's tour is refused."""
    from baselines import sca_multi

    config, paths, plan = mobile
    tour_plan = tour.solve(config, paths=paths)
    given = solve_multinode(config, resolution=H, paths=paths, tour_plan=tour_plan)
    assert np.array_equal(given.trajectory, plan.trajectory)
    assert given.info["upper_bound"] == plan.info["upper_bound"]
    a = sca_multi.solve(config, max_iters=1, paths=paths)
    b = sca_multi.solve(config, max_iters=1, paths=paths, tour_plan=tour_plan)
    runs = [[(s["start"], s["init_score"], s["score"]) for s in p.info["starts"]] for p in (a, b)]
    assert np.array_equal(a.trajectory, b.trajectory) and runs[0] == runs[1]
    longer = config.replace(T=config.T + 2.0)
    other = tour.solve(longer, paths=node_paths(longer, np.random.default_rng(0)))
    for solve in (
        lambda: solve_multinode(config, resolution=H, paths=paths, tour_plan=other),
        lambda: sca_multi.solve(config, max_iters=1, paths=paths, tour_plan=other),
    ):
        with pytest.raises(ValueError, match="tour_plan"):
            solve()
