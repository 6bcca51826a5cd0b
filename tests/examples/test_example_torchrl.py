"""examples/torchrl_env.py: TorchRL's GymEnv on every id, check_env_specs, a rollout with the info keys."""

from conftest import require

import ios_uav_env


def test_torchrl_gymenv_every_id(run_example):
    require("torchrl", "tensordict", "torch")
    ids = [*ios_uav_env.ENV_IDS, ios_uav_env.RANDOM_ENV_ID]
    out = run_example("torchrl_env.py", "--env", *ids, "--steps", "200")
    for env_id in ios_uav_env.ENV_IDS:  # the fixed scenario's whole episode: N - 1 = 149 < 200 steps
        assert f"{env_id}: 149 steps, mean rate" in out, out
    assert f"{ios_uav_env.RANDOM_ENV_ID}: " in out and out.count("episode done True") == len(ids), out
