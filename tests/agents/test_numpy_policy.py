"""The numpy export of a policy acts exactly like the SB3 model it came from."""

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import gymnasium as gym  # noqa: E402
import torch  # noqa: E402
from stable_baselines3 import PPO, SAC  # noqa: E402
from stable_baselines3.common.env_util import make_vec_env  # noqa: E402
from stable_baselines3.common.vec_env import VecNormalize  # noqa: E402

import ios_uav_env  # noqa: E402, F401
from agents.numpy_policy import NumpyPolicy  # noqa: E402

ENV = "ios_uav_env/IOSUAV-Random-v0"


def observations(n: int = 200, **env_kwargs) -> np.ndarray:
    env = gym.make(ENV, **env_kwargs)
    env.action_space.seed(0)
    obs, _ = env.reset(seed=0)
    out = [obs]
    for _ in range(n - 1):
        obs, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            obs, _ = env.reset()
        out.append(obs)
    return np.array(out)


@pytest.mark.parametrize("algo", [PPO, SAC])
@pytest.mark.parametrize("normalize", [False, True])
def test_numpy_policy_matches_predict(algo, normalize):
    torch.manual_seed(0)
    venv = make_vec_env(ENV, n_envs=1, seed=0)
    if normalize:
        venv = VecNormalize(venv)
        venv.obs_rms.mean = np.linspace(-0.5, 0.5, venv.observation_space.shape[0])
        venv.obs_rms.var = np.linspace(0.1, 3.0, venv.observation_space.shape[0])
        venv.training = False
    kwargs = {"policy_kwargs": {"net_arch": [32, 32]}}
    model = algo("MlpPolicy", venv, seed=0, device="cpu", **kwargs)
    with torch.no_grad():  # make the actor's output non-trivial (SB3 initialises the mean layer small)
        for p in model.policy.parameters():
            p.add_(0.3 * torch.randn_like(p))
    fast = NumpyPolicy.from_sb3(model, venv if normalize else None)
    obs = observations()
    for o in obs:
        x = venv.normalize_obs(o) if normalize else o
        expected, _ = model.predict(x, deterministic=True)
        np.testing.assert_allclose(fast.act(o), expected, atol=1e-5)
    actions = np.array([fast.act(o) for o in obs])
    assert actions.std() > 0.05  # not a constant policy: the comparison means something
    with pytest.raises(ValueError, match="deterministic"):
        fast.act(obs[0], deterministic=False)


def test_learning_curve_scores_every_checkpoint(tmp_path):
    import json

    from agents.loading import checkpoints
    from agents.suite.curve import learning_curve, write_curve

    venv = make_vec_env(ENV, n_envs=1, seed=0)
    model = PPO("MlpPolicy", venv, seed=0, device="cpu", n_steps=64, batch_size=64)
    (tmp_path / "checkpoints").mkdir()
    for steps in (200, 100):
        model.save(tmp_path / "checkpoints" / f"rl_model_{steps}_steps.zip")
    (tmp_path / "config.json").write_text(json.dumps({"algo": "ppo", "env_id": ENV, "env_kwargs": {}}))
    assert [s for s, _ in checkpoints(tmp_path)] == [100, 200]
    rows = learning_curve(tmp_path, "single-node-v1", n=2)
    assert [r["steps"] for r in rows] == [100, 200]
    assert all(r["n"] == 2 and r["feasible"] == 2 and 0 < r["mean_pct_dp"] <= 110 for r in rows)
    csv, png = write_curve(rows, tmp_path / "out")
    assert csv.read_text().count("\n") == 3 and png.stat().st_size > 5000
    assert checkpoints(tmp_path / "out") == []
    with pytest.raises(FileNotFoundError, match="no checkpoints"):
        learning_curve(tmp_path / "out", n=1)


def test_load_numpy_agent_acts_as_the_loaded_agent_and_carries_its_env():
    from agents.loading import load_agent, load_numpy_agent

    path = "agents/models/ppo_IOSUAV-Random-v0"
    agent, fast = load_agent(path), load_numpy_agent(path)
    assert fast.env_kwargs == agent.env_kwargs and fast.env_kwargs and fast.name == agent.name
    assert fast.env_id == agent.env_id
    obs = observations(50, **agent.env_kwargs)
    np.testing.assert_allclose(np.array([fast.act(o) for o in obs]), agent.act(obs), atol=1e-5)
