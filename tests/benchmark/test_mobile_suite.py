"""The mobile suite kind: a tiny suite frozen by ``python -m baselines.references mobile --quick``
loads, its checks refuse a tampered file, and a policy or a plan file is scored on it by the
same ``evaluate`` / ``score_trajectories`` on the node's true path, as % of the clairvoyant
bound and of MPC(k=1); the evaluator replays the suite's own env rows exactly."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from baselines.references.mobile import mobile_tasks
from ios_uav_env import MOBILE_IDS, score_plan
from ios_uav_env.benchmark import evaluate, load_suite, reference_results, score_trajectories
from ios_uav_env.envs.policies import HoverAt
from ios_uav_env.model.motion import node_paths
from tests.benchmark.quick_suites import freeze_quick, tampered


@pytest.fixture(scope="module")
def frozen(tmp_path_factory) -> Path:
    return freeze_quick(tmp_path_factory, "mobile")


@pytest.fixture(scope="module")
def suite(frozen):
    return load_suite(frozen)


def test_the_quick_suite_loads_as_a_mobile_suite(suite):
    assert suite.kind == "mobile" and suite.mobile and suite.env_id in MOBILE_IDS
    assert suite.normalizer == "bound" and suite.references[0] == "bound"
    (s,) = suite.scenarios
    assert s.config.motion is not None and s.config.K == 1 and isinstance(s.seed, int)
    assert s.seed == mobile_tasks(1, 20261130)[0]["seed"]  # the held-out stream's own seed
    ub = s.value("bound")
    for r in suite.references[1:]:
        assert 0 < s.value(r) <= ub and s.reference[r]["feasible"], r
    np.testing.assert_array_equal(s.paths(), node_paths(s.config, np.random.default_rng(s.seed)))
    assert np.ptp(s.paths()[:, 0, 0]) > 1.0  # the node walks


def test_the_evaluator_replays_the_suites_env_rows_on_the_true_path(suite):
    """HoverAt("ground") on the suite's env (reports) and on exact knowledge gives the stored
    track rows exactly: the same seed, the same draws, the same scorer; batched too."""
    (s,) = suite.scenarios
    reports = evaluate(HoverAt("ground"), suite)
    # exact knowledge is another task than the suite's: run only when asked for, and named so
    exact = evaluate(HoverAt("ground"), suite, env_kwargs={"knowledge": "exact"}, allow_task_change=True)
    assert exact.task == "mobile-quick-v1 with knowledge='exact' [not mobile-quick-v1's task]"
    batched = evaluate(HoverAt("ground"), suite, batched=True)
    assert reports.scenarios[0].rate == s.value("track_reports")
    assert exact.scenarios[0].rate == s.value("track_exact")
    assert batched.scenarios[0].rate == s.value("track_reports")
    row = reports.scenarios[0]
    assert row.pct_bound == pytest.approx(100 * row.rate / s.value("bound"))
    assert row.pct_mpc_k1 == pytest.approx(100 * row.rate / s.value("mpc_k1"))
    assert "MPC(k=1)" in reports.summary()
    # the reset seed of a mobile scenario is its own: another evaluate seed changes nothing
    assert evaluate(HoverAt("ground"), suite, seed=7).scenarios[0].rate == row.rate
    # a plan file is scored on the true path too (not on the configured position)
    files = score_trajectories({0: row.trajectory}, suite)
    assert files.scenarios[0].rate == row.rate
    static = score_plan(s.config.replace(motion=None), row.trajectory).rate
    assert static != row.rate


def test_an_env_that_draws_another_path_is_refused(suite, monkeypatch):
    import sys

    import ios_uav_env.envs.single  # noqa: F401  (loads the env modules that draw the path)
    from ios_uav_env.envs import knowledge

    real = knowledge.start_track

    def shifted(cfg, rng, sigma):
        rng.standard_normal()  # one draw before the path: another path
        return real(cfg, rng, sigma)

    users = [m for name, m in list(sys.modules.items())
             if name.startswith("ios_uav_env.envs") and getattr(m, "start_track", None) is real]  # fmt: skip
    assert len(users) >= 2  # knowledge and the env module that calls it
    for module in users:
        monkeypatch.setattr(module, "start_track", shifted)
    with pytest.raises(RuntimeError, match="another node path"):
        evaluate(HoverAt("ground"), suite)


def test_reference_rows_and_at_once(suite):
    bound = reference_results(suite, "bound")
    assert bound.scenarios[0].pct_bound == pytest.approx(100.0)
    with pytest.raises(ValueError, match="static single-node suites"):
        evaluate(HoverAt("ground"), suite, batched=True, at_once=True)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda s: s.pop("seed"), "seed must be an integer >= 0"),
        (lambda s: s.update(seed=-1), "seed must be an integer >= 0"),
        (lambda s: s["config"].pop("motion"), "needs a motion model"),
        (lambda s: s["mpc_k10"].update(rate=s["bound"]["upper_bound"] * 1.01), "is below mpc_k10"),
        (lambda s: s["mpc_k1"].update(rate=0.0), r"mpc_k1.rate \(bps/Hz\) must be a finite number > 0"),
    ],
)
def test_a_tampered_file_is_refused(frozen, tmp_path, change, message):
    with pytest.raises(ValueError, match=message):
        load_suite(tampered(frozen, tmp_path, lambda data: change(data["scenarios"][0])))


def test_a_seed_in_a_static_suite_is_refused(tmp_path):
    from ios_uav_env.benchmark.suite import suite_path

    data = json.loads(suite_path("energy-v1").read_text())
    data["name"] = "energy-tampered"
    data["scenarios"][0]["seed"] = 3
    path = tmp_path / "static.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="only a mobile suite's scenarios have a seed"):
        load_suite(path)


@pytest.mark.parametrize("knowledge", ["reports", "exact"])
def test_the_reports_replay_from_the_seed_without_the_flight(suite, knowledge):
    """The figure's reports are the env's: the draws replay from the seed alone."""
    from ios_uav_env.envs.knowledge import episode_reports
    from ios_uav_env.envs.single import IOSUAVEnv

    (s,) = suite.scenarios
    sigma = {"report_sigma": 7.0} if knowledge == "reports" else {}  # (exact knowledge takes no report_sigma)
    env = IOSUAVEnv(s.config, knowledge=knowledge, **sigma)
    env.reset(seed=s.seed, options={"config": s.config})
    while len(env.trajectory) < s.config.N:
        env.step(np.array([0.3, -0.8]))
    truth, reports = episode_reports(s.config, s.seed, 7.0, knowledge)
    np.testing.assert_array_equal(truth, env.paths)
    np.testing.assert_array_equal(reports, env.reports)


def test_a_mobile_result_saves_its_figure(suite, tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    results = evaluate(HoverAt("ground"), suite)
    paths = results.save(tmp_path)
    assert paths["mobile"].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # and a panel per scenario: the grid figure has one axes for each
    from matplotlib.image import imread

    from ios_uav_env.benchmark import figures

    assert paths["mobile_scenarios"].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    drawn = []
    real = figures._mobile_panel
    monkeypatch.setattr(
        figures, "_mobile_panel", lambda ax, r, *a, **k: (drawn.append(r.index), real(ax, r, *a, **k))
    )
    figures.save_mobile_figure(results, tmp_path / "all.png", count=None)
    assert drawn == [r.index for r in results.scenarios] and imread(tmp_path / "all.png").shape[0] > 0
