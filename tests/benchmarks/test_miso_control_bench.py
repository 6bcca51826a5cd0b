"""benchmarks/miso_control.py --quick: a row per objective, the AO below the certified bound."""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_quick_run_prints_a_row_per_objective(capsys):
    spec = importlib.util.spec_from_file_location(
        "benchmarks_miso_control", ROOT / "benchmarks" / "miso_control.py"
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    try:
        spec.loader.exec_module(module)
        assert module.main(["--quick", "--episodes", "1"]) == 0
    finally:
        sys.modules.pop(spec.name, None)
    out = capsys.readouterr().out
    rows = re.findall(r"^\s+2\s+2\s+16\s+(sum|maxmin)\s+([\d.]+)\s+(-?[\d.]+)\s+([\d.]+)$", out, re.M)
    assert [r[0] for r in rows] == ["sum", "maxmin"], out
    for _, step_ms, _, share in rows:
        assert float(step_ms) > 0 and 0 < float(share) <= 1, out  # the bound is certified
