"""benchmarks/miso_slot.py --quick: a row for every (N_t, K, objective) and every power, each with
AO between MRT with aligned phases and the certified bound."""

from __future__ import annotations

import re

from tests.benchmarks.quick import run_main


def test_the_quick_run_prints_ao_between_the_aligned_baseline_and_the_bound(capsys):
    module = run_main("miso_slot", ["--quick"])
    out = capsys.readouterr().out
    number = r"\s+(-|[\d.]+)"
    rows = re.findall(r"^\s*(\d)\s+(\d)\s+(sum|maxmin)" + number * len(module.COLUMNS) + r"\s*$", out, re.M)
    assert {(r[0], r[1], r[2]) for r in rows} == {
        (n, k, o) for n in "248" for k in "24" for o in ("sum", "maxmin")
    }
    sweep = re.findall(r"^\s*([\d.]+)" + number * len(module.COLUMNS) + r"\s*$", out, re.M)
    assert [float(r[0]) for r in sweep] == [0.01, 0.1, 1.0]
    for values in [r[3:] for r in rows] + [r[1:] for r in sweep]:
        table = dict(zip(module.COLUMNS, values, strict=True))
        ao, bound, mrt = float(table["AO"]), float(table["bound"]), float(table["MRT aligned"])
        assert mrt <= ao <= bound  # (rounding to the printed decimals keeps the order)
