"""The suites normalised by the clairvoyant optimum, one walking node (``mobile-v2``): a quick suite
frozen by ``python -m baselines.references mobile --version 2 --quick`` loads, its pipeline refuses a
tampered record, naming it, the scorer reports % of the optimum (the new metric) and of the bound,
and the evaluator replays the suite's env rows; the shipped suites hold bound >= optimum >= 99.5 %
of every online row on every scenario, under their registered hashes, and every row of their
sections of docs/leaderboard.md reproduces from its command."""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

import numpy as np
import pytest

from baselines.references.online import ONLINE_SHARE, check_online_record, online_rows
from ios_uav_env import MOBILE_ID
from ios_uav_env.benchmark import evaluate, load_suite, reference_results, score_trajectories
from ios_uav_env.benchmark.cli import main as cli_main
from ios_uav_env.benchmark.suite import BOUND_REL, MOBILE_V2_REFERENCES, SUITES, content_hash
from ios_uav_env.envs.policies import HoverAt
from tests.benchmark.quick_suites import freeze_quick_online, rerun_tampered_online, tampered
from tests.benchmark.test_leaderboard import _rows, task_changes_of

#: The shipped suites normalised by the clairvoyant optimum (each registered one has its section
#: in docs/leaderboard.md).
ONLINE_SUITES = tuple(name for name in ("mobile-v2", "multi-node-mobile-v1") if name in SUITES)


@pytest.fixture(scope="module")
def frozen(tmp_path_factory) -> Path:
    return freeze_quick_online(tmp_path_factory, multi=False)


@pytest.fixture(scope="module")
def suite(frozen):
    return load_suite(frozen)


def test_the_quick_suite_is_a_mobile_suite_normalised_by_the_optimum(suite):
    assert suite.kind == "mobile" and suite.env_id == MOBILE_ID and suite.normalizer == "optimum"
    assert suite.references == MOBILE_V2_REFERENCES and suite.scores == ("optimum", "bound")
    (s,) = suite.scenarios
    assert s.config.K == 1 and s.config.motion is not None and isinstance(s.seed, int)
    opt, ub = s.value("optimum"), s.value("bound")
    assert opt <= ub * (1 + BOUND_REL)
    for r in online_rows(1):
        assert s.reference[r]["feasible"] and opt >= ONLINE_SHARE * s.value(r), r


def test_the_scorer_reports_the_optimum_and_the_bound_and_replays_the_env_rows(suite):
    (s,) = suite.scenarios
    result = evaluate(HoverAt("ground"), suite)
    row = result.scenarios[0]
    assert row.rate == s.value("track_reports")  # the same seed, draws and scorer as the pipeline
    assert row.pct_optimum == pytest.approx(100 * row.rate / s.value("optimum"))
    assert row.pct_bound == pytest.approx(100 * row.rate / s.value("bound"))
    assert set(row.pct) == {"optimum", "bound"} and "pct_optimum" in row.to_dict()
    assert "% of optimum mean" in result.summary() and "% of bound mean" in result.summary()
    assert score_trajectories({0: row.trajectory}, suite).scenarios[0].rate == row.rate
    optimum = reference_results(suite, "optimum")
    assert optimum.aggregate.mean_pct_optimum == pytest.approx(100.0, rel=1e-12)
    assert optimum.aggregate.mean_pct_bound == pytest.approx(100 * s.value("optimum") / s.value("bound"))


def test_a_tampered_record_stops_the_freeze_naming_it(frozen, tmp_path):
    def above_the_optimum(data):  # an online row 1 % above the optimum, still under the bound
        data["mpc_dp_k1"]["rate"] = min(data["optimum"]["rate"] * 1.01, data["bound"]["upper_bound"])

    message = rerun_tampered_online(frozen, tmp_path, above_the_optimum, multi=False)
    assert "not frozen" in message and "#0: optimum" in message and "mpc_dp_k1" in message

    def bound_below(data):
        data["bound"]["upper_bound"] = data["optimum"]["rate"] * 0.99

    assert "#0: bound" in rerun_tampered_online(frozen, tmp_path / "b", bound_below, multi=False)


def test_the_record_checks_name_every_failure(frozen):
    (path,) = (frozen.parent / "cache").glob("online_*.json")
    rec = {"index": 0, **json.loads(path.read_text())}
    assert check_online_record(rec) == []
    rec["track_exact"] = {**rec["track_exact"], "feasible": False}
    rec["plan_once"] = {"rate": 0.0, "feasible": False, "seconds": 0.0, "error": "RuntimeError: boom"}
    notes = check_online_record(rec)
    assert any("track_exact failed or infeasible" in n for n in notes)
    assert any("plan_once" in n and "boom" in n for n in notes)


def test_a_tampered_suite_file_is_refused(frozen, tmp_path):
    def above_bound(data):
        s = data["scenarios"][0]
        s["optimum"]["rate"] = s["bound"]["upper_bound"] * 1.01

    with pytest.raises(ValueError, match="optimum"):
        load_suite(tampered(frozen, tmp_path, above_bound))

    def no_optimum(data):
        data["references"].remove("optimum")

    with pytest.raises(ValueError, match="including"):
        load_suite(tampered(frozen, tmp_path, no_optimum))

    def other_normaliser(data):
        data["normalizer"] = "dp"

    with pytest.raises(ValueError, match="normalizer of a mobile suite must be one of"):
        load_suite(tampered(frozen, tmp_path, other_normaliser))


@pytest.mark.parametrize("name", ONLINE_SUITES)
def test_the_shipped_suite_holds_its_checks_under_its_registered_hash(name):
    suite = load_suite(name)
    data = json.loads(suite.path.read_text(encoding="utf-8"))
    assert content_hash(data) == SUITES[name].sha256 == suite.sha256
    assert suite.normalizer == "optimum" and suite.mobile
    for s in suite:
        opt, ub = s.value("optimum"), s.value("bound")
        assert opt <= ub * (1 + BOUND_REL), (name, s.index)
        for r in online_rows(s.config.K):
            assert opt >= ONLINE_SHARE * s.value(r), (name, s.index, r)
            assert s.reference[r]["feasible"], (name, s.index, r)


def test_mobile_v2_holds_mobile_v1s_scenarios_and_seeds_and_v1_is_unchanged():
    v1, v2 = load_suite("mobile-v1"), load_suite("mobile-v2")
    assert SUITES["mobile-v1"].sha256 == "f3b2712dd4b82c0ce6bfc9bb941a930ad571db086c071d97f496f64cf18578e7"
    assert v1.sha256 == SUITES["mobile-v1"].sha256 and v1.normalizer == "bound"
    assert [s.seed for s in v1] == [s.seed for s in v2]
    assert [s.config for s in v1] == [s.config for s in v2]
    # the rows both suites hold are the same planners on the same truth: the same rates
    for r in ("bound", "clairvoyant", "mpc_k1", "mpc_k10", "plan_once", "track_exact", "track_reports"):
        np.testing.assert_allclose([s.value(r) for s in v2], [s.value(r) for s in v1], rtol=1e-9, err_msg=r)


#: The summary line of a suite normalised by the optimum (K > 1: with the best schedule).
ONLINE_SUMMARY = re.compile(
    r"% of optimum mean (?P<mean>-?[\d.]+) \| p10 (?P<p10>-?[\d.]+) \| min (?P<min>-?[\d.]+); "
    r"% of bound mean (?P<bound>-?[\d.]+) \| p10 (?P<bound_p10>-?[\d.]+) \| min (?P<bound_min>-?[\d.]+); "
    r"(?:best schedule % of optimum mean (?P<best>-?[\d.]+); )?feasible (?P<feasible>\d+/\d+)"
)
ONLINE_COLUMNS = {"mean % of optimum": "mean", "p10": "p10", "min": "min", "mean % of bound": "bound",
                  "p10 % of bound": "bound_p10", "min % of bound": "bound_min",
                  "best schedule % of optimum": "best", "feasible": "feasible"}  # fmt: skip
LEADERBOARD_ROWS = [(name, row) for name in ONLINE_SUITES for row in _rows(name)]


def test_the_leaderboard_sections_are_sorted_and_on_their_suites():
    for name in ONLINE_SUITES:
        rows = _rows(name)
        means = [float(row["mean % of optimum"]) for row in rows]
        assert means == sorted(means, reverse=True), f"{name}: rows must be in order of mean % of optimum"
        assert rows and all(f"--suite {name}" in row["command"] for row in rows)
        assert any("evaluate" in row["command"] for row in rows)  # a policy, not only references


@pytest.mark.parametrize("name, row", LEADERBOARD_ROWS, ids=[f"{n}-{r['#']}" for n, r in LEADERBOARD_ROWS])
def test_a_leaderboard_row_reproduces_from_its_command(name, row, capsys):
    words = shlex.split(row["command"].strip("`"))
    assert words[:3] == ["python", "-m", "ios_uav_env.benchmark"]
    assert "--allow-task-change" not in words or task_changes_of(words[3:])
    assert cli_main(words[3:]) == 0
    match = ONLINE_SUMMARY.search(capsys.readouterr().out)
    assert match, row["command"]
    printed = {key: value for key, value in match.groupdict().items() if value is not None}
    table = {key: row[column] for column, key in ONLINE_COLUMNS.items() if column in row}
    assert printed == table, f"{row['command']}: the table says {table}, the command prints {printed}"
