"""examples/rllib_ppo.py: RLlib's PPO (new API stack) on the registered env, one iteration on a local Ray."""

import math
import re

from conftest import require


def test_rllib_ppo_one_iteration(run_example):
    require("ray", "tree", "torch")  # the 'ray' extra (RLlib's dependencies)
    out = run_example("rllib_ppo.py", "--iters", "1", "--num-cpus", "2", timeout=600)
    match = re.search(r"iteration 1, (\d+) env steps, (\d+) episodes, episode return mean (\S+)", out)
    assert match, out
    steps, episodes, mean = int(match.group(1)), int(match.group(2)), float(match.group(3))
    assert steps >= 320 and episodes >= 1 and math.isfinite(mean), out
