"""benchmarks/star_slot.py: the quick run prints a row per surface and access, every gap >= 0,
the per-scenario comparison and the summary line (the figures themselves are not asserted)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_quick_run_prints_every_row() -> None:
    out = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "star_slot.py"), "--quick"],
        capture_output=True, text=True, check=True, cwd=ROOT, timeout=600,
    ).stdout  # fmt: skip
    rows = [row for row in map(str.split, out.splitlines()) if len(row) == 7 and row[0].count(":") == 2]
    assert len(rows) == 2 * 11  # SURFACES x (noma, tdma)
    assert {row[1] for row in rows} == {"noma", "tdma"}
    assert all(float(row[3]) >= 0 and float(row[4]) >= 0 for row in rows)  # certified gaps
    assert all(float(row[3]) == 0 for row in rows if row[1] == "tdma")  # TDMA is closed form
    assert "NOMA above TDMA in" in out and "TS above ES (NOMA) in" in out
