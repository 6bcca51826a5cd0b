"""benchmarks/miso_noma.py --quick: a row per grid point and objective, NOMA and SDMA below the
certified bound, NOMA's sum rate at least TDMA's."""

from __future__ import annotations

import re

from tests.benchmarks.quick import run_main


def test_the_quick_run_prints_its_rows_below_the_bound(capsys):
    run_main("miso_noma", ["--quick"])
    out = capsys.readouterr().out
    rows = re.findall(r"^\s+2\s+([23])\s+4\s+" + r"\s+".join([r"([\d.]+)"] * 7) + "$", out, re.M)
    assert len(rows) == 4, out  # two grid points, two objectives
    for number, (_, noma, sdma, tdma, bound, share, *_) in enumerate(rows):
        noma, sdma, tdma, bound = float(noma), float(sdma), float(tdma), float(bound)
        assert noma <= bound and sdma <= bound and 0 < float(share) <= 1, out
        if number < 2:  # the sum rate: each user alone is a start
            assert noma >= tdma * (1 - 1e-9), out
