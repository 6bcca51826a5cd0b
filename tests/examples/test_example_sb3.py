"""examples/sb3_ppo.py: SB3's checker, PPO and an evaluation episode on the fixed and random ids."""

import re

import pytest
from conftest import require


@pytest.mark.parametrize("env_id", ["ios_uav_env/IOSUAV-v0", "ios_uav_env/IOSUAV-Random-v0"])
def test_sb3_ppo(run_example, env_id):
    require("stable_baselines3", "torch")
    out = run_example("sb3_ppo.py", "--env", env_id, "--steps", "256")
    match = re.search(rf"{env_id}: average rate ([0-9.]+) bps/Hz, feasible True, (\d+) slots", out)
    assert match, out
    assert float(match.group(1)) > 0
