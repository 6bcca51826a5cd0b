"""examples/fast_ippo_fleet.py: the fast trainer's PPO with shared parameters on the fleet's batched
form (agents as rows), a tiny budget: it writes its run folder and prints the learner report."""

import json
import re

from conftest import require


def test_fast_ippo_on_the_batched_fleet_runs(run_example, tmp_path):
    require("stable_baselines3", "torch", "scipy", "pettingzoo")
    folder = str(tmp_path / "run")
    out = run_example(
        "fast_ippo_fleet.py", "--steps", "2000", "--fleets", "18", "--out", folder, "--no-progress"
    )
    line = re.search(
        r"IPPO \(fast trainer, shared\), U = 2: min rate ([0-9.]+) .* \(feasible True\), .* "
        r"([0-9.]+) % of the bound",
        out,
    )
    assert line, out
    assert 0.0 <= float(line.group(2)) <= 100.0 + 1e-6  # no policy's flights beat the certified bound
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["steps"] == 18 * 2 * 59 and f"{summary['final_eval']['score']:.4f}" == line.group(1)
