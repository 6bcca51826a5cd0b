"""agents.suite (and its report): the held-out suite file, its build (cached, resumable) and
the report of a policy on it (run with a heuristic policy: no training needed)."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

import ios_uav_env
from agents.rollout import ScenarioRunner
from agents.suite.__main__ import main
from agents.suite.report import HEURISTICS, evaluate_suite, load_policy, run_report, suite_score, summarize
from baselines import dp
from baselines.references import solve as solve_module
from baselines.references.heldout import (
    DEFAULT_SIZE,
    HELDOUT_SEED,
    SUITE_PATH,
    build_suite,
    cache_key,
    load_suite,
    suite_configs,
)
from ios_uav_env import DEFAULT_RANGES, RANDOM_ENV_ID, ScenarioRanges, average_rate, check_trajectory
from ios_uav_env.benchmark import load_suite as load_benchmark
from ios_uav_env.envs.policies import HoverAt
from tests.tolerances import PLANNER_REL, RATE_REL

#: A family of tiny scenarios (N <= 12, M <= 60) whose planners run in a fraction of a second.
TINY = ScenarioRanges(
    ground_x=(-50.0, 50.0), ground_y=(-30.0, 30.0), T=(10.0, 12.0), ios_rows=(4, 6), ios_columns=10,
    start_x=(-60.0, -60.0), start_y=(-5.0, 5.0), end_x=(60.0, 60.0), end_y=(-5.0, 5.0),
)  # fmt: skip


@pytest.fixture(scope="module")
def suite():
    return load_suite()  # the held-out plan file (DP and SCA plans with their trajectories)


@pytest.fixture(scope="module")
def bench():
    return load_benchmark("single-node-v1")  # the frozen suite of the same draw, which reports score on


# --- the shipped suite -----------------------------------------------------------------------
def test_the_shipped_suite_is_the_documented_draw(suite):
    assert SUITE_PATH.exists() and SUITE_PATH.stat().st_size < 500_000
    assert len(suite) == DEFAULT_SIZE >= 50 and suite.seed == HELDOUT_SEED == 20261122
    assert suite.ranges == DEFAULT_RANGES and suite.dp_resolution == 2.5
    assert suite.configs() == suite_configs(DEFAULT_SIZE, HELDOUT_SEED, DEFAULT_RANGES)
    training = {c for seed in range(16) for c in suite_configs(4, seed)}  # small training seeds
    assert not training & set(suite.configs())
    for e in suite:
        n = e.config.N
        assert e.dp["trajectory"].shape == e.sca["trajectory"].shape == (n, 2)
        assert e.dp_rate > 0 and e.sca["rate"] > 0 and isinstance(e.sca["feasible"], bool)
        assert 95.0 < e.sca_pct_dp < 105.0 and e.dp["seconds"] > 0 and e.sca["seconds"] > 0


def test_cached_optima_match_a_fresh_dp(suite):
    e = min(suite, key=lambda e: e.config.N)
    plan = dp.solve(e.config, resolution=suite.dp_resolution)
    assert plan.mean_rate == pytest.approx(e.dp_rate, rel=PLANNER_REL)
    assert np.abs(plan.trajectory - e.dp["trajectory"]).max() <= 5e-4 + 1e-9  # rounded to 1e-3 m


def test_stored_trajectories_reproduce_their_rates(suite):
    for e in suite:
        for plan in (e.dp, e.sca):
            assert average_rate(e.config, plan["trajectory"]) == pytest.approx(plan["rate"], abs=1e-5)
        assert check_trajectory(e.config, e.dp["trajectory"], tol=2e-3).feasible


# --- building a suite --------------------------------------------------------------------------
def test_build_writes_a_suite_and_resumes_from_its_cache(tmp_path, monkeypatch):
    path, cache = tmp_path / "tiny.json", tmp_path / "cache"
    built = build_suite(path, n=3, seed=1, ranges=TINY, jobs=1, cache_dir=cache, progress=False)
    loaded = load_suite(path)
    assert loaded.configs() == built.configs() == suite_configs(3, 1, TINY) and loaded.ranges == TINY
    assert [e.dp_rate for e in loaded] == [e.dp_rate for e in built]
    for e in loaded:
        fresh = dp.solve(e.config, resolution=2.5)
        assert fresh.mean_rate == pytest.approx(e.dp_rate, rel=PLANNER_REL) and e.sca["feasible"]
    files = sorted(cache.glob("*.json"))
    assert [f.stem for f in files] == sorted(cache_key(c, 2.5) for c in built.configs())

    calls = []
    real = solve_module.solve_scenario
    monkeypatch.setattr(
        solve_module, "solve_scenario", lambda task, **kw: calls.append(task) or real(task, **kw)
    )
    files[0].unlink()  # as if interrupted before that scenario
    again = build_suite(path, n=3, seed=1, ranges=TINY, jobs=1, cache_dir=cache, progress=False)
    assert len(calls) == 1 and json.loads(files[0].read_text())["config"] == calls[0]["config"]
    assert [e.dp_rate for e in again] == [e.dp_rate for e in built]


def test_show_and_bad_files(tmp_path, capsys):
    assert main(["show", "--table"]) == 0
    out = capsys.readouterr().out
    assert f"{DEFAULT_SIZE} scenarios, seed {HELDOUT_SEED}" in out and "% of DP on average" in out
    assert len([line for line in out.splitlines() if line.strip()[:2].strip().isdigit()]) == DEFAULT_SIZE
    with pytest.raises(SystemExit):
        main(["show", "--suite", str(tmp_path / "missing.json")])
    (tmp_path / "other.json").write_text('{"format": "something else"}')
    with pytest.raises(ValueError, match="not a suite file"):
        load_suite(tmp_path / "other.json")


# --- the report ------------------------------------------------------------------------------
def test_report_end_to_end_with_a_heuristic_policy(bench, tmp_path):
    result = run_report(HoverAt("ground"), tmp_path, n=3, progress=False)
    results, s = result["results"], result["summary"]
    rows = results.scenarios
    assert results.suite == "single-node-v1" and [r.index for r in rows] == [0, 1, 2] and s["n"] == 3
    for r in rows:
        cfg = bench[r.index].config
        assert r.rate == average_rate(cfg, r.trajectory) and r.feasible  # the guard
        assert r.pct_dp == pytest.approx(100 * r.rate / bench[r.index].dp_rate)
        # plan times are wall times (a cold numba cache compiles in the first episode, a busy
        # machine stretches them): checked for sign and for the summary's arithmetic, not speed
        assert 0 < r.pct_dp < 102.0 and r.seconds > 0
        assert np.array_equal(r.trajectory[0], cfg.q0) and np.allclose(r.trajectory[-1], cfg.qF, atol=1e-6)
    pct = [r.pct_dp for r in rows]
    assert s["mean_pct_dp"] == pytest.approx(np.mean(pct)) and s["min_pct_dp"] == min(pct)
    assert s["feasible"] == 3 and s["median_seconds"] == pytest.approx(np.median([r.seconds for r in rows]))
    assert s["speedup"] == pytest.approx(s["sca_median_seconds"] / s["median_seconds"])
    assert s["sca_mean_pct_dp"] == pytest.approx(
        np.mean([100 * b.sca_rate / b.dp_rate for b in bench.subset(3)])
    )
    with open(result["paths"]["csv"], newline="") as fh:
        table = list(csv.DictReader(fh))
    assert [int(t["index"]) for t in table] == [0, 1, 2] and float(table[0]["rate"]) == rows[0].rate
    text = (tmp_path / "results.md").read_text()
    assert text.count("\n| ") == 4 and "% of DP mean" in text
    for name in ("suite_trajectories.png", "pct_dp.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_suite_score_and_fixed_id_policies(bench):
    score = suite_score(HoverAt("ground"), bench, n=3)
    rows = evaluate_suite(HoverAt("ground"), bench, n=3)
    assert score == {
        "mean_pct_dp": summarize(rows)["mean_pct_dp"],
        "p10_pct_dp": summarize(rows)["p10_pct_dp"],
        "min_pct_dp": summarize(rows)["min_pct_dp"],
        "feasible_frac": 1.0,
        "n": 3,
    }
    # a policy of a fixed id runs in that id made on each scenario: same observation prefix
    fixed = evaluate_suite(HoverAt("ground"), bench, n=3, env_id="ios_uav_env/IOSUAV-v0")
    assert [r.rate for r in fixed] == [r.rate for r in rows]
    # the randomised id runs the scenarios at once in its batched env: one env pinned per
    # scenario gives the same episodes
    peak = HoverAt("peak")
    batched = evaluate_suite(peak, bench, n=4)
    with ScenarioRunner(RANDOM_ENV_ID, peak.env_kwargs) as runner:
        single = [runner.run(peak, e.config, seed=0) for e in bench.subset(4)]
    for row, episode in zip(batched, single, strict=True):
        np.testing.assert_allclose(row.trajectory, episode.trajectory, atol=1e-9)
        assert row.rate == pytest.approx(episode.average_rate, rel=1e-12)


def test_report_cli_and_shipped_agent(tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    from agents.evaluate import MODELS_DIR

    assert main(["report", "--model", "heuristic", "--n", "2", "--out", str(tmp_path)]) == 0
    assert "held-out scenarios" in capsys.readouterr().out and (tmp_path / "results.csv").exists()
    with pytest.raises(SystemExit):
        main(["report", "--model", str(tmp_path / "nothing"), "--n", "1"])
    shipped = MODELS_DIR / "ppo_IOSUAV-v0"
    with pytest.raises(ValueError, match="PPO model, not SAC"):
        load_policy(shipped, "sac")
    rows = evaluate_suite(load_policy(shipped, "ppo"), n=2)  # an 11-feature agent, on single-node-v1
    assert len(rows) == 2 and all(r.rate > 0 for r in rows)


def test_peak_heuristic_follows_the_hint_and_beats_flying_to_g_where_the_surface_matters(bench):
    assert set(HEURISTICS) == {"heuristic", "peak-heuristic"}
    peak = load_policy("peak-heuristic")
    assert peak.env_kwargs == {"peak_hint": True}
    # scenario 15: G at (49, -30), 50 m in front of the IOS; the best hover point is across it
    cfg = bench[15].config
    assert cfg.ground_node[0] > 0 and ios_uav_env.rate_peak(cfg).x < 0
    (by_peak,) = [r for r in evaluate_suite(peak, bench, n=16) if r.index == 15]
    (by_g,) = [r for r in evaluate_suite(HoverAt("ground"), bench, n=16) if r.index == 15]
    assert by_peak.feasible and by_peak.pct_dp > 98.0 > 80.0 > by_g.pct_dp


def test_shipped_generalist_reproduces_its_recorded_suite_rows(bench):
    pytest.importorskip("stable_baselines3")
    from agents.evaluate import MODELS_DIR

    folder = MODELS_DIR / "ppo_IOSUAV-Random-v0"
    with open(folder / "suite_report.csv", newline="") as fh:
        recorded = list(csv.DictReader(fh))
    assert len(recorded) == len(bench) == 60
    pct = [float(r["pct_dp"]) for r in recorded]
    # the bars (mean >= 97%, min >= 90% of DP, every plan feasible), on the recorded table
    assert np.mean(pct) >= 97.0 and min(pct) >= 90.0 and all(r["feasible"] == "True" for r in recorded)
    agent = load_policy(folder)
    assert agent.env_kwargs["peak_hint"] is True
    rows = evaluate_suite(agent, bench, n=8)
    for row, rec in zip(rows, recorded, strict=False):
        assert row.index == int(rec["index"]) and row.feasible
        assert row.rate == pytest.approx(float(rec["rate"]), rel=RATE_REL)


# --- multi-node agents: scored on the benchmark's multi-node suite (agents.suite.multi) ---------
@pytest.mark.parametrize(
    "env_id", ["ios_uav_env/IOSUAV-MultiNode-Random-v0", "ios_uav_env/IOSUAV-MultiNode-v0"]
)
def test_a_multinode_model_is_reported_on_the_multinode_suite(tmp_path, env_id, capsys):
    import gymnasium as gym
    from stable_baselines3 import PPO

    from ios_uav_env.benchmark import load_suite as load_benchmark

    folder = tmp_path / "model"
    folder.mkdir()
    PPO("MlpPolicy", gym.make(env_id), seed=0, device="cpu").save(folder / "model.zip")
    (folder / "config.json").write_text(json.dumps({"algo": "ppo", "env_id": env_id, "env_kwargs": {}}))
    out = tmp_path / "report"
    assert main(["report", "--model", str(folder), "--n", "6", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    suite = load_benchmark("multi-node-v1").subset(6)
    fits = [s.index for s in suite if env_id.endswith("Random-v0") or s.config.K <= 3]
    assert len(fits) < 6 or env_id.endswith("Random-v0")  # the 3-node model skips the K = 4 scenarios
    assert f"on multi-node-v1 ({len(fits)} scenarios): % of SCA mean" in printed
    rows = list(csv.DictReader((out / "results.csv").open()))
    assert [int(r["index"]) for r in rows] == fits
    assert all(float(r["rate"]) <= float(r["best_schedule_rate"]) for r in rows)
    assert {"shares.png", "pct_sca.png", "results.md", "trajectories.npz"} <= {p.name for p in out.iterdir()}


def test_node_orders_average_a_multinode_model_and_refuse_a_one_node_one(tmp_path, capsys):
    import gymnasium as gym
    from stable_baselines3 import PPO

    env_id = "ios_uav_env/IOSUAV-MultiNode-Random-v0"
    folder = tmp_path / "model"
    folder.mkdir()
    PPO("MlpPolicy", gym.make(env_id), seed=0, device="cpu").save(folder / "model.zip")
    (folder / "config.json").write_text(json.dumps({"algo": "ppo", "env_id": env_id, "env_kwargs": {}}))
    out = tmp_path / "report"
    assert main(["report", "--model", str(folder), "--n", "2", "--out", str(out), "--node-orders"]) == 0
    assert "(node orders averaged) on multi-node-v1 (2 scenarios): % of SCA mean" in capsys.readouterr().out
    assert len(list(csv.DictReader((out / "results.csv").open()))) == 2
    with pytest.raises(SystemExit):
        main(["report", "--model", "heuristic", "--node-orders", "--out", str(tmp_path / "one")])
    assert "argument --node-orders: heuristic is a one-node model" in capsys.readouterr().err


def test_shipped_multinode_generalist_reproduces_its_recorded_suite_rows():
    # agents/models/dagger_IOSUAV-MultiNode-Random-v0 (agents.imitation): its recorded
    # suite table, the numbers the README states, and 8 of its rows replayed from the model
    pytest.importorskip("stable_baselines3")
    from agents.evaluate import MODELS_DIR
    from agents.evaluate_multi import fast_act
    from agents.suite.multi import suite_env_kwargs
    from ios_uav_env.benchmark import load_suite as load_benchmark
    from ios_uav_env.benchmark.results import spread
    from ios_uav_env.benchmark.scoring import evaluate_scenarios

    folder = MODELS_DIR / "dagger_IOSUAV-MultiNode-Random-v0"
    recorded = list(csv.DictReader((folder / "suite_report.csv").open()))
    suite = load_benchmark("multi-node-v1")
    assert [int(r["index"]) for r in recorded] == [s.index for s in suite] and len(recorded) == 48
    pct = np.array([float(r["pct_sca"]) for r in recorded])
    assert all(r["feasible"] == "True" and r["own_shares"] == "True" for r in recorded)
    summary = json.loads((folder / "summary.json").read_text())
    assert spread(pct)[:2] == pytest.approx(
        (summary["suite"]["mean_pct_sca"], summary["suite"]["p10_pct_sca"])
    )
    assert summary["suite"]["mean_pct_sca"] > 90.0  # 31% for pure PPO in 12M steps (results/log.md)
    agent = load_policy(folder)
    assert agent.env_kwargs["peak_hint"] is True and agent.meta["config"]["trained_by"] == "agents.imitation"
    chosen = suite.subset(8)
    rows = evaluate_scenarios(
        fast_act(agent), suite, chosen, suite_env_kwargs(agent, 4), 0, "dagger"
    ).scenarios
    for row, rec in zip(rows, recorded, strict=False):
        assert row.index == int(rec["index"]) and row.feasible
        assert row.rate == pytest.approx(float(rec["rate"]), rel=RATE_REL)


# --- results folders, task changes, plan times and errors of the report and the curve ----------
def _exit_2(capsys, argv) -> str:
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2
    return capsys.readouterr().err.strip().splitlines()[-1]


def test_report_refuses_an_out_holding_results_and_overwrite_removes_the_stale_ones(tmp_path, capsys):
    argv = ["report", "--model", "heuristic", "--n", "1", "--out", str(tmp_path)]
    assert main(argv) == 0
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert {"results.md", "suite_trajectories.png", "pct_dp.png"} <= set(before)
    line = _exit_2(capsys, argv)
    assert "argument --out: " in line and "results.md" in line and "--overwrite" in line
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
    (tmp_path / "shares.png").write_bytes(b"a multi-node report's figure")  # a previous run's file
    assert main([*argv, "--overwrite"]) == 0
    assert not (tmp_path / "shares.png").exists() and (tmp_path / "suite_trajectories.png").exists()


def test_curve_refuses_an_out_holding_a_curve_and_keeps_it_until_a_new_row_is_written(
    tmp_path, capsys, monkeypatch
):
    from agents.suite import curve

    (tmp_path / "suite_curve.png").write_bytes(b"the previous curve")
    argv = ["curve", "--run", str(tmp_path / "no-run"), "--out", str(tmp_path)]
    assert "argument --out: " in _exit_2(capsys, argv)
    assert "argument --run: " in _exit_2(capsys, [*argv, "--overwrite"])  # no checkpoint: nothing removed
    assert (tmp_path / "suite_curve.png").read_bytes() == b"the previous curve"
    row = {"mean_pct_dp": 99.0, "p10_pct_dp": 98.0, "min_pct_dp": 97.0, "feasible": 2, "n": 2}
    (tmp_path / "rl_model_1000_steps.zip").write_bytes(b"")
    monkeypatch.setattr(curve, "checkpoints", lambda run: [(1000, tmp_path / "rl_model_1000_steps.zip")])
    monkeypatch.setattr(curve, "load_agent", lambda *a, **k: HoverAt("ground"))
    monkeypatch.setattr(curve, "summarize", lambda results: row)
    monkeypatch.setattr(curve, "evaluate_suite", lambda *a, **k: None)
    seen = []
    real = curve.remove_stale
    monkeypatch.setattr(curve, "remove_stale", lambda stale, kept: seen.extend(real(stale, kept)))
    assert main([*argv, "--overwrite"]) == 0
    assert [p.name for p in seen] == ["suite_curve.png"]  # removed before the first row, then redrawn
    assert (tmp_path / "suite_curve.csv").read_text().splitlines()[1].startswith("1000,")


class NoGuard(HoverAt):
    """HoverAt("ground") in an env without the arrival guard: another task than the suite's."""

    env_kwargs = {"arrival_guard": False}


def test_report_refuses_a_task_change_and_names_it_everywhere_with_the_opt_in(bench, tmp_path, capsys):
    with pytest.raises(ValueError, match=r"arrival_guard=False \(the suite's: True.*--allow-task-change"):
        run_report(NoGuard("ground"), tmp_path / "a", n=1, progress=False)
    assert not (tmp_path / "a").exists() or not any((tmp_path / "a").iterdir())
    out = tmp_path / "b"
    result = run_report(NoGuard("ground"), out, n=1, progress=False, allow_task_change=True)
    label = "single-node-v1 with arrival_guard=False [not single-node-v1's task]"
    printed = capsys.readouterr().out
    assert result["results"].task == label and result["summary"]["task"] == label
    assert f"held-out scenarios of {label}" in printed and f"on {label} (1 scenarios)" in printed
    assert label in (out / "results.md").read_text() and label in (out / "results.json").read_text()


def test_a_fixed_id_report_times_warm_episodes_and_names_a_failing_scenario(bench, monkeypatch):
    import types

    from ios_uav_env.benchmark import PolicyError
    from ios_uav_env.envs import rollout

    clock = types.SimpleNamespace(now=0.0)
    monkeypatch.setattr(rollout, "time", types.SimpleNamespace(perf_counter=lambda: clock.now))
    calls = []

    def slow_first(obs):  # its first call costs 100 s of the fake clock (a compilation), others 1 s
        clock.now += 1.0 if calls else 100.0
        calls.append(1)
        return HoverAt("ground")(obs)

    rows = evaluate_suite(slow_first, bench, n=2, env_id="ios_uav_env/IOSUAV-v0")
    steps = [bench[i].config.N - 1 for i in range(2)]
    assert [r.seconds for r in rows] == [float(s) for s in steps]  # the warm-up episode took the 100 s
    assert len(calls) == steps[0] + sum(steps)

    def breaks(obs):
        raise KeyError("feature")

    with pytest.raises(
        PolicyError, match=r"scenario 0 \(the unscored warm-up episode\) of suite single-node-v1"
    ):
        evaluate_suite(breaks, bench, n=1, env_id="ios_uav_env/IOSUAV-v0")
