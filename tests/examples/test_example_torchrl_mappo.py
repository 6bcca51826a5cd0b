"""examples/torchrl_mappo_fleet.py: MAPPO on the fleet through TorchRL's PettingZoo wrapper, a tiny
budget (the script runs, trains, evaluates and compares with the planner and its bound)."""

import re

from conftest import require


def test_torchrl_mappo_on_the_fleet_runs(run_example):
    require("torchrl", "tensordict", "torch", "pettingzoo", "scipy")
    out = run_example("torchrl_mappo_fleet.py", "--frames", "600", "--batch", "300")  # MAPPO: central critic
    line = re.search(r"MAPPO, U = 2: min rate .* \(feasible True\), .* ([0-9.]+) % of the bound", out)
    assert line, out
    assert 0.0 <= float(line.group(1)) <= 100.0 + 1e-6  # no policy's flights beat the certified bound
