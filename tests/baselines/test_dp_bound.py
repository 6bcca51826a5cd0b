"""The certified upper bound for several ground nodes (baselines.dp_bound via baselines.dp)."""

import numpy as np
import pytest

import ios_uav_env as ie
from baselines import dp, tour
from baselines.dp_bound import RelaxedDP, region_rate_bound, relaxed_offsets
from baselines.fixed import fly_hover_fly, straight_line_path
from ios_uav_env import ScenarioConfig
from ios_uav_env.model.schedule import dual_value

NODES = ((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0))
SMALL = {"ios_shape": (10, 6), "quadrature_nodes": 4}


@pytest.mark.parametrize("surface", ["ios", "ris", "none"])
def test_rectangle_bound_holds_everywhere_and_is_tight_on_points(surface):
    c = ScenarioConfig(surface=surface)
    rng = np.random.default_rng(3)
    for _ in range(200):
        x0, y0 = rng.uniform(-400, 400), rng.uniform(-250, 250)
        w, h = rng.uniform(0.1, 60.0, size=2)
        bound = region_rate_bound(c, x0, x0 + w, y0, y0 + h)
        pts = np.column_stack([rng.uniform(x0, x0 + w, 100), rng.uniform(y0, y0 + h, 100)])
        pts = np.vstack([pts, [[x0, y0], [x0 + w, y0 + h]]])
        assert bound >= ie.slot_rates(c, pts).max()
    # a degenerate rectangle is a point: the bound is the rate there (up to the slack)
    pts = rng.uniform(-300, 300, size=(20, 2))
    b = region_rate_bound(c, pts[:, 0], pts[:, 0], pts[:, 1], pts[:, 1])
    np.testing.assert_allclose(b, ie.slot_rates(c, pts), rtol=1e-8)
    # half-planes (infinite bounds): above every sampled rate in them
    far = region_rate_bound(c, 150.0, np.inf, -np.inf, np.inf)
    pts = np.column_stack([rng.uniform(150, 2000, 500), rng.uniform(-2000, 2000, 500)])
    assert far >= ie.slot_rates(c, pts).max()


def test_relaxed_offsets_cover_every_continuous_move():
    h, d = 5.0, 25.0
    off = {tuple(o) for o in relaxed_offsets(h, d)}
    rng = np.random.default_rng(0)
    p = rng.uniform(-1000, 1000, size=(5000, 2))
    ang = rng.uniform(0, 2 * np.pi, 5000)
    q = p + d * rng.uniform(0, 1, 5000)[:, None] * np.column_stack([np.cos(ang), np.sin(ang)])
    cp, cq = np.round(p / h).astype(int), np.round(q / h).astype(int)  # cells of side h at k h
    for a, b in zip(cp, cq, strict=True):
        assert (b[1] - a[1], b[0] - a[0]) in off


@pytest.fixture(scope="module")
def scenario():
    config = ScenarioConfig(ground_nodes=NODES, T=70.0, **SMALL)
    return config, dp.solve(config, resolution=5.0)


def test_bound_is_above_every_plan_found(scenario):
    config, plan = scenario
    ub = plan.info["upper_bound"]
    assert plan.feasible and plan.scheme == "dp"
    assert plan.mean_rate == ie.maxmin_rate(config, plan.trajectory)
    assert plan.info["gap"] == pytest.approx(ub / plan.mean_rate - 1, rel=1e-12)
    t = tour.solve(config)
    candidates = [t.trajectory, straight_line_path(config), plan.trajectory]
    candidates += [fly_hover_fly(config, p).trajectory for p in t.info["candidates"].values()]
    for q in candidates:
        assert ie.check_trajectory(config, q).feasible
        assert ie.maxmin_rate(config, q) <= ub
    assert plan.info["kelley_lower"] <= ub + 1e-12
    assert t.mean_rate >= 0.9 * ub  # the bound is not absurdly loose


def test_relaxed_value_bounds_the_dual_objective_of_any_trajectory(scenario):
    """UB(w) >= (1/N) sum_n max_k w_k r_k(q[n]) for feasible q, including ones that leave the
    grid box (margin 0), and the cut G is a valid minorant of UB."""
    config, _ = scenario
    relaxed = RelaxedDP(config, 5.0, margin=0.0)
    rng = np.random.default_rng(5)
    trajectories = [straight_line_path(config)]
    for _ in range(20):  # random feasible walks: fly-hover-fly through random far points
        p = rng.uniform([-300, -400], [300, 400])
        trajectories.append(fly_hover_fly(config, p).trajectory)
    for _ in range(4):
        w = rng.dirichlet(np.ones(config.K))
        ub, g = relaxed.value(w)
        for q in trajectories:
            assert ub >= dual_value(ie.node_rates(config, q), w) - 1e-12
        for _ in range(5):
            w2 = rng.dirichlet(np.ones(config.K))
            assert relaxed.value(w2)[0] >= g @ w2 - 1e-12


def test_k1_dp_unchanged_and_bad_arguments():
    c = ScenarioConfig(T=40.0, **SMALL)
    assert "upper_bound" not in dp.solve(c, resolution=5.0).info
    from baselines.dp_bound import solve_multinode

    with pytest.raises(ValueError, match="K >= 2"):
        solve_multinode(c)
    c3 = ScenarioConfig(ground_nodes=NODES, T=70.0, **SMALL)
    with pytest.raises(ValueError, match="start_weights must be K=3"):
        solve_multinode(c3, resolution=5.0, start_weights=np.array([0.5, 0.5]))


def test_tight_horizon_off_grid_line_is_bounded():
    """At T = the minimum horizon the only feasible trajectories are near the straight line,
    whose moves (~D, off the grid's axes) join cells more than D apart centre to centre: the
    relaxed moves must still allow them (plain grid moves would find no path at all)."""
    c = ScenarioConfig(ground_nodes=NODES[:2], q0=(-400.0, 20.0), qF=(380.0, 200.0), **SMALL)
    c = c.replace(T=c.min_horizon())
    q = straight_line_path(c)
    assert ie.check_trajectory(c, q).feasible
    relaxed = RelaxedDP(c, 5.0)
    for w in (np.array([0.5, 0.5]), np.array([0.9, 0.1])):
        ub, _ = relaxed.value(w)
        assert np.isfinite(ub) and ub >= dual_value(ie.node_rates(c, q), w)
