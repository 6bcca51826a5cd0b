"""examples/torchrl_env.py: TorchRL's GymEnv on every id, check_env_specs, a rollout with the info keys."""

import pytest
from conftest import require

import ios_uav_env


@pytest.mark.parametrize("env_id", ["ios_uav_env/IOSUAV-v0", ios_uav_env.RANDOM_ENV_ID])
def test_torchrl_gymenv(run_example, env_id):
    require("torchrl", "tensordict", "torch")
    steps = "200" if env_id == "ios_uav_env/IOSUAV-v0" else "20"
    out = run_example("torchrl_env.py", "--env", env_id, "--steps", steps)
    if env_id == "ios_uav_env/IOSUAV-v0":  # the whole episode: it ends at slot N = 150
        assert f"{env_id}: 149 steps" in out and "episode done True" in out, out
    else:
        assert f"{env_id}: 20 steps" in out, out
