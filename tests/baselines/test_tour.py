"""The tour heuristic for several ground nodes."""

import numpy as np
import pytest

import ios_uav_env as ie
from baselines import tour
from baselines.fixed import fly_hover_fly
from ios_uav_env import ScenarioConfig

NODES = ((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0))


@pytest.fixture(scope="module")
def config():
    return ScenarioConfig(ground_nodes=NODES, ios_shape=(10, 6), T=80.0)


@pytest.fixture(scope="module")
def plan(config):
    return tour.solve(config)


def test_tour_is_feasible_and_scored_by_the_one_scorer(config, plan):
    assert plan.scheme == "tour" and plan.feasible
    assert plan.mean_rate == ie.maxmin_rate(config, plan.trajectory)
    # the LP relaxes the integer hover slots of the same route: it bounds the route's score
    assert plan.mean_rate <= plan.info["lp_value"] + 1e-9
    assert sum(plan.info["hover_slots"]) + 1 <= config.N


def test_tour_beats_hovering_over_any_single_candidate(config, plan):
    for _, point in plan.info["candidates"].items():
        q = fly_hover_fly(config, point).trajectory
        assert plan.mean_rate >= ie.maxmin_rate(config, q) - 1e-12


def test_route_trajectory_hovers_where_told(config):
    points = np.array([[-100.0, -20.0], [150.0, -60.0]])
    lp = tour.route_lp(config, points)
    assert lp is not None
    value, x = lp
    spare = int(round(x.sum()))
    q = tour.route_trajectory(config, points, np.array([spare, 0]))
    assert ie.check_trajectory(config, q).feasible
    assert np.sum(np.all(q == points[0], axis=1)) == spare + 1
    assert ie.maxmin_rate(config, q) <= value + 1e-9
    with pytest.raises(ValueError, match="hover_slots must be 2 integers >= 0 summing to"):
        tour.route_trajectory(config, points, np.array([spare, 1]))
    far = np.array([[0.0, 5000.0]])
    assert tour.route_lp(config, far) is None


def test_single_node_tour_matches_hovering_at_the_peak():
    c = ScenarioConfig(ios_shape=(10, 6), T=60.0)
    plan = tour.solve(c)
    peak = ie.rate_peak(c)
    assert plan.mean_rate >= fly_hover_fly(c, (peak.x, peak.y)).mean_rate - 1e-12


def test_bad_arguments():
    c = ScenarioConfig(ios_shape=(10, 6), T=60.0)
    with pytest.raises(ValueError, match="orders must be an integer >= 1"):
        tour.solve(c, orders=0)
    with pytest.raises(ValueError, match="candidates must hold at least one"):
        tour.solve(c, candidates=[])


def test_coinciding_hover_points_keep_n_slots(config):
    """Two stops at the same point (a leg of 0 moves) share one way-point of the path."""
    points = np.array([[-100.0, -20.0], [-100.0, -20.0]])
    lp = tour.route_lp(config, points)
    assert lp is not None
    spare = int(round(lp[1].sum()))
    q = tour.route_trajectory(config, points, np.array([spare - 3, 3]))
    assert q.shape == (config.N, 2) and ie.check_trajectory(config, q).feasible


def test_route_bound_is_above_the_route_lp(config):
    """The pruning bound (weak duality) never cuts a route that could be better."""
    points = np.array([[-100.0, -20.0], [150.0, -60.0], [-40.0, 90.0]])
    path, where = tour.route_legs(config, points)
    r_path = ie.node_rates(config, path)
    value, _, w_star = tour._solve_route(config, r_path, where)
    rng = np.random.default_rng(2)
    weights = rng.dirichlet(np.ones(3), size=20)
    assert tour.route_bound(config, r_path, where, weights) >= value - 1e-12
    assert tour.route_bound(config, r_path, where, w_star[None]) == pytest.approx(value, abs=1e-7)


@pytest.mark.parametrize("count", [1, 2, 3])
def test_route_lp_is_the_documented_lp(config, count):
    """The route LP's value is its optimum: no integer split of the H hover slots scores above
    it (each is a feasible point of the relaxation), its hover slots sum to H, and its dual
    weights certify it (route_bound at them, which counts H slots, equals it)."""
    points = np.array([[-100.0, -20.0], [150.0, -60.0], [-40.0, 90.0]])[:count]
    path, where = tour.route_legs(config, points)
    r_path = ie.node_rates(config, path)
    value, x, w = tour._solve_route(config, r_path, where)
    spare = config.N - len(path)
    assert np.all(x >= 0) and x.sum() == pytest.approx(spare, abs=1e-7)
    assert w.sum() == pytest.approx(1.0) and np.all(w >= 0)
    assert tour.route_bound(config, r_path, where, w[None]) == pytest.approx(value, rel=1e-7)
    rng = np.random.default_rng(count)
    for split in [tour.round_slots(x, spare), *rng.multinomial(spare, np.full(count, 1 / count), size=4)]:
        assert ie.maxmin_rate(config, tour.route_trajectory(config, points, split)) <= value + 1e-9


def test_route_lp_reports_an_infeasible_route(config):
    """A route with more path points than slots has no hover slots to give (H < 0): None."""
    points = np.array([[-100.0, -20.0]])
    path, where = tour.route_legs(config, points)
    r_path = ie.node_rates(config, path)
    too_long = np.hstack([r_path] * (config.N // r_path.shape[1] + 1))
    assert tour._solve_route(config, too_long, where) is None
