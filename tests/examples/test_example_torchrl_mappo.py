"""examples/torchrl_mappo_fleet.py: MAPPO on the fleet through TorchRL's PettingZoo wrapper, a tiny
budget (the script runs, trains, evaluates and compares with the planner and its bound)."""

import re

from conftest import require


def test_torchrl_mappo_on_the_fleet_runs(run_example):
    require("torchrl", "tensordict", "torch", "pettingzoo", "scipy")
    out = run_example("torchrl_mappo_fleet.py", "--frames", "600", "--batch", "300", "--ippo")
    assert out.count("mean episode return") == 0 or "frames" in out
    line = re.search(
        r"IPPO, U = 2: min rate ([0-9.]+) bps/Hz \(feasible True\), ([0-9.]+) % of the planner", out
    )
    assert line, out
    assert 0.0 <= float(line.group(2)) <= 100.0 + 1e-6  # the planner's plan is at least a trained policy's
