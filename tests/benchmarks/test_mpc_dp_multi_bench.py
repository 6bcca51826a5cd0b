"""benchmarks/mpc_dp_multi.py: one frozen scenario of ``multi-node-mobile-v1`` flown by MPC-DP with the
tour at every re-plan; ``--trace`` prints every re-plan and the drift of the plans flown; ``--plans``
writes the flight as a trajectories file of the suite and a second run reads it back instead of
flying again."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np

from ios_uav_env.benchmark.trajectories import read_plans

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "benchmarks" / "mpc_dp_multi.py"
#: The cheapest scenario of the suite (2 nodes, 104 s).
CHEAP = "12"


def run(*args: str) -> str:
    return subprocess.run([sys.executable, str(SCRIPT), "--k", "10", *args, CHEAP], capture_output=True,
                          text=True, check=True, cwd=ROOT, timeout=600).stdout  # fmt: skip


def test_trace_prints_every_replan_and_the_drift() -> None:
    out = run("--trace")
    made = int(re.search(r"^#12 K=2 run\s+[\d.]+ %.* plans (\d+) kept (\d+)$", out, re.M).group(1))
    line = r"^    slot\s+(\d+): incumbent (\S+) \|((?: (?:tour|dp) [\d.]+)+) -> (\S+)$"
    slots = re.findall(line, out, re.M)
    assert [int(s) for s, *_ in slots] == [10 * i for i in range(made)]
    assert slots[0][1] == "-" and slots[0][3] == "tour"
    first = dict(zip(*[iter(slots[0][2].split())] * 2, strict=True))
    # the values docs/benchmark.md gives to three decimals (0.392 and 0.065 bps/Hz), within their last digit
    assert abs(float(first["tour"]) - 0.392) < 1e-3 and abs(float(first["dp"]) - 0.065) < 1e-3, first
    assert all(" tour " in cands for _, _, cands, _ in slots)  # dp-tour: the tour at every re-plan
    replaced = sum(kept != "incumbent" for *_, kept in slots[:-1])  # the last plan has no next re-plan
    assert f"    replaced: {replaced} plans, predicted value lost by the next re-plan" in out
    assert f"    kept: {made - 1 - replaced} plans" in out


def test_plans_are_written_and_read_back(tmp_path) -> None:
    plans = tmp_path / "mpc.npz"
    first = run("--plans", str(plans))
    trajectories, seconds, shares = read_plans(plans)
    assert sorted(trajectories) == sorted(seconds) == sorted(shares) == [12] and seconds[12] > 0
    assert trajectories[12].shape == (shares[12].shape[1], 2) and shares[12].shape[0] == 2
    again = run("--plans", str(plans))  # read back: not flown again, the same score
    pct = r"^#12 K=2 run\s+([\d.]+) %"
    assert re.search(pct, again, re.M).group(1) == re.search(pct, first, re.M).group(1)
    assert "plans -1 kept -1" in again and "plans -1" not in first
    np.testing.assert_array_equal(read_plans(plans)[0][12], trajectories[12])
