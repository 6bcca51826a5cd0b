"""A trained agent (SB3 model + optional VecNormalize statistics) and its episodes.

>>> agent = load_agent("agents/models/ppo_IOSUAV-v0")                  # doctest: +SKIP
>>> result = rollout(agent, agent.env_id, agent.env_kwargs)           # doctest: +SKIP
>>> result.average_rate, result.feasible, result.terminal_miss        # doctest: +SKIP
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import ios_uav_env  # noqa: F401  (registers the ids)
from ios_uav_env import ScenarioConfig, average_rate, check_trajectory
from ios_uav_env.registration import ENV_IDS


@dataclass
class Agent:
    """A policy: ``model.predict`` on observations normalised as in training (if they were)."""

    model: Any  # an SB3 algorithm
    vecnormalize: Any = None  # VecNormalize with the training statistics, or None
    env_id: str = "ios_uav_env/IOSUAV-v0"
    env_kwargs: dict[str, Any] = field(default_factory=dict)  # the env arguments it was trained with
    name: str = "agent"
    meta: dict[str, Any] = field(default_factory=dict)  # config.json and summary.json of its run

    def act(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
        if self.vecnormalize is not None:
            obs = self.vecnormalize.normalize_obs(obs)
        action, _ = self.model.predict(obs, deterministic=deterministic)
        return action


def load_agent(path: str | Path, name: str | None = None) -> Agent:
    """Load the agent of a run or model folder (``model.zip``, ``config.json`` and, if any,
    ``vecnormalize.pkl`` and ``summary.json``), or of a bare ``.zip`` (default env settings)."""
    import torch
    from stable_baselines3 import PPO, SAC

    torch.set_num_threads(1)
    path = Path(path)
    folder, zip_path = (path.parent, path) if path.suffix == ".zip" else (path, path / "model.zip")
    if not zip_path.exists():
        raise FileNotFoundError(f"no model at {zip_path}")
    meta: dict[str, Any] = {}
    for key in ("config", "summary"):
        file = folder / f"{key}.json"
        if file.exists():
            meta[key] = json.loads(file.read_text())
    config = meta.get("config", {})
    algo = config.get("algo") or ("sac" if "sac" in zip_path.as_posix().lower() else "ppo")
    model = {"ppo": PPO, "sac": SAC}[algo].load(zip_path, device="cpu")
    vecnormalize = None
    if (folder / "vecnormalize.pkl").exists():
        from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

        env_id = config.get("env_id", "ios_uav_env/IOSUAV-v0")
        dummy = DummyVecEnv([lambda: gym.make(env_id, **config.get("env_kwargs", {}))])
        vecnormalize = VecNormalize.load(str(folder / "vecnormalize.pkl"), dummy)
        vecnormalize.training, vecnormalize.norm_reward = False, False
    return Agent(
        model,
        vecnormalize,
        config.get("env_id", "ios_uav_env/IOSUAV-v0"),
        dict(config.get("env_kwargs", {})),
        name or folder.name,
        meta,
    )


@dataclass
class Episode:
    """One deterministic episode of an agent, scored by the model (eq. (9)) and checked (eq. (10))."""

    trajectory: np.ndarray  # (N, 2) m
    average_rate: float  # bps/Hz, expected-gain rate of eq. (9)
    feasible: bool
    terminal_miss: float  # m, |q[N] - qF|
    max_step: float  # m
    episode_return: float
    mean_faded_rate: float | None = None  # channel "rician" only


def make_env(env_id: str, env_kwargs: dict[str, Any], config: ScenarioConfig | None = None) -> gym.Env:
    """``gym.make`` of ``env_id`` with ``env_kwargs``, on ``config`` when given (its horizon too;
    its surface picks the matching id of this package, since an id sets the surface)."""
    kwargs = dict(env_kwargs)
    if config is not None:
        kwargs.update(config=config, max_episode_steps=config.N - 1)
        if env_id in ENV_IDS:
            env_id = next(i for i, kw in ENV_IDS.items() if kw["surface"] == config.surface)
    return gym.make(env_id, **kwargs)


def rollout(
    agent: Agent,
    env_id: str | None = None,
    env_kwargs: dict[str, Any] | None = None,
    *,
    config: ScenarioConfig | None = None,
    seed: int = 0,
    deterministic: bool = True,
) -> Episode:
    """Run one episode of ``agent`` (default: on its own env id and kwargs; ``config`` replaces
    the scenario) and score its trajectory with ``average_rate`` / ``check_trajectory``."""
    env_id = env_id or agent.env_id
    env = make_env(env_id, agent.env_kwargs if env_kwargs is None else env_kwargs, config)
    obs, info = env.reset(seed=seed)
    total, done = 0.0, False
    while not done:
        obs, reward, terminated, truncated, info = env.step(agent.act(obs, deterministic))
        total += float(reward)
        done = terminated or truncated
    base = env.unwrapped
    trajectory = base.trajectory
    env.close()
    report = check_trajectory(base.config, trajectory)
    return Episode(
        trajectory,
        average_rate(base.config, trajectory),
        report.feasible,
        report.end_error,
        report.max_step,
        total,
        info.get("mean_faded_rate"),
    )
