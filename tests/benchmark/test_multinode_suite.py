"""The multi-node suite ``multi-node-v1``: the documented held-out draw, hash-checked, its stored
values reproducible from the planners (a cheap sample), and the scorer of any multi-node policy
or plan file (own shares or the best schedule), from Python and from the command line."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from baselines.references.draws import ENTROPY, SPAWN_KEY, heldout_rng, multinode_configs
from ios_uav_env.benchmark import SUITES, evaluate, load_suite, reference_results, score_trajectories
from ios_uav_env.benchmark.cli import main
from ios_uav_env.benchmark.multi_policies import StraightEqualShares
from ios_uav_env.benchmark.suite import content_hash, suite_path
from ios_uav_env.benchmark.trajectories import read_plans, write_trajectories
from ios_uav_env.model.schedule import maxmin_rate, scheduled_rates
from tests.tolerances import PLANNER_REL, SOLVER_REL

ROOT = Path(__file__).resolve().parents[2]
PLANS = ROOT / "results" / "benchmark" / "multi-node-v1"


@pytest.fixture(scope="module")
def suite():
    return load_suite("multi-node-v1")


def test_the_suite_is_the_documented_held_out_draw(suite):
    path = suite_path("multi-node-v1")
    assert suite.sha256 == SUITES["multi-node-v1"].sha256 == content_hash(json.loads(path.read_text()))
    assert len(suite) == 48 and suite.kind == "multi-node" and suite.normalizer == "sca"
    assert suite.env_id == "ios_uav_env/IOSUAV-MultiNode-Random-v0" and path.stat().st_size < 100_000
    assert [s.config for s in suite] == multinode_configs(48)
    assert {s.config.K for s in suite} == {2, 3, 4} and {s.config.surface for s in suite} == {"ios", "ris"}
    # a spawned seed sequence: never the stream of a reset seed (those have no spawn key)
    assert (ENTROPY, SPAWN_KEY) == (20261130, (17,))
    state = heldout_rng().bit_generator.state["state"]["state"]
    assert all(np.random.default_rng(s).bit_generator.state["state"]["state"] != state for s in range(2000))
    env = gym.make("ios_uav_env/IOSUAV-MultiNode-Random-v0")
    firsts = {s.config.nodes for s in suite}
    for seed in range(300):  # the first scenario of a training reset is never a suite scenario
        env.reset(seed=seed)
        assert env.unwrapped.config.nodes not in firsts
    env.close()


def test_stored_values_are_consistent(suite):
    for s in suite:
        ub = s.rate("bound")
        assert s.reference["bound"]["resolution"] == 2.5 and s.reference["bound"]["plan_feasible"]
        for rate in (s.rate("sca"), s.rate("tour"), s.reference["bound"]["plan_rate"]):
            assert 0 < rate <= ub + 1e-9, s.index
        assert s.reference["sca"]["feasible"] and s.reference["tour"]["feasible"], s.index
        assert s.reference["sca"]["seconds"] > 0 and s.reference["tour"]["seconds"] > 0
    wins = sum(s.rate("sca") >= s.rate("tour") - 1e-12 for s in suite)
    assert wins >= 0.9 * len(suite)


def test_a_sample_of_stored_values_reproduces_from_the_planners(suite):
    """The cheapest scenarios: the tour on two, SCA on one, the bound on one (< 20 s)."""
    from baselines import sca, tour
    from baselines.dp_bound import solve_multinode

    cheap = sorted(suite, key=lambda s: s.reference["tour"]["seconds"])[:2]
    for s in cheap:
        plan = tour.solve(s.config)
        assert plan.mean_rate == pytest.approx(s.rate("tour"), rel=PLANNER_REL) and plan.feasible, s.index
    s = min(suite, key=lambda s: s.reference["sca"]["seconds"])
    plan = sca.solve(s.config)
    assert plan.feasible and plan.mean_rate == pytest.approx(s.rate("sca"), rel=SOLVER_REL), s.index
    s = min(suite, key=lambda s: s.reference["bound"]["seconds"])
    res = s.reference["bound"]["resolution"]
    plan = solve_multinode(s.config, resolution=res, bound_resolution=res)
    assert plan.info["upper_bound"] == pytest.approx(s.rate("bound"), rel=PLANNER_REL), s.index
    assert plan.mean_rate == pytest.approx(s.reference["bound"]["plan_rate"], rel=PLANNER_REL)


@pytest.mark.parametrize("reference", ["tour", "sca"])
def test_the_planners_plans_reproduce_the_stored_rates(suite, reference):
    trajectories, seconds, shares = read_plans(PLANS / f"{reference}.npz")
    assert sorted(shares) == sorted(trajectories) == list(range(48))
    results = score_trajectories(trajectories, suite, seconds=seconds, shares=shares, name=reference)
    for r, s in zip(results.scenarios, suite, strict=True):
        assert r.own_shares and r.feasible
        assert r.rate == pytest.approx(s.rate(reference), rel=1e-12, abs=1e-15), s.index
        assert r.best_schedule_rate == pytest.approx(r.rate, rel=1e-9)
    stored = reference_results(suite, reference).aggregate
    assert results.aggregate.mean_pct_sca == pytest.approx(stored.mean_pct_sca, rel=1e-9)
    assert results.aggregate.mean_pct_bound == pytest.approx(stored.mean_pct_bound, rel=1e-9)


def test_a_policy_is_scored_by_its_own_shares_and_the_env_agrees(suite):
    policy = StraightEqualShares()
    results = evaluate(policy, "multi-node-v1", n=3)
    env = gym.make(suite.env_id)
    for r, s in zip(results.scenarios, suite, strict=False):
        obs, info = env.reset(seed=0, options={"config": s.config})
        done = False
        while not done:
            obs, _, done, _, info = env.step(policy(obs))
        q, a = env.unwrapped.trajectory, env.unwrapped.shares
        assert r.rate == pytest.approx(info["min_rate"], rel=1e-12) == scheduled_rates(s.config, q, a).min()
        assert r.best_schedule_rate == info["best_schedule_rate"] == maxmin_rate(s.config, q)
        assert r.rate < r.best_schedule_rate and r.own_shares and r.feasible
        assert np.allclose(a, 1.0 / s.config.K) and a.shape == (s.config.K, s.config.N)
        assert r.pct_sca == pytest.approx(100 * r.rate / s.rate("sca"))
        assert r.pct_bound == pytest.approx(100 * r.rate / s.rate("bound"))
        np.testing.assert_array_equal(r.trajectory, q)
    env.close()
    pct = [r.pct_sca for r in results.scenarios]
    a = results.aggregate
    assert (a.mean_pct_sca, a.p10_pct_sca, a.min_pct_sca) == pytest.approx(
        (np.mean(pct), np.percentile(pct, 10), min(pct))
    )
    assert "% of bound mean" in results.summary() and a.feasible == 3

    class SB3Like:
        def predict(self, obs, deterministic=False):
            return policy(obs), None

    again = evaluate(SB3Like(), suite, n=3)
    assert [r.rate for r in again.scenarios] == [r.rate for r in results.scenarios]


def test_a_policys_plan_time_leaves_out_the_envs_scoring_lp(suite, monkeypatch):
    """As a planner's time stops before ``Plan.from_trajectory`` scores its plan, a policy's stops
    before the env's best-schedule LP of the last step (``score_seconds``)."""
    import time

    from ios_uav_env.envs import multi_node as multinode_env

    real = multinode_env.reported_maxmin_rate

    def slow(config, trajectory, paths=None, kernels=None):
        time.sleep(1.0)
        return real(config, trajectory, paths, kernels)

    evaluate(StraightEqualShares(), suite, n=1)  # compiled first: the timed episode is warm
    monkeypatch.setattr(multinode_env, "reported_maxmin_rate", slow)
    start = time.perf_counter()
    results = evaluate(StraightEqualShares(), suite, n=1)
    assert time.perf_counter() - start > 1.0  # the LP ran
    assert 0.0 < results.scenarios[0].seconds < 1.0  # a warm straight-line episode: milliseconds
    assert results.scenarios[0].best_schedule_rate == maxmin_rate(
        suite[0].config, results.scenarios[0].trajectory
    )


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
def test_plan_files_with_and_without_shares(tmp_path, suite, suffix):
    results = evaluate(StraightEqualShares(), suite, n=3)
    plans = {r.index: r.trajectory for r in results.scenarios}
    shares = {r.index: r.shares for r in results.scenarios}
    path = write_trajectories(tmp_path / f"plans{suffix}", plans, None, shares)
    trajectories, _, read = read_plans(path)
    assert all(np.allclose(read[i], shares[i], rtol=0, atol=0) for i in shares)
    own = score_trajectories(trajectories, suite, shares=read)
    assert [r.rate for r in own.scenarios] == [r.rate for r in results.scenarios]
    best = score_trajectories(trajectories, suite)  # no shares: the best schedule of each trajectory
    for r, o in zip(best.scenarios, own.scenarios, strict=True):
        assert not r.own_shares and r.rate == r.best_schedule_rate == o.best_schedule_rate > o.rate


def test_shares_errors_name_the_scenario(suite):
    q = {i: np.linspace(s.config.q0, s.config.qF, s.config.N) for i, s in enumerate(suite.subset(2))}
    good = {i: np.full((s.config.K, s.config.N), 1.0 / s.config.K) for i, s in enumerate(suite.subset(2))}
    with pytest.raises(ValueError, match=r"not for \[1\]"):
        score_trajectories(q, suite, shares={0: good[0]})
    with pytest.raises(ValueError, match="scenario 1: shares' column sums"):
        score_trajectories(q, suite, shares={0: good[0], 1: 2 * good[1]})
    with pytest.raises(ValueError, match="scenario 0: shares must have shape"):
        score_trajectories(q, suite, shares={0: good[0][:, 1:], 1: good[1]})
    single = load_suite("single-node-v1")
    q1 = {0: np.linspace(single[0].config.q0, single[0].config.qF, single[0].config.N)}
    with pytest.raises(ValueError, match="single-node suite"):
        score_trajectories(q1, single, shares={0: np.ones((1, single[0].config.N))})


def test_cli_show_and_evaluate(tmp_path, capsys):
    assert main(["show", "--suite", "multi-node-v1"]) == 0
    out = capsys.readouterr().out
    for reference in ("sca", "tour", "bound"):
        assert f"\n{reference} on multi-node-v1 (48 scenarios): % of SCA mean" in out
    assert main(["show", "--suite", "multi-node-v1", "--reference", "bound"]) == 0
    assert "% of bound mean 100.00 | p10 100.00 | min 100.00" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["show", "--suite", "multi-node-v1", "--reference", "dp"])
    spec = "ios_uav_env.benchmark.multi_policies:StraightEqualShares"
    out_dir = tmp_path / "straight"
    assert (
        main(["evaluate", "--suite", "multi-node-v1", "--policy", spec, "--n", "3", "--out", str(out_dir)])
        == 0
    )
    line = capsys.readouterr().out.splitlines()[0]
    assert "feasible 3/3" in line
    names = {p.name for p in out_dir.iterdir()}
    assert names >= {
        "results.csv",
        "results.json",
        "results.md",
        "trajectories.npz",
        "pct_sca.png",
        "shares.png",
    }
    assert (out_dir / "shares.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    header = (out_dir / "results.csv").read_text().splitlines()[0]
    assert header.startswith("index,K,rate,best_schedule_rate,feasible")
    assert main(["evaluate", "--suite", "multi-node-v1", "--trajectories", str(out_dir / "trajectories.npz"),
                 "--name", spec]) == 0  # fmt: skip
    assert capsys.readouterr().out.splitlines()[0] == line  # own shares kept: the same scores and times


def test_a_batched_policy_scores_as_the_plain_one(suite):
    policy = StraightEqualShares()
    plain = evaluate(policy, suite, n=2)
    batched = evaluate(lambda obs: np.stack([policy(o) for o in obs]), suite, n=2, batched=True)
    assert [r.to_dict() | {"seconds": 0} for r in batched.scenarios] == [
        r.to_dict() | {"seconds": 0} for r in plain.scenarios
    ]


def test_the_freeze_checks_report_every_violation():
    from baselines.references import check_record as _check
    from baselines.references import multinode_content

    ok = {"index": 3, "config": {}, "tour": {"rate": 0.30, "feasible": True},
          "sca": {"rate": 0.31, "feasible": True},
          "bound": {"upper_bound": 0.32, "plan_rate": 0.30}}  # fmt: skip
    assert _check(ok) == []
    bad = {**ok, "sca": {"rate": 0.29, "feasible": False, "error": "SolverError: x"},
           "bound": {"upper_bound": 0.295, "plan_rate": 0.30}}  # fmt: skip
    notes = " ".join(_check(bad))
    for text in ("#3: sca failed or infeasible (SolverError: x)", "#3: tour 0.300000000 > bound",
                 "dp-bound plan", "#3: SCA 0.290000 < tour 0.300000"):  # fmt: skip
        assert text in notes, text
    with pytest.raises(ValueError, match="no normaliser"):
        multinode_content([{**ok, "sca": {"rate": 0.0, "feasible": False}}], "x", 1)


def test_scoring_a_multinode_policy_imports_no_planner_and_no_deep_learning_library():
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from ios_uav_env.benchmark import evaluate\n"
        "from ios_uav_env.benchmark.multi_policies import StraightEqualShares\n"
        "r = evaluate(StraightEqualShares(), 'multi-node-v1', n=2)\n"
        "bad = {'cvxpy', 'torch', 'matplotlib', 'baselines', 'agents'} & set(sys.modules)\n"
        "assert not bad, bad\n"
        "print(r.aggregate.feasible)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd="/")
    assert proc.returncode == 0 and proc.stdout.strip() == "2", proc.stderr


def test_an_infeasible_plan_scores_zero_and_keeps_its_rates(suite):
    """A plan that never leaves q0 (it misses qF): every % is 0, its rates are still reported."""
    scenarios = suite.subset(2)
    stay = {s.index: np.tile(s.config.q0, (s.config.N, 1)) for s in scenarios}
    equal = {s.index: np.full((s.config.K, s.config.N), 1.0 / s.config.K) for s in scenarios}
    results = score_trajectories(stay, suite, shares=equal)
    for r, s in zip(results.scenarios, scenarios, strict=True):
        assert not r.feasible and r.worst_violation > 0
        assert r.rate == scheduled_rates(s.config, stay[s.index], equal[s.index]).min() > 0
        assert r.best_schedule_rate == maxmin_rate(s.config, stay[s.index]) > 0
        assert (r.pct_sca, r.pct_bound, r.best_pct_sca) == (0.0, 0.0, 0.0)
    assert results.aggregate.feasible == 0 and results.aggregate.mean_pct_bound == 0.0


def test_a_stored_reference_saves_without_plans(tmp_path, suite):
    """A reference's results hold no trajectories: the tables and the histogram, no shares figure."""
    paths = reference_results(suite, "sca", n=3).save(tmp_path)
    assert {p.name for p in tmp_path.iterdir()} == {
        "results.csv",
        "results.json",
        "results.md",
        "pct_sca.png",
    }
    assert set(paths) == {"csv", "json", "markdown", "figure"}
    assert json.loads((tmp_path / "results.json").read_text())["aggregate"]["mean_pct_sca"] == 100.0


def test_a_csv_plan_with_a_gap_in_its_shares_is_refused_naming_the_line(tmp_path, suite):
    """share_0 empty but share_1 given: refused, not read as node 0's share."""
    s = suite[0]
    q = np.linspace(s.config.q0, s.config.qF, s.config.N)
    a = np.full((s.config.K, s.config.N), 1.0 / s.config.K)
    path = write_trajectories(tmp_path / "plans.csv", {0: q}, None, {0: a})
    lines = path.read_text().splitlines()
    cells = lines[3].split(",")
    cells[5] = ""  # share_0 of slot 2
    lines[3] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValueError, match=r"plans\.csv:4: scenario 0: the shares must fill share_0"):
        read_plans(path)
