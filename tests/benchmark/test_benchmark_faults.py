"""Fault injection on the benchmark's inputs: trajectory files, suite files, the command line,
and the multi-node comparison of agents.evaluate. Each bad input is refused with one clear error
naming the file, the field or the argument, before any scenario runs or anything is written."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path
from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest

from ios_uav_env import ScenarioConfig
from ios_uav_env.benchmark import (
    evaluate,
    load_suite,
    read_plans,
    read_trajectories,
    score_trajectories,
    scoring,
)
from ios_uav_env.benchmark.cli import main
from ios_uav_env.benchmark.suite import suite_path

POLICY = "ios_uav_env.envs.policies:HoverAt('peak')"
MULTI_ID = "ios_uav_env/IOSUAV-MultiNode-v0"


@pytest.fixture(scope="module")
def suite():
    return load_suite("single-node-v1")


@pytest.fixture
def good(suite):
    """Straight-line plans of the suite's first two scenarios."""
    return {s.index: np.linspace(s.config.q0, s.config.qF, s.config.N) for s in suite.subset(2)}


@pytest.fixture
def no_scenario_runs(monkeypatch):
    """Any episode of the scorer fails the test: the refusal must come before the first one."""

    def ran(*args, **kwargs):
        raise AssertionError("a scenario ran before the bad input was refused")

    monkeypatch.setattr(scoring, "episode", ran)


def _csv(path: Path, rows: list[str], header: str = "scenario,slot,x,y,seconds") -> Path:
    path.write_text("\n".join([header, *rows]) + "\n")
    return path


# --- trajectory files: one name per scenario and slot ---------------------------------------------
@pytest.mark.parametrize(
    ("kind", "first", "second"),
    [("scenario", "scenario_1", "scenario_01"), ("seconds", "seconds_1", "seconds_001")],
)
def test_an_npz_naming_one_scenario_twice_is_refused_naming_both_arrays(tmp_path, good, kind, first, second):
    arrays = {"scenario_0": good[0], "scenario_1": good[1]}
    if kind == "scenario":
        arrays[second] = 0.5 * good[1]  # read as scenario 1 too: the later one would win
    else:
        arrays.update({first: np.asarray(1.0), second: np.asarray(2.0)})
    path = tmp_path / "plans.npz"
    np.savez(path, **arrays)
    with pytest.raises(
        ValueError, match=rf"plans\.npz: arrays '{first}' and '{second}' both name scenario 1"
    ):
        read_trajectories(path)


def test_a_csv_giving_one_slot_twice_is_refused_naming_both_lines(tmp_path):
    path = _csv(tmp_path / "plans.csv", ["0,0,1,2,", "0,1,3,4,", "0,1,5,6,"], "scenario,slot,x,y,seconds")
    with pytest.raises(ValueError, match=r"plans\.csv:4: scenario 0: slot 1 appears twice \(lines 3 and 4\)"):
        read_trajectories(path)


def test_an_npz_time_or_shares_without_its_trajectory_is_refused(tmp_path, good):
    path = tmp_path / "plans.npz"
    np.savez(path, scenario_0=good[0], seconds_1=np.asarray(1.0))
    with pytest.raises(ValueError, match=r"\['seconds_1'\] name no scenario_<index> array"):
        read_trajectories(path)


@pytest.mark.parametrize("width", [1, 3])
def test_an_npz_trajectory_of_width_other_than_two_is_refused(tmp_path, good, width):
    path = tmp_path / "plans.npz"
    np.savez(path, scenario_0=np.zeros((good[0].shape[0], width)))
    shape = r"must have shape \(N, 2\) \(a fleet.s: \(U, N, 2\)\)"
    with pytest.raises(ValueError, match=rf"scenario 0: scenario_0 {shape}, got \(\d+, {width}\)"):
        read_trajectories(path)


# --- trajectory files: times to plan --------------------------------------------------------------
@pytest.mark.parametrize("seconds", [-5.0, float("nan"), float("inf")])
def test_an_npz_time_to_plan_that_is_negative_or_not_finite_is_refused(tmp_path, good, seconds):
    path = tmp_path / "plans.npz"
    np.savez(path, scenario_0=good[0], seconds_0=np.asarray(seconds))
    with pytest.raises(ValueError, match=r"plans\.npz: seconds_0: the time to plan must be a finite number"):
        read_trajectories(path)


@pytest.mark.parametrize("seconds", ["-5", "nan", "inf"])
def test_a_csv_time_to_plan_that_is_negative_or_not_finite_is_refused(tmp_path, seconds):
    path = _csv(tmp_path / "plans.csv", [f"0,0,1,2,{seconds}", f"0,1,3,4,{seconds}"])
    with pytest.raises(
        ValueError, match=r"plans\.csv:2: scenario 0: the time to plan must be a finite number"
    ):
        read_trajectories(path)


@pytest.mark.parametrize(("second", "shown"), [("2.5", "2.5"), ("", "(empty)")])
def test_a_csv_scenario_whose_rows_give_different_times_is_refused_naming_both_lines(tmp_path, second, shown):
    path = _csv(tmp_path / "plans.csv", ["0,0,1,2,1.5", f"0,1,3,4,{second}"])
    with pytest.raises(
        ValueError, match=rf"plans\.csv:3: scenario 0: seconds {re.escape(shown)} differs from 1\.5 on line 2"
    ):
        read_trajectories(path)


def test_a_csv_time_to_plan_given_alike_on_every_row_is_read(tmp_path):
    path = _csv(tmp_path / "plans.csv", ["0,0,1,2,1.5", "0,1,3,4,1.5", "1,0,1,2,", "1,1,3,4,"])
    assert read_trajectories(path)[1] == {0: 1.5}


def test_score_trajectories_refuses_a_negative_or_infinite_time_to_plan(suite, good):
    for seconds in (-5.0, float("inf")):
        with pytest.raises(ValueError, match="scenario 1: the time to plan must be a finite number"):
            score_trajectories(good, suite, seconds={0: 1.0, 1: seconds})


def test_a_text_file_named_npz_is_refused_as_not_an_npz(tmp_path):
    path = tmp_path / "plans.npz"
    path.write_text("scenario,slot,x,y\n0,0,1,2\n")
    with pytest.raises(ValueError, match=r"plans\.npz: not a readable \.npz file"):
        read_plans(path)


# --- suite files ----------------------------------------------------------------------------------
def _suite_file(tmp_path: Path, change, n: int = 3) -> Path:
    """The first ``n`` scenarios of single-node-v1 under another name, with ``change`` applied."""
    data = json.loads(suite_path("single-node-v1").read_text())
    data = {**copy.deepcopy(data), "name": "faulty-v1", "scenarios": data["scenarios"][:n]}
    change(data)
    path = tmp_path / "faulty.json"
    path.write_text(json.dumps(data).replace('"NAN"', "NaN"))
    return path


def _relabel_multi_node(data: dict) -> None:
    data.update(kind="multi-node", normalizer="sca", env_id="ios_uav_env/IOSUAV-MultiNode-Random-v0")


SUITE_FAULTS = {
    "a 0 reference": (lambda d: d["scenarios"][1]["dp"].update(rate=0.0), r"scenario 1: dp\.rate .* > 0"),
    "an unknown env_id": (lambda d: d.update(env_id="ios_uav_env/Nope-v0"), "env_id of a single-node suite"),
    "a multi-node kind": (_relabel_multi_node, "references of a multi-node suite must be"),
    "no name": (lambda d: d.pop("name"), "name must be a non-empty string"),
    "a NaN rate": (
        lambda d: d["scenarios"][2]["sca"].update(rate="NAN"),
        "NaN is not a number a suite may hold",
    ),
}


@pytest.mark.parametrize("fault", SUITE_FAULTS)
def test_the_cli_refuses_a_faulty_suite_file_naming_the_argument(tmp_path, capsys, no_scenario_runs, fault):
    change, message = SUITE_FAULTS[fault]
    path = _suite_file(tmp_path, change)
    for command in (["evaluate", "--policy", POLICY], ["show"]):
        with pytest.raises(SystemExit) as exit_:
            main([*command, "--suite", str(path)])
        assert exit_.value.code == 2
        line = capsys.readouterr().err.strip().splitlines()[-1]
        assert line.startswith("python -m ios_uav_env.benchmark: error: argument --suite: ")
        assert str(path) in line
        assert re.search(message, line), line


def test_a_valid_copy_of_the_suite_under_another_name_still_loads(tmp_path):
    assert len(load_suite(_suite_file(tmp_path, lambda d: None))) == 3


# --- the command line: each bad argument is one error line, before any scenario ------------------
def _refused(capsys, argv: list[str], argument: str) -> str:
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"error: argument {argument}: " in line, line
    return line


def test_an_unknown_env_kwarg_is_refused_naming_it(capsys, no_scenario_runs):
    line = _refused(
        capsys, ["evaluate", "--policy", POLICY, "--n", "1", "--env-kwargs", "foo:1"], "--env-kwargs"
    )
    assert "'foo'" in line


def test_a_negative_seed_is_refused(capsys, no_scenario_runs):
    _refused(capsys, ["evaluate", "--policy", POLICY, "--n", "1", "--seed", "-1"], "--seed")
    with pytest.raises(ValueError, match="seed must be an integer >= 0"):
        scoring.evaluate(lambda obs: [0.0, 0.0], n=1, seed=-1)


@pytest.mark.parametrize("spec", ["math:floor(1, 2)", "ios_uav_env.envs.policies:HoverAt(1, 2)", "math:pi"])
def test_a_policy_whose_call_fails_or_that_is_no_policy_is_refused(capsys, no_scenario_runs, spec):
    line = _refused(capsys, ["evaluate", "--policy", spec, "--n", "1"], "--policy")
    assert repr(spec) in line or "callable" in line


def test_a_text_file_named_npz_is_refused_by_the_cli(tmp_path, capsys):
    path = tmp_path / "plans.npz"
    path.write_text("not an archive\n")
    _refused(capsys, ["evaluate", "--trajectories", str(path)], "--trajectories")


@pytest.mark.parametrize("where", ["a file", "under a file"])
def test_an_out_that_cannot_be_a_folder_is_refused_before_any_scenario(
    tmp_path, capsys, no_scenario_runs, where
):
    blocker = tmp_path / "taken"
    blocker.write_text("a file\n")
    out = blocker if where == "a file" else blocker / "results"
    _refused(capsys, ["evaluate", "--policy", POLICY, "--n", "1", "--out", str(out)], "--out")
    assert blocker.read_text() == "a file\n"


def test_an_out_of_a_trajectories_run_is_checked_first(tmp_path, capsys, good):
    path = tmp_path / "plans.npz"
    np.savez(path, scenario_0=good[0])
    blocker = tmp_path / "taken"
    blocker.write_text("")
    _refused(capsys, ["evaluate", "--trajectories", str(path), "--out", str(blocker)], "--out")


# --- agents.evaluate on several nodes: checked before any reference is solved, no failure cached --
def _multi_agent(max_nodes: int):
    from agents.loading import Agent
    from ios_uav_env.envs.multi import BASE_FEATURES, NODE_FEATURES

    shape = (len(BASE_FEATURES) + max_nodes * len(NODE_FEATURES),)
    model = SimpleNamespace(observation_space=SimpleNamespace(shape=shape))
    return Agent(model=model, env_id=MULTI_ID, name=f"stub_K{max_nodes}")


@pytest.fixture
def no_reference_solve(monkeypatch):
    import agents.evaluate_multi as evaluate_multi

    def solved(*args, **kwargs):
        raise AssertionError("a reference was solved before the bad scenario was refused")

    monkeypatch.setattr(evaluate_multi, "references", solved)


FOUR_NODES = "ground_nodes:[[-100,-20],[150,-60],[-40,90],[60,50]]"


@pytest.mark.parametrize(
    ("nodes", "message"), [(FOUR_NODES, "max_nodes = 3"), ("ground_nodes:[[-100,-20]]", "K >= 2")]
)
def test_agents_evaluate_refuses_a_scenario_the_agent_cannot_take_before_solving(
    tmp_path, capsys, monkeypatch, no_reference_solve, nodes, message
):
    import agents.evaluate as evaluate

    monkeypatch.setattr(evaluate, "load_agent", lambda path: _multi_agent(3))
    with pytest.raises(SystemExit) as exit_:
        evaluate.main(["stub", "--scenario", nodes, "T:40", "ios_shape:(10,6)", "--out", str(tmp_path)])
    assert exit_.value.code == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert "error: argument --scenario: " in line and message in line, line
    assert list(tmp_path.iterdir()) == []


def test_compare_multi_checks_the_agents_max_nodes_before_solving(tmp_path, no_reference_solve):
    from agents.evaluate_multi import DEFAULT_MULTI, compare_multi

    config = DEFAULT_MULTI.replace(
        ground_nodes=(*DEFAULT_MULTI.nodes, (60.0, 50.0)), T=40.0, ios_shape=(10, 6)
    )
    with pytest.raises(ValueError, match="stub_K3 observes at most max_nodes = 3"):
        compare_multi([_multi_agent(3)], config, tmp_path)


def _record(config: ScenarioConfig, failed: bool) -> dict:
    plan = {"rate": 0.3, "feasible": True, "seconds": 0.1, "trajectory": None, "shares": None}
    sca = {**plan, "rate": 0.0, "feasible": False, "error": "ValueError: injected"} if failed else plan
    bound = {"upper_bound": 0.4, "resolution": 2.5, "plan_rate": 0.3, "plan_feasible": True, "seconds": 0.1}
    return {"index": 0, "config": config.to_dict(), "tour": plan, "sca": sca, "bound": bound}


def test_a_failed_reference_solve_raises_and_is_not_cached(tmp_path, monkeypatch):
    from agents.evaluate_multi import DEFAULT_MULTI, references
    from baselines.references import solve

    config = DEFAULT_MULTI.replace(T=40.0, ios_shape=(10, 6))
    cache = tmp_path / "cache"
    monkeypatch.setattr(solve, "solve_scenario", lambda task, **kw: _record(config, failed=True))
    with pytest.raises(RuntimeError, match="sca: ValueError: injected"):
        references(config, cache)
    assert list(cache.glob("*.json")) == []  # the next run solves again
    monkeypatch.setattr(solve, "solve_scenario", lambda task, **kw: _record(config, failed=False))
    assert references(config, cache)["sca"]["rate"] == 0.3
    assert len(list(cache.glob("*.json"))) == 1

    def solved_again(task, **kw):
        raise AssertionError("a cached record was solved again")

    monkeypatch.setattr(solve, "solve_scenario", solved_again)
    assert references(config, cache)["sca"]["rate"] == 0.3


class SpecialistOfTheFixedId:
    """A policy that says what it was trained on, as SB3's models and the numpy export do: the 11
    features of ``ios_uav_env/IOSUAV-v0`` (no instance features)."""

    observation_space = gym.spaces.Box(-1.0, 1.0, (11,), dtype=np.float32)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return np.zeros(2, dtype=np.float32)


def test_a_policy_of_other_observations_is_refused_naming_both_shapes(capsys, no_scenario_runs):
    spec = "tests.benchmark.test_benchmark_faults:SpecialistOfTheFixedId()"
    line = _refused(capsys, ["evaluate", "--policy", spec, "--n", "1"], "--policy")
    assert "(11,)" in line and "(17,)" in line and "instance_features:false" in line
    with pytest.raises(ValueError, match=r"\(11,\).*\(17,\)"):
        evaluate(SpecialistOfTheFixedId(), n=1)


def test_a_policy_of_other_observations_runs_with_the_env_arguments_it_was_trained_with():
    results = evaluate(SpecialistOfTheFixedId(), n=1, env_kwargs={"instance_features": False})
    assert len(results.scenarios) == 1
