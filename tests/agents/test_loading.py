"""agents.loading: one loader for runs, shipped models, checkpoints and bare zips; Agent.act
normalises observations with the run's VecNormalize statistics."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from stable_baselines3 import PPO, SAC  # noqa: E402

import ios_uav_env  # noqa: E402, F401
from agents.evaluate import MODELS_DIR  # noqa: E402
from agents.loading import ALGOS, Agent, checkpoint_file, checkpoints, load_agent, zip_algorithm  # noqa: E402

GENERALIST = MODELS_DIR / "ppo_IOSUAV-Random-v0"  # trained with norm_obs: True


def test_algos_map_names_to_classes_and_import_sb3_only_when_looked_up():
    assert list(ALGOS) == ["ppo", "sac"] and ALGOS["ppo"] is PPO and ALGOS["sac"] is SAC
    assert "ppo" in ALGOS and "dqn" not in ALGOS
    code = (
        "import sys; "
        "from agents.loading import ALGOS; 'ppo' in ALGOS; print('stable_baselines3' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == "False", out.stderr


def observations(agent: Agent, n: int = 20) -> list[np.ndarray]:
    env = gym.make(agent.env_id, **agent.env_kwargs)
    obs, _ = env.reset(seed=0)
    out = [obs]
    for _ in range(n - 1):
        obs, *_ = env.step(agent.act(obs))
        out.append(obs)
    return out


def test_act_normalises_observations_with_the_runs_statistics():
    agent = load_agent(GENERALIST)
    assert agent.meta["config"]["algo"] == "ppo" and agent.vecnormalize.norm_obs
    assert not agent.vecnormalize.training
    obs = observations(agent)
    normalised = [
        agent.model.predict(agent.vecnormalize.normalize_obs(o), deterministic=True)[0] for o in obs
    ]
    raw = [agent.model.predict(o, deterministic=True)[0] for o in obs]
    np.testing.assert_array_equal([agent.act(o) for o in obs], normalised)
    assert max(np.abs(a - b).max() for a, b in zip(normalised, raw, strict=True)) > 1e-3  # it matters


def test_act_calls_the_vecnormalize_it_holds():
    seen = []

    class Spy:
        def normalize_obs(self, obs: np.ndarray) -> np.ndarray:
            seen.append(obs)
            return obs * 0.0

    class Model:
        def predict(self, obs: np.ndarray, deterministic: bool = True) -> tuple[np.ndarray, None]:
            return obs[:2] + 1.0, None

    agent = Agent(Model(), Spy())
    obs = np.arange(11, dtype=np.float32)
    np.testing.assert_array_equal(agent(obs), [1.0, 1.0])
    assert len(seen) == 1 and seen[0] is obs


def test_algorithm_comes_from_the_config_and_a_bare_zip_needs_it(tmp_path):
    shipped = MODELS_DIR / "ppo_IOSUAV-v0"
    agent = load_agent(shipped)
    assert (
        isinstance(agent.model, PPO)
        and agent.name == "ppo_IOSUAV-v0"
        and agent.env_id == "ios_uav_env/IOSUAV-v0"
    )
    with pytest.raises(ValueError, match="holds a PPO model, not SAC"):
        load_agent(shipped, "sac")
    with pytest.raises(ValueError, match="unknown algorithm 'dqn'"):
        load_agent(shipped, "dqn")
    bare = tmp_path / "sac_named_but_ppo.zip"
    shutil.copy(shipped / "model.zip", bare)
    with pytest.raises(ValueError, match="pass the algorithm"):
        load_agent(bare)
    agent = load_agent(bare, "ppo", env_id="ios_uav_env/RISUAV-v0")
    assert isinstance(agent.model, PPO) and agent.vecnormalize is None
    assert agent.env_id == "ios_uav_env/RISUAV-v0" and agent.name == "sac_named_but_ppo"
    with pytest.raises(FileNotFoundError, match="no model at"):
        load_agent(tmp_path / "nothing")


def test_a_node_set_model_is_known_as_ppo(tmp_path):
    """The node-set policy is this package's class (its module is not SB3's): its zip still says
    PPO, so a node-set model named as another algorithm is refused."""
    shipped = MODELS_DIR / "dagger_IOSUAV-MultiNode-Random-v0"
    assert zip_algorithm(shipped / "model.zip") == "ppo"
    bare = tmp_path / "node_set.zip"
    shutil.copy(shipped / "model.zip", bare)
    with pytest.raises(ValueError, match="holds a PPO model, not SAC"):
        load_agent(bare, "sac", env_id="ios_uav_env/IOSUAV-MultiNode-Random-v0")


def test_a_checkpoint_loads_with_its_own_vecnormalize_statistics(tmp_path):
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize

    venv = VecNormalize(make_vec_env("ios_uav_env/IOSUAV-v0", n_envs=1, seed=0))
    model = PPO("MlpPolicy", venv, n_steps=64, batch_size=64, policy_kwargs={"net_arch": [8]}, device="cpu")
    (tmp_path / "checkpoints").mkdir()
    (tmp_path / "config.json").write_text(json.dumps({"algo": "ppo", "env_id": "ios_uav_env/IOSUAV-v0"}))
    means = {}
    for steps in (64, 128):
        model.learn(64, reset_num_timesteps=False)
        model.save(checkpoint_file(tmp_path, steps))
        venv.save(str(checkpoint_file(tmp_path, steps, "vecnormalize")))
        means[steps] = venv.obs_rms.mean.copy()
    assert [s for s, _ in checkpoints(tmp_path)] == [64, 128]
    for steps in (64, 128):
        agent = load_agent(tmp_path, checkpoint=steps)
        np.testing.assert_array_equal(agent.vecnormalize.obs_rms.mean, means[steps])
        assert agent.name == f"rl_model_{steps}_steps" and not agent.vecnormalize.training
    with pytest.raises(FileNotFoundError, match="rl_model_96_steps.zip"):
        load_agent(tmp_path, checkpoint=96)
