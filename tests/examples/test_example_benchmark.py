"""examples/benchmark_cleanrl.py: a CleanRL-style torch actor scored on the frozen suite."""

import re

from conftest import require


def test_benchmark_cleanrl(run_example, tmp_path):
    require("torch")
    out = run_example("benchmark_cleanrl.py", "--n", "5", "--out", str(tmp_path))
    assert re.search(r"CleanRL actor on single-node-v1 \(5 scenarios\): % of DP mean [0-9.]+", out), out
    assert "feasible 5/5" in out and out.count("reference:") == 2
    assert (tmp_path / "results.csv").exists() and (tmp_path / "trajectories.npz").exists()
