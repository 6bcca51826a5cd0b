"""examples/sb3_fleet_central.py: SB3's PPO on the fleet's Gymnasium form, a tiny budget (the script
trains, evaluates and compares with the planner and its bound)."""

import re

from conftest import require


def test_sb3_ppo_on_the_central_fleet_runs(run_example):
    require("stable_baselines3", "torch", "scipy")
    out = run_example("sb3_fleet_central.py", "--steps", "2048", "--envs", "2")
    line = re.search(
        r"PPO \(central\), U = 2: min rate .* \(feasible True\), .* ([0-9.]+) % of the bound", out
    )
    assert line, out
    assert 0.0 <= float(line.group(1)) <= 100.0 + 1e-6  # no policy's flights beat the certified bound
