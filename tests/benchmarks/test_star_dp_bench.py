"""benchmarks/star_dp.py: the quick run prints one row whose plan is below its certified bound and
not below the TDMA plan's scores (the script itself exits non-zero if a plan or a random flight is
above the bound)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_quick_run_prints_a_row_below_the_bound() -> None:
    out = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "star_dp.py"), "--quick", "--flights", "4"],
        capture_output=True, text=True, check=True, cwd=ROOT, timeout=600,
    ).stdout  # fmt: skip
    rows = [row for row in map(str.split, out.splitlines()) if row[:1] == ["star-control"]]
    assert len(rows) == 1
    _, m, plan, candidate, _, tdma, tdma_noma, bound, gap, _, random, _ = rows[0]
    assert int(m) == 16
    assert float(tdma) <= float(tdma_noma) <= float(candidate) <= float(plan) <= float(bound)
    assert float(random) <= float(bound) and float(gap) >= 0
