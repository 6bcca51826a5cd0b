"""examples/online_task_figure.py: the online task's picture is drawn by one command from the stored
rows of both online suites and their leaderboard rows, prints every point, and never overwrites a
figure."""

from __future__ import annotations

import re
import subprocess
import sys

from tests.examples.conftest import EXAMPLES, ROOT, require

POINT = re.compile(
    r"^(?P<suite>\S+)\s+(?P<label>.+?)\s+mean\s+(?P<mean>[\d.]+) \| p10\s+(?P<p10>[\d.]+) \| "
    r"min\s+(?P<min>[\d.]+) % of optimum; (?P<seconds>[\d.e+-]+) s per episode$",
    re.M,
)


def test_the_figure_is_drawn_from_the_stored_and_the_leaderboard_rows(run_example, tmp_path):
    require("matplotlib")
    figure = tmp_path / "online_task.png"
    out = run_example("online_task_figure.py", "--out", str(figure))
    assert figure.stat().st_size > 1000 and f"figure: {figure}" in out
    rows = [m.groupdict() for m in POINT.finditer(out)]
    by_suite = {
        name: [r for r in rows if r["suite"] == name] for name in ("mobile-v2", "multi-node-mobile-v1")
    }
    # every plan row of docs/leaderboard.md's sections: not the bound nor the optimum (not online plans)
    assert len(by_suite["mobile-v2"]) == 11 and len(by_suite["multi-node-mobile-v1"]) >= 7, out
    labels = {r["label"] for r in by_suite["multi-node-mobile-v1"]}
    assert {"MPC-DP, k=10 (dp)", "MPC-DP, k=10 (dp-tour)", "StraightEqualShares"} <= labels, labels
    for r in rows:  # a point is a spread: min <= p10 <= mean < 100 % of the optimum, a time per episode
        assert float(r["min"]) <= float(r["p10"]) <= float(r["mean"]) < 100.0, r
        assert float(r["seconds"]) > 0, r
    # the stored frozen row, printed as `show` prints it
    mpc_dp = next(r for r in by_suite["multi-node-mobile-v1"] if r["label"] == "MPC-DP, k=10 (dp)")
    assert (mpc_dp["mean"], mpc_dp["p10"], mpc_dp["min"]) == ("47.97", "27.82", "24.19")


def test_an_existing_figure_is_never_overwritten(tmp_path):
    figure = tmp_path / "shipped.png"
    figure.write_bytes(b"not a figure")
    proc = subprocess.run(
        [sys.executable, str(EXAMPLES / "online_task_figure.py"), "--out", str(figure)],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 2 and "exists" in proc.stderr, proc.stderr
    assert figure.read_bytes() == b"not a figure"
    assert (ROOT / "docs" / "online_task.png").stat().st_size > 1000  # the shipped figure
