"""agents/hyperparams/*.yml: an rl-zoo3 entry for every registered id, in each file."""

from pathlib import Path

import gymnasium as gym
import pytest
import yaml

import ios_uav_env

HYPERPARAMS = Path(__file__).resolve().parents[2] / "agents" / "hyperparams"
REGISTERED = sorted(env_id for env_id in gym.registry if env_id.startswith("ios_uav_env/"))


def test_registered_ids_are_the_package_ids():
    assert set(REGISTERED) == {
        *ios_uav_env.ENV_IDS,
        *ios_uav_env.RANDOM_IDS,
        *ios_uav_env.MULTINODE_IDS,
        *ios_uav_env.ENERGY_IDS,
        *ios_uav_env.MOBILE_IDS,
        *ios_uav_env.MULTINODE_MOBILE_IDS,
        *ios_uav_env.STAR_CONTROL_IDS,
        *ios_uav_env.MISO_CONTROL_IDS,
        *ios_uav_env.STAR_NOMA_IDS,
        *ios_uav_env.MISO_IDS,
        *ios_uav_env.MISO_SDMA_IDS,
    }


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_every_registered_id_has_a_zoo_entry(algo):
    table = yaml.safe_load((HYPERPARAMS / f"{algo}.yml").read_text())
    missing = [env_id for env_id in REGISTERED if env_id not in table]
    assert not missing, f"{algo}.yml has no entry for {missing}"
    for env_id in REGISTERED:
        entry = table[env_id]
        assert entry["policy"] == "MlpPolicy" and float(entry["n_timesteps"]) > 0, env_id
