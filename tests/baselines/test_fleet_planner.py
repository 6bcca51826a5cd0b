"""The fleet planner (``baselines.fleet``): its plan is feasible and separated, its bound is
above every separated fleet of the same scenario (the plan, the straight lanes, the env's
random flights), one UAV meets the single-UAV planners, and bad input is refused by name."""

from __future__ import annotations

import numpy as np
import pytest

from baselines import fleet
from baselines.dp_bound import solve_multinode
from ios_uav_env import ScenarioConfig, check_trajectory
from ios_uav_env.model.fleet import default_lanes, fleet_maxmin, fleet_setup
from ios_uav_env.model.separation import flights_separated

CONFIG = ScenarioConfig(
    ground_nodes=((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0)), ios_shape=(10, 6), T=40.0,
    q0=(-200.0, 20.0), qF=(200.0, 20.0),
)  # fmt: skip


@pytest.fixture(scope="module")
def two() -> fleet.FleetPlan:
    return fleet.solve(CONFIG, uavs=2, resolution=10.0)


def test_the_plan_is_feasible_separated_and_scored_by_the_one_scorer(two):
    starts, finals = np.array(two.info["starts"]), np.array(two.info["finals"])
    for c, flight in zip(fleet_setup(CONFIG, 2, starts, finals)[2], two.trajectories, strict=True):
        assert check_trajectory(c, flight).feasible
    assert flights_separated(two.trajectories, fleet.DEFAULT_SEPARATION)
    assert two.value == fleet_maxmin(CONFIG, two.trajectories).value
    assert two.value <= two.upper_bound and two.gap < 0.5


def test_the_bound_is_above_every_separated_fleet(two):
    starts, finals = default_lanes(CONFIG, 2)
    straight = np.stack([np.linspace(s, f, CONFIG.N) for s, f in zip(starts, finals, strict=True)])
    assert fleet_maxmin(CONFIG, straight).upper <= two.upper_bound
    rng = np.random.default_rng(0)
    for _ in range(3):  # random separated flights within the speed limit and arriving
        wobble = straight.copy()
        wobble[:, 1:-1, 1] += rng.uniform(-5.0, 5.0, (2, CONFIG.N - 2))
        for c, flight in zip(fleet_setup(CONFIG, 2)[2], wobble, strict=True):
            assert check_trajectory(c, flight).feasible
        assert flights_separated(wobble, 10.0)
        assert fleet_maxmin(CONFIG, wobble).upper <= two.upper_bound
    # a second UAV helps: more than any one UAV's certified bound (the sum, not one term, bounds it)
    one_bound = solve_multinode(CONFIG, resolution=10.0).info["upper_bound"]
    assert two.value > one_bound


def test_one_uav_meets_the_single_uav_planners():
    one = fleet.solve(CONFIG, uavs=1, resolution=10.0, polish_steps=())
    dp = solve_multinode(CONFIG, resolution=10.0)
    assert one.value >= dp.mean_rate * (1 - 0.02)  # the tour competes in both; the DP's grid plans too
    assert one.upper_bound >= dp.mean_rate and one.upper_bound == pytest.approx(
        dp.info["upper_bound"], rel=2e-3
    )


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"uavs": 0}, "uavs must be an integer >= 1"),
        ({"starts": [[0.0, 0.0]]}, r"starts must be a finite \(2, 2\) array"),
        ({"finals": [[200.0, 20.0], [200.0, 25.0]]}, "finals: UAVs 0 and 1 are 5 m apart"),
        ({"min_separation": float("nan")}, "min_separation must be a finite number >= 0"),
        ({"finals": [[200.0, 20.0], [2000.0, 25.0]]}, r"starts\[1\] / finals\[1\]"),
        ({"polish_budget": -1}, "polish_budget must be None or an integer >= 0"),
        ({"polish_budget": 2.5}, "polish_budget must be None or an integer >= 0"),
    ],
)
def test_bad_input_is_refused_by_name(kwargs, message):
    with pytest.raises(ValueError, match=message):
        fleet.solve(CONFIG, **kwargs)


def test_another_problem_is_refused():
    with pytest.raises(ValueError, match="objective='rate', motion=None"):
        fleet.solve(CONFIG.replace(objective="energy_efficiency"))


def test_a_fleet_that_would_meet_is_never_returned(monkeypatch):
    """Every candidate meets at the surface's centre: each is feasible alone, none is separated."""

    def to_the_centre(config, nodes):
        legs = [
            np.linspace(config.q0, (0.0, 0.0), 11),
            np.zeros((18, 2)),
            np.linspace((0.0, 0.0), config.qF, 11),
        ]
        return np.concatenate(legs), None  # (no route: nothing to polish)

    monkeypatch.setattr(fleet, "_tour_flight", to_the_centre)
    monkeypatch.setattr(fleet, "dual_flights", lambda *args: None)
    with pytest.raises(ValueError, match="no candidate fleet keeps min_separation = 10 m all along"):
        fleet.solve(CONFIG, uavs=2, resolution=10.0, max_cuts=2)


def test_a_shared_band_is_planned_below_the_same_bound(two):
    shared = fleet.solve(CONFIG, uavs=2, resolution=10.0, access="shared", polish_steps=(20.0,))
    assert shared.value == fleet_maxmin(CONFIG, shared.trajectories, access="shared").value
    assert shared.value <= fleet_maxmin(CONFIG, shared.trajectories).value * (1 + 1e-9)  # interference
    assert (
        shared.upper_bound == pytest.approx(two.upper_bound, rel=1e-12) and shared.value <= shared.upper_bound
    )
    with pytest.raises(ValueError, match="access must be one of"):
        fleet.solve(CONFIG, access="tdma")


def test_candidates_met_again_after_a_rejection_are_not_scored_again():
    """A large separation rejects most candidates, and nearby Kelley weights give the same dual
    paths again: each is looked at once, and the plan (if any) is separated."""
    try:
        plan = fleet.solve(CONFIG, uavs=2, resolution=10.0, min_separation=70.0, polish_steps=())
    except ValueError as err:
        assert "no candidate fleet keeps min_separation = 70 m" in str(err)
    else:
        assert flights_separated(plan.trajectories, 70.0)
        assert len(plan.info["rejected"]) == len(set(plan.info["rejected"]))


def test_a_plan_whose_uavs_meet_is_flown_through_the_envs_guards():
    """Both UAVs detour through the same point: the guarded flights keep the separation all along,
    keep the speed limit and still arrive (or the repair gives up with None)."""
    starts, finals, configs = fleet_setup(CONFIG, 2)
    meet = np.array([(-50.0, -20.0)])
    flights = np.stack([
        np.concatenate([np.linspace(s, meet[0], 12), np.linspace(meet[0], f, CONFIG.N - 12)])
        for s, f in zip(starts, finals, strict=True)
    ])  # fmt: skip
    assert not flights_separated(flights, 10.0)
    repaired = fleet.guarded_flights(configs, flights, finals, 10.0)
    assert repaired is not None
    assert flights_separated(repaired, 10.0)
    for c, flight in zip(configs, repaired, strict=True):
        assert check_trajectory(c, flight).feasible


def test_each_uav_is_planned_at_its_own_speed_limit():
    plan = fleet.solve(CONFIG, uavs=2, speeds=[25.0, 15.0], resolution=10.0, polish_steps=(20.0,))
    _, _, configs = fleet_setup(CONFIG, 2, speeds=[25.0, 15.0])
    for c, flight in zip(configs, plan.trajectories, strict=True):
        assert check_trajectory(c, flight).feasible
    assert np.hypot(*np.diff(plan.trajectories[1], axis=0).T).max() <= 15.0 * (1 + 1e-9)
    assert plan.value <= plan.upper_bound


def test_the_cli_prints_the_table_and_draws_the_plan_once(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    out = tmp_path / "plan.png"
    fleet.main(["--uavs", "1", "--resolution", "10", "--no-polish", "--plot", str(out)])
    printed = capsys.readouterr().out
    assert "| 1 | orthogonal | " in printed and out.stat().st_size > 1000
    with pytest.raises(SystemExit):  # an existing figure is never overwritten
        fleet.main(["--uavs", "1", "--plot", str(out)])


def test_polishing_the_hover_points_raises_the_value(two):
    """The best cover's tours, their hover points moved while the value rises: the plan is at
    least the cover's, and here strictly better (no polishing: the cover's own value)."""
    plain = fleet.solve(CONFIG, uavs=2, resolution=10.0, polish_steps=(), sca_iterations=0)
    assert plain.info["polished_from"] is None and plain.info["sca"] is None
    assert two.info["polished_from"] == plain.value  # (the same cover search before it)
    assert two.info["sca"]["from"] > plain.value and two.info["source"].startswith("polished")
    assert flights_separated(two.trajectories, 10.0)


def test_block_coordinate_sca_refines_the_best_plan(two):
    """The last step: SCA from the best polished plan, recorded in ``info``; the plan is the better
    of the two (here the refined one), feasible, separated and under the bound."""
    sca = two.info["sca"]
    assert (
        sca["rounds"] >= 1 and sca["value"] > sca["from"] == two.info["candidates"][two.info["source"][:-4]]
    )
    assert two.value == sca["value"] == fleet_maxmin(CONFIG, two.trajectories).value
    assert two.info["source"].endswith("-sca") and two.value <= two.upper_bound


def test_the_polish_scores_at_most_its_budget_of_flights(two):
    """A budget of b moved flights: b + 1 polished candidates at most (the cover's own first)."""
    polished = [s for s in two.info["candidates"] if s.startswith("polished")]
    assert len(polished) > 4  # unbounded, it scores more than the budget below
    capped = fleet.solve(CONFIG, uavs=2, resolution=10.0, polish_budget=3, sca_iterations=0)
    scored = [s for s in capped.info["candidates"] if s.startswith("polished")]
    assert 1 <= len(scored) <= 4 and capped.value <= two.info["sca"]["from"]
    assert capped.info["polished_from"] == two.info["polished_from"]
