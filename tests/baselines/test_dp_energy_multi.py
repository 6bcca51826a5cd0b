"""The energy efficiency of several nodes: Dinkelbach on the schedule's dual, its certificate over
the grid paths (checked by enumerating every grid path of a short mission) and its plans."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import ios_uav_env as ie
from baselines import dp_energy_multi, registry, tour
from baselines.dp_energy import parametric_path
from baselines.grid import disk_offsets, grid_axes
from baselines.registry import PlannerMismatch
from ios_uav_env import ScenarioConfig

NODES = ((-50.0, 60.0), (40.0, -70.0), (120.0, 20.0))
#: 39 moves for 800 m between q0 and qF: room to visit the three nodes and loiter.
SMALL = ScenarioConfig(
    T=40.0, v_max=40.0, ios_shape=(10, 6), ground_nodes=NODES, objective="energy_efficiency"
)
#: Three moves: every grid path can be enumerated.
TINY = ScenarioConfig(
    T=4.0, q0=(-80.0, 0.0), qF=(-40.0, 0.0), ios_shape=(6, 4), ground_nodes=((-60.0, 30.0), (-50.0, -30.0)),
    objective="energy_efficiency",
)  # fmt: skip


@pytest.fixture(scope="module")
def small_plan():
    return dp_energy_multi.solve(SMALL, resolution=10.0)


def test_the_plan_is_feasible_and_scored_by_the_one_scorer(small_plan):
    plan = small_plan
    assert plan.scheme == "dp-ee-multi" and plan.feasible
    assert plan.energy_efficiency == pytest.approx(
        ie.score_plan(SMALL, plan.trajectory).energy_efficiency, rel=1e-12
    )
    lams = [h["lambda"] for h in plan.history]
    assert all(b >= a for a, b in itertools.pairwise(lams))  # Dinkelbach's lam never decreases
    assert plan.info["ee_gap"] == pytest.approx(plan.info["ee_upper_bound"] / plan.energy_efficiency - 1)


def test_the_bound_is_above_every_weighted_dp_path(small_plan):
    # any grid path of the weighted DP, at any (lam, w), is a plan the certificate covers
    nodes = dp_energy_multi._Nodes(SMALL, 10.0, dp_energy_multi.DEFAULT_MARGIN)
    rng = np.random.default_rng(0)
    for lam in (0.0, 0.5 * small_plan.energy_efficiency, 2 * small_plan.energy_efficiency):
        for w in rng.dirichlet(np.ones(SMALL.K), size=4):
            traj, _ = parametric_path(nodes.weighted(w), lam)
            assert ie.score_plan(SMALL, traj).energy_efficiency <= small_plan.info["ee_upper_bound"]


def test_it_beats_the_tour_and_the_rate_plan_scored_on_energy(small_plan):
    ee = small_plan.energy_efficiency
    rate_tour = tour.solve(SMALL.replace(objective="rate")).trajectory
    assert ee >= ie.score_plan(SMALL, rate_tour).energy_efficiency
    assert ee >= ie.score_plan(SMALL, dp_energy_multi.straight_line_path(SMALL)).energy_efficiency


def _grid_paths(config: ScenarioConfig, resolution: float):
    """Every grid path of the DP's feasible set for N = 4: q0, two grid points, qF."""
    xs, ys, (iy0, ix0) = grid_axes(config, resolution, dp_energy_multi.DEFAULT_MARGIN)
    offsets = disk_offsets(resolution, config.D)
    q0, q_f = np.asarray(config.q0, float), np.asarray(config.qF, float)
    for o1, o2 in itertools.product(offsets, offsets):
        a = (iy0 + o1[0], ix0 + o1[1])
        b = (a[0] + o2[0], a[1] + o2[1])
        if not all(0 <= c[0] < len(ys) and 0 <= c[1] < len(xs) for c in (a, b)):
            continue
        p, r = np.array([xs[a[1]], ys[a[0]]]), np.array([xs[b[1]], ys[b[0]]])
        if np.hypot(*(q_f - r)) <= config.D:
            yield np.vstack([q0, p, r, q_f])


def test_the_certificate_holds_on_every_grid_path_of_a_short_mission():
    assert TINY.N == 4
    plan = dp_energy_multi.solve(TINY, resolution=10.0)
    best = max(ie.score_plan(TINY, q).energy_efficiency for q in _grid_paths(TINY, 10.0))
    assert best <= plan.info["ee_upper_bound"] * (1 + 1e-12)
    assert plan.energy_efficiency >= best * (1 - 1e-12)  # here the DP's own paths find the grid optimum


def test_loitering_a_hover_saves_energy_and_stays_feasible():
    cfg = SMALL
    route = tour.solve(cfg.replace(objective="rate")).trajectory
    assert np.any(np.all(np.diff(route, axis=0) == 0, axis=1))  # the tour hovers
    loitered = dp_energy_multi.loiter_hovers(cfg, route, 0.0)
    assert ie.check_trajectory(cfg, loitered).feasible
    assert ie.energy(cfg, loitered) < ie.energy(cfg, route)
    moves = np.hypot(*np.diff(loitered, axis=0).T)
    changed = np.any(loitered != route, axis=1)
    assert changed.any() and np.all(moves <= cfg.D * (1 + 1e-12))
    straight = dp_energy_multi.straight_line_path(cfg)  # nothing hovers: unchanged
    np.testing.assert_array_equal(dp_energy_multi.loiter_hovers(cfg, straight, 1.0), straight)


@pytest.mark.parametrize(
    ("config", "why"),
    [
        (SMALL.replace(ground_nodes=None), "ground node"),
        (SMALL.replace(objective="rate"), "objective='rate'"),
        (SMALL.replace(motion={"kind": "gauss_markov"}), "motion"),
    ],
)
def test_what_it_does_not_handle_is_refused(config, why):
    with pytest.raises(PlannerMismatch, match=why):
        dp_energy_multi.solve(config, resolution=10.0)


def test_the_registry_routes_energy_with_several_nodes_here():
    names = [p.name for p in registry.handlers(SMALL) if p.kind == "optimum"]
    assert names == ["dp-ee-multi"]
    with pytest.raises(PlannerMismatch, match="dp-ee-multi"):
        registry.check("dp-ee", SMALL)


@pytest.mark.parametrize(
    ("field", "value"),
    [("tol", 0.0), ("max_iter", 0), ("max_cuts", 1.5), ("resolution", -1.0), ("resolution", float("nan")),
     ("resolution", 0.01), ("margin", -5.0)],
)  # fmt: skip
def test_bad_arguments_name_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        dp_energy_multi.solve(SMALL, **{"resolution": 10.0, field: value})


def test_the_command_line_runs_the_energy_planners_of_several_nodes(tmp_path, capsys):
    from baselines import __main__ as cli

    nodes = ";".join(f"{x:g},{y:g}" for x, y in NODES)
    args = ["--objective", "energy_efficiency", f"--nodes={nodes}", "--T", "60", "--M", "100"]
    status = cli.main([*args, "--resolution", "12.5", "--out", str(tmp_path), "--no-plot"])
    out = capsys.readouterr().out
    assert status == 0 and "dp-ee-multi's EE upper bound over its grid paths" in out
    for name in ("dp-ee-multi", "loiter", "hover"):
        assert (tmp_path / f"{name}_T60_M100.json").exists()
    with pytest.raises(SystemExit):  # the single-node energy DP refuses several nodes, by name
        cli.main([*args, "--scheme", "dp-ee", "--out", str(tmp_path)])
    assert "dp-ee: 3 ground node(s)" in capsys.readouterr().err
