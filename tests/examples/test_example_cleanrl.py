"""examples/cleanrl_ppo.py: the CleanRL-style single-file PPO runs and logs whole episodes."""

import re

import pytest
from conftest import require


@pytest.mark.parametrize("env_id", ["ios_uav_env/IOSUAV-v0"])
def test_cleanrl_ppo(run_example, env_id):
    require("torch")
    out = run_example("cleanrl_ppo.py", "--env-id", env_id, "--total-timesteps", "600", "--num-steps", "150")
    returns = [float(r) for r in re.findall(r"episodic_return=(-?[0-9.]+)", out)]
    assert returns, out
    assert "iteration 2/2" in out
