"""The fleet of ``ios_uav_env.parallel_env`` as one Gymnasium env: a centralised controller of
every UAV, for single-agent learners (SB3's PPO in ``examples/sb3_fleet_central.py``)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ios_uav_env.envs.fleet import FleetParallelEnv
from ios_uav_env.model.config import ScenarioConfig

__all__ = ["FleetCentralEnv"]


class FleetCentralEnv(gym.Env):
    """The fleet as one Gymnasium env, for single-agent learners (a centralised controller).

    The observation is :meth:`FleetParallelEnv.state` (the agents' observations, concatenated in
    agent order), the action the agents' actions concatenated, the reward the team reward, and
    ``info`` maps each agent still flying to its info. With ``horizons``, a UAV past its horizon
    keeps its place in the observation (its last row, the team's rates and the others' positions
    updated) and in the action, whose part for it is ignored; the episode ends when the last UAV's
    horizon does. Arguments: those of :class:`FleetParallelEnv`.
    """

    metadata = {"render_modes": []}

    def __init__(self, config: ScenarioConfig | Mapping[str, Any] | None = None, **kwargs: Any) -> None:
        self.fleet = FleetParallelEnv(config, **kwargs)
        agents = self.fleet.possible_agents
        obs = [self.fleet.observation_space(a) for a in agents]
        acts = [self.fleet.action_space(a) for a in agents]
        self.observation_space = spaces.Box(
            np.concatenate([s.low for s in obs]), np.concatenate([s.high for s in obs]), dtype=np.float32
        )
        self.action_space = spaces.Box(
            np.concatenate([s.low for s in acts]), np.concatenate([s.high for s in acts]), dtype=np.float32
        )
        self._widths = np.cumsum([s.shape[0] for s in acts])[:-1]

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        _, infos = self.fleet.reset(seed=seed, options=options)
        return self.fleet.state().copy(), infos

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if not self.fleet.agents:
            raise RuntimeError("the episode is over (or was never started): call reset()")
        a = np.asarray(action, dtype=np.float64)
        if a.shape != self.action_space.shape:
            raise ValueError(f"action must have shape {self.action_space.shape}, got {a.shape}")
        parts = dict(zip(self.fleet.possible_agents, np.split(a, self._widths), strict=True))
        live = {agent: parts[agent] for agent in self.fleet.agents}  # a finished UAV's part is ignored
        _, rewards, _, truncs, infos = self.fleet.step(live)
        reward = float(next(iter(rewards.values())))
        return self.fleet.state().copy(), reward, not self.fleet.agents, any(truncs.values()), infos

    def close(self) -> None:
        self.fleet.close()
