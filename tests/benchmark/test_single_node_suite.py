"""ios_uav_env.benchmark: frozen suites (hash-checked, reproducible from the planners), the scorer of
any policy or trajectory file, and its command line."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from baselines.references import freeze, heuristic_reference, single_node_content
from ios_uav_env.benchmark import (
    SUITES,
    evaluate,
    load_suite,
    read_trajectories,
    reference_results,
    score_trajectories,
    write_trajectories,
)
from ios_uav_env.benchmark.cli import load_policy, main, parse_env_kwargs
from ios_uav_env.benchmark.suite import content_hash, suite_path
from ios_uav_env.envs.policies import HoverAt
from tests.tolerances import PLANNER_REL, SOLVER_REL

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def suite():
    return load_suite("single-node-v1")


def test_the_suite_is_small_complete_and_matches_its_registered_hash(suite):
    path = suite_path("single-node-v1")
    assert path.stat().st_size < 100_000
    assert len(suite) == 60 and suite.version == 1 and suite.normalizer == "dp"
    assert suite.sha256 == SUITES["single-node-v1"].sha256 == content_hash(json.loads(path.read_text()))
    for s in suite:
        assert set(s.reference) == {"dp", "sca", "hover_peak", "hover_ground"}
        assert s.reference["dp"]["resolution"] == 2.5 and s.reference["sca"]["seconds"] > 0


def test_a_modified_copy_fails_loudly_and_an_exact_copy_loads(tmp_path, suite):
    data = json.loads(suite_path("single-node-v1").read_text())
    exact = tmp_path / "copy.json"
    exact.write_text(json.dumps(data))  # other whitespace, same content
    assert load_suite(exact).sha256 == suite.sha256
    data["scenarios"][7]["dp"]["rate"] *= 1 + 1e-12
    tampered = tmp_path / "tampered.json"
    tampered.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="was modified"):
        load_suite(tampered)
    data["name"] = "single-node-dev"  # an unregistered name loads with its own hash
    dev = tmp_path / "dev.json"
    dev.write_text(json.dumps(data))
    assert load_suite(dev).sha256 == content_hash(data)
    with pytest.raises(KeyError, match="single-node-v1"):
        load_suite("single-node-v0")


def test_stored_planner_values_reproduce_from_the_planners(suite):
    """A sample: DP on the two shortest scenarios, SCA on the shortest (CI has cvxpy)."""
    from baselines import dp, sca

    shortest = sorted(suite, key=lambda s: s.config.T)[:2]
    for s in shortest:
        plan = dp.solve(s.config, resolution=s.reference["dp"]["resolution"])
        assert plan.mean_rate == pytest.approx(s.dp_rate, rel=PLANNER_REL), s.index
    plan = sca.solve(shortest[0].config)
    assert plan.feasible == shortest[0].reference["sca"]["feasible"]
    assert plan.mean_rate == pytest.approx(shortest[0].sca_rate, rel=SOLVER_REL)


def test_stored_heuristic_values_reproduce(suite):
    for s in suite.subset(6):
        for key, target in (("hover_peak", "peak"), ("hover_ground", "ground")):
            ref = heuristic_reference(s.config, target)
            assert ref["feasible"] == s.reference[key]["feasible"]
            assert ref["rate"] == pytest.approx(s.reference[key]["rate"], rel=PLANNER_REL), (s.index, key)


def test_the_frozen_suite_is_the_checkouts_heldout_suite(suite):
    heldout = json.loads((ROOT / "agents/suite/heldout.json").read_text())
    assert len(heldout["scenarios"]) == len(suite)
    for rec, s in zip(heldout["scenarios"], suite, strict=True):
        assert s.config.to_dict() == rec["config"] or s.config == type(s.config)(**rec["config"])
        assert (s.dp_rate, s.sca_rate) == (rec["dp"]["rate"], rec["sca"]["rate"])
    head = {**heldout, "scenarios": heldout["scenarios"][:2]}
    content = single_node_content(head, "single-node-v1", 1)
    stored = json.loads(suite_path("single-node-v1").read_text())
    # the heuristics' rates are recomputed: equal to rounding (the compiled rate kernel's node
    # sum is reassociated, numba or not), everything else to the bit
    for new, old in zip(content["scenarios"], stored["scenarios"][:2], strict=True):
        for key in ("hover_peak", "hover_ground"):
            a, b = new.pop(key), old.pop(key)
            assert a["feasible"] == b["feasible"] and a["rate"] == pytest.approx(b["rate"], rel=1e-12)
        assert new == old


def test_freeze_refuses_to_change_a_suite_under_its_name(tmp_path):
    content = {"format": "x", "name": "demo-v1", "scenarios": [{"index": 0}]}
    path, digest = freeze(content, tmp_path)
    assert freeze(content, tmp_path) == (path, digest)  # same content: idempotent
    with pytest.raises(ValueError, match="new name"):
        freeze({**content, "scenarios": [{"index": 1}]}, tmp_path)


def test_a_callable_a_predict_object_and_a_batched_callable_score_alike(suite):
    peak = HoverAt("peak")

    class SB3Like:
        def predict(self, obs, deterministic=False):
            assert deterministic
            return peak(obs), None

    def batched(obs):
        return np.stack([peak(o) for o in obs])

    runs = [
        evaluate(peak, suite, n=3),  # env_kwargs from the policy (peak_hint)
        evaluate(SB3Like(), suite, n=3, env_kwargs={"peak_hint": True}),
        evaluate(batched, suite, n=3, env_kwargs={"peak_hint": True}, batched=True),
    ]
    for results in runs:
        assert [r.rate for r in results.scenarios] == pytest.approx(
            [s.reference["hover_peak"]["rate"] for s in suite.subset(3)], rel=1e-12
        )
        assert results.aggregate.feasible == 3 and results.env_kwargs == {"peak_hint": True}
        assert all(r.seconds > 0 and r.trajectory.shape == (s.config.N, 2)
                   for r, s in zip(results.scenarios, suite, strict=False))  # fmt: skip
    a = runs[0].aggregate
    pct = [100 * s.reference["hover_peak"]["rate"] / s.dp_rate for s in suite.subset(3)]
    assert (a.mean_pct_dp, a.min_pct_dp, a.p10_pct_dp) == pytest.approx(
        (np.mean(pct), min(pct), np.percentile(pct, 10))
    )
    with pytest.raises(TypeError, match="callable"):
        evaluate(object(), suite, n=1)


def test_reference_results_are_the_stored_values(suite):
    sca = reference_results(suite, "sca").aggregate
    assert sca.mean_pct_sca == pytest.approx(100.0) and sca.feasible == 60
    assert reference_results(suite, "dp", n=5).aggregate.min_pct_dp == pytest.approx(100.0)
    assert math.isnan(reference_results(suite, "hover_ground").aggregate.median_seconds)


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
def test_trajectory_files_round_trip_and_score_as_the_policy(tmp_path, suite, suffix):
    results = evaluate(HoverAt("ground"), suite, n=4)
    plans = {r.index: r.trajectory for r in results.scenarios}
    times = {r.index: r.seconds for r in results.scenarios}
    path = write_trajectories(tmp_path / f"plans{suffix}", plans, times)
    trajectories, seconds = read_trajectories(path)
    scored = score_trajectories(trajectories, suite, seconds=seconds)
    assert [r.to_dict() for r in scored.scenarios] == [r.to_dict() for r in results.scenarios]


def test_trajectory_errors_name_the_scenario(tmp_path, suite):
    good = {i: np.linspace(s.config.q0, s.config.qF, s.config.N) for i, s in enumerate(suite.subset(3))}
    with pytest.raises(ValueError, match=r"missing \[1\]"):
        score_trajectories({0: good[0], 2: good[2]}, suite)
    with pytest.raises(ValueError, match="scenario 1: the trajectory must have shape"):
        score_trajectories({0: good[0], 1: good[1][:-1]}, suite)
    with pytest.raises(ValueError, match=r"scenarios \[60\] are not in suite"):
        score_trajectories({60: good[0]}, suite)
    bad = tmp_path / "bad.npz"
    np.savez(bad, scenario_0=good[0], other=good[1])
    with pytest.raises(ValueError, match="unknown array 'other'"):
        read_trajectories(bad)
    csv = tmp_path / "gap.csv"
    csv.write_text("scenario,slot,x,y\n0,0,1,2\n0,2,3,4\n")
    with pytest.raises(ValueError, match=r"scenario 0: slots must be 0..N-1 without gaps; missing \[1\]"):
        read_trajectories(csv)


def test_an_infeasible_plan_scores_zero_but_keeps_its_rate(suite):
    s = suite[0]
    peak = np.array(s.config.ground_node, dtype=float)
    q = np.repeat(peak[None], s.config.N, axis=0)  # never leaves G: misses q0 and qF
    (row,) = score_trajectories({0: q}, suite).scenarios
    assert not row.feasible and row.rate > 0 and row.pct_dp == row.pct_sca == 0.0


def test_policy_specs_and_env_kwargs_parse():
    assert repr(load_policy("ios_uav_env.envs.policies:HoverAt('ground', D=25.0)")) == repr(HoverAt("ground"))
    assert isinstance(load_policy("ios_uav_env.envs.policies:HoverAt"), HoverAt)
    assert load_policy("numpy:zeros") is np.zeros
    for spec in ("ios_uav_env.envs.policies", "ios_uav_env.envs.policies:HoverAt(target=x)", "m:1+2"):
        with pytest.raises(ValueError):
            load_policy(spec)
    assert parse_env_kwargs(["peak_hint:true", "length_scale:400", "channel:rician"]) == {
        "peak_hint": True, "length_scale": 400, "channel": "rician"}  # fmt: skip


def test_cli_scores_a_policy_and_a_file(tmp_path, capsys):
    assert main(["list"]) == 0 and "single-node-v1: 60 scenarios" in capsys.readouterr().out
    assert main(["show", "--n", "3"]) == 0
    assert capsys.readouterr().out.count("on single-node-v1 (3 scenarios)") == 4
    assert main(["show", "--reference", "sca"]) == 0
    assert capsys.readouterr().out.startswith("sca on single-node-v1 (60 scenarios): % of DP mean 100.51 |")
    out = tmp_path / "peak"
    spec = "ios_uav_env.envs.policies:HoverAt('peak')"
    assert (
        main(["evaluate", "--policy", spec, "--n", "3", "--env-kwargs", "peak_hint:true", "--out", str(out)])
        == 0
    )
    line = capsys.readouterr().out.splitlines()[0]
    assert "feasible 3/3" in line
    assert {p.name for p in out.iterdir()} >= {
        "results.csv",
        "results.json",
        "results.md",
        "trajectories.npz",
    }
    assert main(["evaluate", "--trajectories", str(out / "trajectories.npz"), "--name", spec]) == 0
    assert capsys.readouterr().out.splitlines()[0] == line  # the same scores, the same plan times
    with pytest.raises(SystemExit):
        main(["evaluate", "--policy", "no_such_module:f"])


def test_the_docstring_examples_hold():
    import doctest

    import ios_uav_env.benchmark as package
    import ios_uav_env.benchmark.scoring as module

    for mod in (package, module):
        assert doctest.testmod(mod).failed == 0, mod.__name__


def test_scoring_imports_no_planner_and_no_deep_learning_library():
    """(scipy may come with numba, the optional JIT of the core; the wheel test has neither.)"""
    code = (
        "import sys, numpy as np\n"
        "from ios_uav_env.benchmark import evaluate\n"
        "r = evaluate(lambda obs: np.zeros(2), n=2)\n"
        "bad = {'cvxpy', 'torch', 'matplotlib', 'baselines', 'agents'} & set(sys.modules)\n"
        "assert not bad, bad\n"
        "print(r.aggregate.feasible)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd="/")
    assert proc.returncode == 0 and proc.stdout.strip() == "2", proc.stderr


@pytest.mark.parametrize("batched", [False, True])
def test_at_once_scores_the_same_episodes_as_one_env_per_scenario(batched):
    # every scenario as a row of one batched env: the same plans and scores (the env's step is
    # the same kernel on each row), one plan time per batch
    from ios_uav_env.envs.policies import HoverAt

    policy = HoverAt("peak")
    one = evaluate(policy, n=4, batched=batched)
    together = evaluate(policy, n=4, batched=batched, at_once=True)
    for a, b in zip(one.scenarios, together.scenarios, strict=True):
        assert a.index == b.index and a.feasible == b.feasible
        assert b.rate == pytest.approx(a.rate, rel=1e-9)
        np.testing.assert_allclose(b.trajectory, a.trajectory, atol=1e-9)
    assert len({r.seconds for r in together.scenarios}) == 1  # the batch's time / B
    with pytest.raises(ValueError, match="single-node suites"):
        evaluate(lambda obs: np.zeros(6), "multi-node-v1", n=1, at_once=True)
