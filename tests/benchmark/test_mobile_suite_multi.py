"""The multi-node mobile suite kind (``multi-node-mobile``): a quick suite frozen by ``python -m
baselines.references multi-node-mobile --quick`` loads, the scorer plays any policy in
``ios_uav_env/IOSUAV-MultiNode-Mobile-v0`` on each scenario's episode seed and scores its own
shares on the nodes' true paths as % of the clairvoyant optimum and of the bound, replaying the
suite's ``straight`` row exactly; the optimum is the best of its clairvoyant candidates, and the
pipeline refuses a tampered record, naming it; the draws are the env's family from a stream of
their own."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from baselines.references.draws import ENTROPY
from baselines.references.mobile import mobile_tasks
from baselines.references.online import (
    MULTI_MOBILE_RANGES,
    MULTI_MOBILE_SIZE,
    ONLINE_SHARE,
    check_online_record,
    multi_mobile_tasks,
    online_rows,
)
from ios_uav_env import MULTINODE_MOBILE_ID, ScenarioConfig
from ios_uav_env.benchmark import SUITES, evaluate, load_suite, reference_results, score_trajectories
from ios_uav_env.benchmark.multi_policies import StraightEqualShares
from ios_uav_env.benchmark.suite import MULTI_MOBILE_REFERENCES, content_hash, suite_path
from ios_uav_env.model.motion import node_paths
from tests.benchmark.quick_suites import freeze_quick_online, rerun_tampered_online, tampered
from tests.tolerances import RATE_REL


@pytest.fixture(scope="module")
def frozen(tmp_path_factory) -> Path:
    return freeze_quick_online(tmp_path_factory, multi=True)


@pytest.fixture(scope="module")
def suite(frozen):
    return load_suite(frozen)


def test_the_quick_suite_loads_as_a_multi_node_mobile_suite(suite):
    assert suite.kind == "multi-node-mobile" and suite.env_id == MULTINODE_MOBILE_ID
    assert suite.mobile and suite.schedules and not suite.multi_node
    assert suite.references == MULTI_MOBILE_REFERENCES and suite.scores == ("optimum", "bound")
    (s,) = suite.scenarios
    assert s.config.K >= 2 and s.config.motion is not None and isinstance(s.seed, int)
    paths = s.paths()
    assert paths.shape == (s.config.N, s.config.K, 2)
    np.testing.assert_array_equal(paths, node_paths(s.config, np.random.default_rng(s.seed)))
    assert online_rows(s.config.K)[-1] == "straight"


def test_a_policy_is_scored_with_its_own_shares_on_the_true_paths(suite):
    (s,) = suite.scenarios
    result = evaluate(StraightEqualShares(), suite)
    row = result.scenarios[0]
    assert row.rate == s.value("straight")  # the pipeline's own row: same env, seed and scorer
    assert row.own_shares and row.shares.shape == (s.config.K, s.config.N)
    assert row.pct_optimum == pytest.approx(100 * row.rate / s.value("optimum"))
    assert row.pct_bound == pytest.approx(100 * row.rate / s.value("bound"))
    assert row.best_pct_optimum == pytest.approx(100 * row.best_schedule_rate / s.value("optimum"))
    assert row.best_schedule_rate >= row.rate
    summary = result.summary()
    assert "% of optimum mean" in summary and "best schedule % of optimum" in summary
    files = score_trajectories({0: row.trajectory}, suite, shares={0: row.shares})
    assert files.scenarios[0].rate == row.rate
    assert reference_results(suite, "optimum").aggregate.mean_pct_optimum == pytest.approx(100.0, rel=1e-12)


def test_a_single_node_scenario_is_refused(frozen, tmp_path):
    def one_node(data):
        config = data["scenarios"][0]["config"]
        config["ground_nodes"] = config["ground_nodes"][:1]

    with pytest.raises(ValueError, match="K >= 2"):
        load_suite(tampered(frozen, tmp_path, one_node))


def test_the_draws_are_the_envs_family_from_their_own_stream():
    env = gym.make(MULTINODE_MOBILE_ID)
    try:
        assert env.unwrapped.ranges == MULTI_MOBILE_RANGES
    finally:
        env.close()
    tasks = multi_mobile_tasks(3, 20261130)
    assert tasks == multi_mobile_tasks(3, 20261130)
    assert all(2 <= len(t["config"]["ground_nodes"]) <= 4 for t in tasks)
    assert {t["seed"] for t in tasks}.isdisjoint(t["seed"] for t in mobile_tasks(3, 20261130))


def test_the_rows_and_the_share_are_pinned():
    """K > 1 holds every online row of one node but MPC over the tour at k = 1 (its cost), and the
    optimum must reach 99.5 % of each, as for one node: no looser allowance for K > 1."""
    assert ONLINE_SHARE == 0.995
    assert online_rows(2) == online_rows(4) == ("mpc_dp_k1", "mpc_dp_k10", "mpc_k10", "plan_once", "straight")
    assert set(MULTI_MOBILE_REFERENCES) == {"optimum", "bound", "clairvoyant", *online_rows(2)}


def test_the_optimum_is_the_best_of_its_clairvoyant_candidates(frozen, suite):
    (path,) = (frozen.parent / "cache").glob("online_*.json")
    optimum = json.loads(path.read_text())["optimum"]
    rates = optimum["candidates"]
    assert any(c.startswith("dp (") for c in rates) and any(c.startswith("sca from ") for c in rates)
    assert optimum["rate"] == rates[optimum["source"]] == max(rates.values())
    (s,) = suite.scenarios
    assert s.reference["optimum"]["source"] == optimum["source"]
    # SCA starts from the clairvoyant tour and solve_multinode's plan, and never lowers a start's score
    sca = next(r for c, r in rates.items() if c.startswith("sca from "))
    assert sca >= max(s.value("clairvoyant"), *(r for c, r in rates.items() if c.startswith("dp (")))


def test_a_tampered_record_stops_the_freeze_naming_it(frozen, tmp_path):
    def above_the_optimum(data):  # an online row 1 % above the optimum, still under the bound
        data["mpc_k10"]["rate"] = min(data["optimum"]["rate"] * 1.01, data["bound"]["upper_bound"])

    message = rerun_tampered_online(frozen, tmp_path, above_the_optimum, multi=True)
    assert "not frozen" in message and "#0: optimum" in message and "mpc_k10" in message

    def bound_below(data):
        data["bound"]["upper_bound"] = data["optimum"]["rate"] * 0.99

    assert "#0: bound" in rerun_tampered_online(frozen, tmp_path / "b", bound_below, multi=True)

    def straight_infeasible(data):
        data["straight"]["feasible"] = False

    message = rerun_tampered_online(frozen, tmp_path / "c", straight_infeasible, multi=True)
    assert "#0: straight failed or infeasible" in message


#: The shipped suite's registered hash, and mobile-v2's (freezing this one changed neither).
MULTI_MOBILE_V1_SHA256 = "08f72c968b77a6021e8e0a2217ffefdd6520ede4e1ad437bf847f9f329c3d8d3"
MOBILE_V2_SHA256 = "a20d796bb79315b07bb072d961092fae9accb88fcc24a911873b0a5ba9d06944"


def test_multi_node_mobile_v1_is_the_pipelines_draws_under_its_registered_hash():
    suite = load_suite("multi-node-mobile-v1")
    data = json.loads(suite_path("multi-node-mobile-v1").read_text(encoding="utf-8"))
    registered = SUITES["multi-node-mobile-v1"].sha256
    assert registered == MULTI_MOBILE_V1_SHA256 == suite.sha256 == content_hash(data)
    assert SUITES["mobile-v2"].sha256 == MOBILE_V2_SHA256 == load_suite("mobile-v2").sha256
    assert suite.kind == "multi-node-mobile" and suite.normalizer == "optimum"
    assert suite.references == MULTI_MOBILE_REFERENCES and len(suite) == MULTI_MOBILE_SIZE
    tasks = multi_mobile_tasks(MULTI_MOBILE_SIZE, ENTROPY)
    assert [s.seed for s in suite] == [t["seed"] for t in tasks]
    assert [s.config for s in suite] == [ScenarioConfig(**t["config"]) for t in tasks]


def test_every_frozen_scenario_passes_the_pipelines_checks():
    """The pipeline's own check on every stored scenario (bound >= optimum >= 99.5 % of every
    online row, every row feasible and under the bound), and each optimum names its planner."""
    data = json.loads(suite_path("multi-node-mobile-v1").read_text(encoding="utf-8"))
    for entry in data["scenarios"]:
        assert check_online_record(entry) == [], entry["index"]
        assert entry["optimum"]["source"].startswith(("dp (", "sca from ")), entry["index"]
        assert entry["optimum"]["rate"] >= entry["clairvoyant"]["rate"], entry["index"]


def test_the_straight_row_replays_in_the_env():
    suite = load_suite("multi-node-mobile-v1")
    result = evaluate(StraightEqualShares(), suite, n=3)
    # a replay against its record: compiled sums round by the CPU (~1e-16 here), so RATE_REL
    got, stored = [row.rate for row in result.scenarios], [s.value("straight") for s in suite.subset(3)]
    assert got == pytest.approx(stored, rel=RATE_REL, abs=0.0)
