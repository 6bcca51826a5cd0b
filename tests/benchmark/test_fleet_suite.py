"""Several-UAV suites (kind "multi-uav"): frozen by the references CLI, checked at load, every plan
scored by the one scorer of a fleet (fleet_maxmin, feasibility, separation), any policy rolled out
in the parallel env, the shared and the team form alike."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("pettingzoo")

from baselines.references.__main__ import main as references_main  # noqa: E402
from baselines.references.fleet import fleet_tasks, straight_flights  # noqa: E402
from ios_uav_env.benchmark import SUITES, evaluate, load_suite, score_trajectories  # noqa: E402
from ios_uav_env.benchmark.cli import main as benchmark_main  # noqa: E402
from ios_uav_env.benchmark.fleet_policies import NearestWorstNode  # noqa: E402
from ios_uav_env.benchmark.fleet_suite import fleet_configs, score_flights  # noqa: E402
from ios_uav_env.benchmark.results import reference_results  # noqa: E402
from ios_uav_env.model.fleet import fleet_maxmin  # noqa: E402
from ios_uav_env.model.fleet_horizons import flights_feasibility, hold_flights, horizon_slots  # noqa: E402
from ios_uav_env.model.separation import flights_separated  # noqa: E402
from tests.benchmark.quick_suites import tampered  # noqa: E402


@pytest.fixture(scope="module")
def frozen(tmp_path_factory):
    """The quick several-UAV suite: 2 scenarios (one per access), coarse grids, no polishing."""
    out = tmp_path_factory.mktemp("multi-uav")
    argv = ["multi-uav", "--quick", "--cache", str(out / "cache"), "--dir", str(out)]
    assert references_main(argv) == 0
    return out / "multi-uav-quick-v1.json"


@pytest.fixture(scope="module")
def suite(frozen):
    return load_suite(frozen)


def test_the_draws_are_a_stream_of_their_own():
    from baselines.references.draws import ENERGY_SPAWN_KEY, SPAWN_KEY
    from baselines.references.fleet import FLEET_SPAWN_KEY
    from baselines.references.mobile import MOBILE_SPAWN_KEY
    from baselines.references.online import MULTI_MOBILE_SPAWN_KEY

    keys = [SPAWN_KEY, ENERGY_SPAWN_KEY, MOBILE_SPAWN_KEY, MULTI_MOBILE_SPAWN_KEY, FLEET_SPAWN_KEY]
    assert len(set(keys)) == len(keys)


def test_the_draws_cover_both_access_modes_and_the_stated_ranges():
    tasks = fleet_tasks(40, 7)
    assert [t["fleet"]["access"] for t in tasks[:4]] == ["orthogonal", "shared"] * 2
    assert {t["fleet"]["uavs"] for t in tasks} == {2, 3}
    assert {len(t["config"]["ground_nodes"]) for t in tasks} == {3, 4, 5, 6}
    assert all(60.0 <= t["config"]["T"] <= 100.0 for t in tasks)
    for t in tasks:  # UAV 0 flies T, the others a horizon of their own in [0.75 T, T]
        h, big_t = t["fleet"]["horizons"], t["config"]["T"]
        assert h[0] == big_t and all(0.75 * big_t <= x <= big_t for x in h) and len(h) == t["fleet"]["uavs"]
    assert any(x < t["config"]["T"] for t in tasks for x in t["fleet"]["horizons"])
    assert fleet_tasks(3, 7) == tasks[:3]  # a prefix: the draws are in turn
    with pytest.raises(ValueError, match="n must be an integer >= 1"):
        fleet_tasks(0, 7)


def test_the_frozen_suite_holds_its_references_below_the_bound_and_the_planner_best(suite):
    assert suite.kind == "multi-uav" and suite.fleets and suite.env_id == "ios_uav_env.parallel_env"
    assert [s.fleet["access"] for s in suite] == ["orthogonal", "shared"]
    for s in suite:
        bound, planner = s.value("bound"), s.value("planner")
        assert s.reference["planner"]["feasible"]
        assert 0 < planner <= bound
        for r in ("tour", "dual", "straight"):
            assert s.value(r) <= planner * (1 + 1e-9), (s.index, r)


def test_the_stored_rows_are_the_one_scorers_values(suite):
    for s in suite:
        flights = straight_flights(s.config, s.fleet)
        rate, feasible, worst = score_flights(s.config, s.fleet, flights)
        assert feasible and worst < 1e-9
        # same machine, same arithmetic: the scorer gives the stored value to the last bits
        assert rate == pytest.approx(s.value("straight"), rel=1e-12)
        slots = horizon_slots(fleet_configs(s.config, s.fleet))
        assert rate == fleet_maxmin(s.config, flights, access=s.fleet["access"], slots=slots).value
        if slots.min() < s.config.N:  # a UAV gone before T serves nothing after its horizon
            assert rate < fleet_maxmin(s.config, flights, access=s.fleet["access"]).value


def test_a_shared_policy_and_the_same_policy_as_a_team_fly_the_same_flights(suite):
    shared = evaluate(NearestWorstNode(), suite, name="shared")

    class Team:
        team = True

        def bind(self, names):
            bound = Team()
            bound.policy = NearestWorstNode().bind(names)
            return bound

        def __call__(self, observations):
            return {agent: self.policy(obs) for agent, obs in observations.items()}

    team = evaluate(Team(), suite, name="team")
    for a, b in zip(shared, team, strict=True):
        assert a.rate == b.rate and a.feasible and b.feasible
        assert 0 < a.pct["bound"] <= 100.0
    assert shared.aggregate.feasible == len(suite)


def test_flights_that_meet_score_zero_and_a_wrong_shape_names_the_scenario(suite):
    s = suite[0]
    flights = straight_flights(s.config, s.fleet)
    results = score_trajectories({0: flights}, suite, name="straight")
    assert results.scenarios[0].rate == pytest.approx(s.value("straight"), rel=1e-12)
    # both UAVs fly to the point between their lanes, meet there at slot m, then go on to their
    # final points in time (each within its speed limit): feasible flights that are not separated
    configs = fleet_configs(s.config, s.fleet)
    slots = horizon_slots(configs)
    m, meet = int(slots.min()) // 2, flights[:, 0].mean(axis=0) + [100.0, 0.0]
    legs = [
        np.array([np.interp(np.arange(n), [0, m, n - 1], [f[0, j], meet[j], f[n - 1, j]]) for j in (0, 1)]).T
        for f, n in zip(flights, slots, strict=True)
    ]
    met = hold_flights(legs, s.config.N)
    assert flights_feasibility(configs, met)[0]
    assert not flights_separated(met, s.fleet["min_separation"], slots)
    row = score_trajectories({0: met}, suite).scenarios[0]
    assert not row.feasible and row.pct["planner"] == 0.0 and row.rate > 0
    with pytest.raises(ValueError, match=r"scenario 0: the flights must have shape \(U, N, 2\)"):
        score_trajectories({0: flights[:1]}, suite)
    with pytest.raises(ValueError, match="cover scenarios 0..n-1"):
        score_trajectories({1: flights}, suite)
    with pytest.raises(ValueError, match="scenario 0: the time to plan must be a finite number of seconds"):
        score_trajectories({0: flights}, suite, seconds={0: -1.0})


def test_the_fleet_and_the_scenario_are_pinned_and_a_task_change_is_refused(suite):
    zero = lambda obs: np.zeros(len(obs), np.float32)  # noqa: E731
    with pytest.raises(ValueError, match=r"\['uavs'\] would be ignored .* the fleet's"):
        evaluate(zero, suite, env_kwargs={"uavs": 3})
    with pytest.raises(ValueError, match="surface_sharpness=9.0 .* change the task"):
        evaluate(zero, suite, env_kwargs={"surface_sharpness": 9.0})
    with pytest.raises(ValueError, match="batched and at_once are for single-UAV suites"):
        evaluate(zero, suite, batched=True)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d["scenarios"][0]["fleet"].pop("access"), "fleet must have exactly the fields"),
        (lambda d: d["scenarios"][0]["fleet"].update(uavs=1), "fleet.uavs must be an integer >= 2"),
        (lambda d: d["scenarios"][0]["fleet"].update(starts=[[0.0, 0.0]]), "fleet: starts must be"),
        (lambda d: d["scenarios"][0]["fleet"].update(access="tdma"), "fleet: access must be one of"),
        (lambda d: d["scenarios"][0]["straight"].update(rate=99.0), "no plan's rate may exceed it"),
        (lambda d: d["scenarios"][0].pop("fleet"), "fleet must be an object"),
        (lambda d: d.update(env_id="ios_uav_env/IOSUAV-MultiNode-v0"), "env_id of a multi-uav suite"),
        (lambda d: d["scenarios"][0]["config"].update(motion={"kind": "gauss_markov"}), "static nodes"),
    ],
)
def test_a_tampered_suite_is_refused_naming_the_field(frozen, tmp_path, change, message):
    with pytest.raises(ValueError, match=message):
        load_suite(tampered(frozen, tmp_path, change))


def test_a_fleet_in_another_kind_of_suite_is_refused(tmp_path):
    from ios_uav_env.benchmark.suite_registry import suite_path

    data = json.loads(suite_path("multi-node-v1").read_text())
    data["name"] = "multi-node-fleet-v1"
    data["scenarios"][0]["fleet"] = {"uavs": 2}
    path = tmp_path / "x.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="only a several-UAV suite's scenarios have a fleet"):
        load_suite(path)


def test_the_command_line_shows_and_scores_a_fleet_suite(frozen, capsys):
    assert benchmark_main(["show", "--suite", str(frozen)]) == 0
    shown = capsys.readouterr().out
    for r in ("planner", "bound", "tour", "dual", "straight"):
        assert f"{r} on multi-uav-quick-v1 (2 scenarios): % of planner mean" in shown
    policy = "ios_uav_env.benchmark.fleet_policies:NearestWorstNode"
    assert benchmark_main(["evaluate", "--suite", str(frozen), "--policy", policy]) == 0
    line = capsys.readouterr().out
    assert "on multi-uav-quick-v1 (2 scenarios): % of planner mean" in line and "feasible 2/2" in line


def test_the_reference_rows_read_the_stored_values(suite):
    row = reference_results(suite, "planner")
    assert row.aggregate.mean_pct_planner == pytest.approx(100.0)
    assert row.aggregate.mean_pct_bound < 100.0


def test_saved_flights_score_again_from_their_file(suite, tmp_path):
    results = evaluate(NearestWorstNode(), suite, name="nearest")
    paths = results.save(tmp_path / "run")
    with np.load(paths["trajectories"]) as data:
        assert data["scenario_0"].shape == (suite[0].fleet["uavs"], suite[0].config.N, 2)
    again = score_trajectories(
        {i: np.load(paths["trajectories"])[f"scenario_{i}"] for i in range(len(suite))}, suite
    )
    assert [r.rate for r in again] == [r.rate for r in results]
    assert (
        benchmark_main(["evaluate", "--suite", str(suite.path), "--trajectories", str(paths["trajectories"])])
        == 0
    )


def test_the_shipped_suite_loads_and_its_straight_rows_reproduce():
    """multi-uav-v1: registered, both bands, 2 and 3 UAVs; the straight flights scored again by
    fleet_maxmin give the stored values (1e-9 relative: another CPU's BLAS sums the surface's
    complex products in another order, ~1e-15; a changed scorer moves them by far more)."""
    shipped = load_suite("multi-uav-v1")
    assert len(shipped) == 40 and shipped.sha256 == SUITES["multi-uav-v1"].sha256
    assert {s.fleet["access"] for s in shipped} == {"orthogonal", "shared"}
    assert {s.fleet["uavs"] for s in shipped} == {2, 3} and {s.config.K for s in shipped} == {3, 4, 5, 6}
    for s in shipped.subset(4):
        rate, feasible, _ = score_flights(s.config, s.fleet, straight_flights(s.config, s.fleet))
        assert feasible and rate == pytest.approx(s.value("straight"), rel=1e-9)
        assert s.value("straight") <= s.value("planner") <= s.value("bound")


def test_the_heuristics_docstring_example_holds():
    import doctest

    from ios_uav_env.benchmark import fleet_policies

    assert doctest.testmod(fleet_policies).failed == 0
