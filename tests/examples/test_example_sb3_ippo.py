"""examples/sb3_ippo_fleet.py: SB3's PPO with shared parameters on the fleet's batched form (agents
as rows, through its VecEnv adapter), a tiny budget."""

import re

from conftest import require


def test_sb3_ippo_on_the_batched_fleet_runs(run_example):
    require("stable_baselines3", "torch", "scipy", "pettingzoo")
    out = run_example("sb3_ippo_fleet.py", "--steps", "2048", "--fleets", "8")
    line = re.search(
        r"IPPO \(SB3, shared\), U = 2: min rate .* \(feasible True\), .* ([0-9.]+) % of the bound", out
    )
    assert line, out
    assert 0.0 <= float(line.group(1)) <= 100.0 + 1e-6  # no policy's flights beat the certified bound
