"""benchmarks/miso_sweep.py --quick: a row per power for each objective, every scheme at most the
bound and AO at least MRT and ZF with aligned phases; --plot writes a new PNG and refuses an
existing path."""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location(
        "benchmarks_miso_sweep", ROOT / "benchmarks" / "miso_sweep.py"
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    yield module
    sys.modules.pop(spec.name, None)


def test_the_quick_run_prints_every_scheme_below_the_bound(bench, capsys):
    assert bench.main(["--quick"]) == 0
    out = capsys.readouterr().out
    number = r"\s+(-|-?[\d.]+)"
    rows = re.findall(r"^\s*(-?[\d.]+)" + number * len(bench.COLUMNS) + r"\s*$", out, re.M)
    assert [float(r[0]) for r in rows] == [0.0, 20.0, 40.0] * 2  # the sum rate, then the max-min rate
    assert re.search(r"^K = 2 users at .*; sum rate$", out, re.M)
    assert re.search(r"^K = 2 users at .*; maxmin rate$", out, re.M)
    for row in rows:
        table = dict(zip(bench.COLUMNS, row[1:], strict=True))
        bound = float(table["bound"])
        for name in bench.SCHEMES:
            assert table[name] == "-" or float(table[name]) <= bound, (name, table)
        for name in ("MRT aligned", "ZF aligned"):
            assert float(table["AO"]) >= float(table[name])  # (rounding to 4 decimals keeps the order)
        assert float(table["AO gap"]) == pytest.approx(bound - float(table["AO"]), abs=2e-4)
    assert re.search(r"^slope 20 -> 40 dBm .*; 2 stream\(s\): 0\.664$", out, re.M)


def test_plot_writes_a_new_png_and_refuses_an_existing_path(bench, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    path = tmp_path / "sweep.png"
    args = ["--quick", "--objectives", "sum", "--powers", "0", "30", "--plot", str(path)]
    assert bench.main(args) == 0
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    before = path.read_bytes()
    with pytest.raises(SystemExit):
        bench.main(args)
    assert "exists" in capsys.readouterr().err
    assert path.read_bytes() == before
