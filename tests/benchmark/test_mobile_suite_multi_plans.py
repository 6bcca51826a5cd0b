"""The rows of ``multi-node-mobile-v1`` that its frozen file does not hold: MPC-DP with the tour at
every re-plan (``MPC(planner="dp-tour")``), stored as trajectories files of the suite
(``results/benchmark/multi-node-mobile-v1/``, written by ``python benchmarks/mpc_dp_multi.py --planner
dp-tour --k K --plans FILE``) and scored by ``python -m ios_uav_env.benchmark evaluate --trajectories``
(their leaderboard rows, rerun by ``tests/benchmark/test_mobile_suite_v2.py``). Every stored flight
is feasible, under the bound, and the stored optimum is at least 99.5 % of it on every scenario: the
suite's freeze check, on the rows added after the freeze. The k = 10 flight of the cheapest
scenario replays from its planner."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from baselines.mpc import MPC, run_online
from baselines.references.online import MPC_RESOLUTION, check_online_record, score
from ios_uav_env.benchmark import load_suite
from ios_uav_env.benchmark.suite import suite_path
from ios_uav_env.benchmark.trajectories import read_plans
from tests.tolerances import PLANNER_REL

ROOT = Path(__file__).resolve().parents[2]
PLANS = ROOT / "results" / "benchmark" / "multi-node-mobile-v1"
#: The stored rows: file name -> the planner that flew them.
STORED = {
    "mpc_dp_tour_k10.npz": MPC(k=10, planner="dp-tour", resolution=MPC_RESOLUTION),
    "mpc_dp_tour_k1.npz": MPC(k=1, planner="dp-tour", resolution=MPC_RESOLUTION),
}
#: The cheapest scenario (2 nodes, 104 s), replayed.
REPLAYED = 12


@pytest.fixture(scope="module")
def suite():
    return load_suite("multi-node-mobile-v1")


def rates(suite, name: str) -> list[tuple[float, bool]]:
    """The stored flights' max-min rates with their own shares on the true paths, and feasibility."""
    trajectories, seconds, shares = read_plans(PLANS / name)
    assert sorted(trajectories) == sorted(shares) == sorted(seconds) == list(range(len(suite))), name
    out = []
    for s in suite:
        scored = score(s.config, trajectories[s.index], shares[s.index], s.paths())
        out.append((float(scored.rate), bool(scored.feasible)))
    return out


def record_with(entry: dict[str, Any], row: str, rate: float, feasible: bool) -> dict[str, Any]:
    """A stored scenario's record with one more online row."""
    return {**entry, row: {"rate": rate, "feasible": feasible}}


@pytest.mark.parametrize("name", sorted(STORED))
def test_the_optimum_holds_the_freeze_check_on_every_stored_row(suite, name):
    """The pipeline's freeze check (``check_online_record``: the row feasible and under the bound,
    bound >= optimum >= 99.5 % of the row) on every scenario, the stored row among the online rows."""
    data = json.loads(suite_path("multi-node-mobile-v1").read_text(encoding="utf-8"))
    row = Path(name).stem
    for entry, (rate, feasible) in zip(data["scenarios"], rates(suite, name), strict=True):
        record = record_with(entry, row, rate, feasible)
        assert check_online_record(record, extra=(row,)) == [], entry["index"]


def test_the_check_refuses_an_added_row_above_the_optimum_or_infeasible(suite):
    data = json.loads(suite_path("multi-node-mobile-v1").read_text(encoding="utf-8"))
    entry = data["scenarios"][REPLAYED]
    opt, ub = entry["optimum"]["rate"], entry["bound"]["upper_bound"]
    above = record_with(entry, "added", min(1.01 * opt, ub), True)
    (note,) = check_online_record(above, extra=("added",))
    assert f"#{REPLAYED}: optimum" in note and "added" in note
    assert check_online_record(above) == []  # not an online row unless named
    (note,) = check_online_record(record_with(entry, "added", 0.5 * opt, False), extra=("added",))
    assert "added failed or infeasible" in note


def test_a_stored_row_replays_from_its_planner(suite):
    """The dp-tour flight of the cheapest scenario, flown again by its planner at the episode seed,
    scores the stored flight's rate (a float64 planner re-run: PLANNER_REL)."""
    s = suite.scenarios[REPLAYED]
    name = "mpc_dp_tour_k10.npz"  # (k = 1 costs a tour and a DP per slot: its flight is not replayed)
    planner = STORED[name]
    trajectories, _, shares = read_plans(PLANS / name)
    stored = score(s.config, trajectories[REPLAYED], shares[REPLAYED], s.paths())
    result = run_online(s.config, planner, s.seed)
    np.testing.assert_array_equal(result.paths, s.paths())
    assert result.rate == pytest.approx(float(stored.rate), rel=PLANNER_REL)
    np.testing.assert_allclose(result.trajectory, trajectories[REPLAYED], rtol=0, atol=1e-6)
