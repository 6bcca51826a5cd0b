"""examples/sb3_ppo.py: SB3's checker, PPO and an evaluation episode on the fixed and random ids."""

import re

from conftest import require


def test_sb3_ppo_fixed_and_random_ids(run_example):
    require("stable_baselines3", "torch")
    env_ids = ["ios_uav_env/IOSUAV-v0", "ios_uav_env/IOSUAV-Random-v0"]
    out = run_example("sb3_ppo.py", "--env", *env_ids, "--steps", "256")
    for env_id in env_ids:
        match = re.search(rf"{env_id}: average rate ([0-9.]+) bps/Hz, feasible True, (\d+) slots", out)
        assert match, out
        assert float(match.group(1)) > 0
