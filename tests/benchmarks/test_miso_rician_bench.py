"""benchmarks/miso_rician.py: a row per scattering, kappa and N_t, the AO below the certified bound
and at least MRT with aligned phases, the LoS rows the same for both scatterings."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_run_prints_a_row_per_cell_below_the_bound() -> None:
    out = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "miso_rician.py"), "--slots", "1", "--elements", "2", "2"],
        capture_output=True, text=True, check=True, cwd=ROOT, timeout=600,
    ).stdout  # fmt: skip
    rows = re.findall(
        r"^\s+(link|element)\s+(\S+)\s+(\d)\s+([\d.]+)\s+([\d.]+)\s+([\d.]+)\s+([\d.]+)$", out, re.M
    )
    cells = [(s, k, int(n)) for s, k, n, *_ in rows]
    assert cells == [
        (s, k, n) for s in ("link", "element") for k in ("0", "3", "10", "LoS") for n in (1, 2, 4, 8)
    ]
    for *_, ao, mrt, bound, share in rows:
        assert float(mrt) * (1 - 1e-3) <= float(ao) <= float(bound) and 0 < float(share) <= 1, out
    los = [row[3:] for row in rows if row[1] == "LoS"]
    assert los[:4] == los[4:]  # the LoS channel has no scattering
