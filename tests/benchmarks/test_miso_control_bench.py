"""benchmarks/miso_control.py --quick: a row per objective, the AO below the certified bound."""

from __future__ import annotations

import re

from tests.benchmarks.quick import run_main


def test_the_quick_run_prints_a_row_per_objective(capsys):
    run_main("miso_control", ["--quick", "--episodes", "1"])
    out = capsys.readouterr().out
    rows = re.findall(r"^\s+2\s+2\s+16\s+(sum|maxmin)\s+([\d.]+)\s+(-?[\d.]+)\s+([\d.]+)$", out, re.M)
    assert [r[0] for r in rows] == ["sum", "maxmin"], out
    for _, step_ms, _, share in rows:
        assert float(step_ms) > 0 and 0 < float(share) <= 1, out  # the bound is certified
