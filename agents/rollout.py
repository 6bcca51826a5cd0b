"""Policies on given scenarios, each in the env it was trained in; the episode loop is
``ios_uav_env.rollout.run_episode`` and the result its ``Episode``.

A fixed id (``ios_uav_env.ENV_IDS``) sets the surface, so a scenario runs in the id of its
surface made on it (``gym.make(id, config=cfg, **env_kwargs)``); any other id (the randomised
``ios_uav_env/IOSUAV-Random-v0``) runs it in one env pinned per episode with
``reset(options={"config": cfg})``.

>>> from agents.loading import load_agent                                  # doctest: +SKIP
>>> agent = load_agent("agents/models/ppo_IOSUAV-v0")                      # doctest: +SKIP
>>> episode = rollout(agent, env_id=agent.env_id, env_kwargs=agent.env_kwargs)  # doctest: +SKIP
>>> episode.average_rate, episode.feasible, episode.terminal_miss          # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import gymnasium as gym
import numpy as np

from ios_uav_env import ENV_IDS, ScenarioConfig
from ios_uav_env.rollout import Episode, run_episode

Policy = Callable[[np.ndarray], Any]


def _check_policy_env(policy: Any, env: gym.Env) -> None:
    """An agent's (``agents.loading.Agent``, or its bound ``act``) observation size must be the env's."""
    agent = getattr(policy, "__self__", policy)
    if hasattr(agent, "check_env"):
        agent.check_env(env)


class ScenarioRunner:
    """Runs policies on scenarios in ``env_id`` with ``env_kwargs`` (the env of the id is made
    once and pinned per scenario, unless the id is a fixed one: then one env per scenario)."""

    def __init__(self, env_id: str, env_kwargs: Mapping[str, Any] | None = None) -> None:
        self.env_id, self.env_kwargs = env_id, dict(env_kwargs or {})
        self.fixed = env_id in ENV_IDS
        self._env: gym.Env | None = None

    def run(self, policy: Policy, config: ScenarioConfig | None = None, *, seed: int | None = 0) -> Episode:
        """One episode of ``policy`` (reset with ``seed``) on ``config`` (None: the env's own)."""
        if config is not None and self.fixed:
            env_id = next(i for i, kw in ENV_IDS.items() if kw["surface"] == config.surface)
            env = gym.make(env_id, **{**self.env_kwargs, "config": config})
            try:
                _check_policy_env(policy, env)
                return run_episode(env, policy, seed=seed)
            finally:
                env.close()
        if self._env is None:
            self._env = gym.make(self.env_id, **self.env_kwargs)
        _check_policy_env(policy, self._env)
        options = None if config is None else {"config": config}
        return run_episode(self._env, policy, seed=seed, options=options)

    def close(self) -> None:
        if self._env is not None:
            self._env.close()
            self._env = None

    def __enter__(self) -> ScenarioRunner:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def rollout(
    policy: Any,
    config: ScenarioConfig | None = None,
    *,
    env_id: str | None = None,
    env_kwargs: Mapping[str, Any] | None = None,
    seed: int | None = 0,
) -> Episode:
    """One deterministic episode of ``policy`` on ``config`` (None: the env's own scenario), in
    ``env_id`` with ``env_kwargs`` (default: the policy's ``env_id`` / ``env_kwargs``, as an
    ``agents.loading.Agent`` has them)."""
    env_id = env_id or getattr(policy, "env_id", "ios_uav_env/IOSUAV-v0")
    kwargs = getattr(policy, "env_kwargs", {}) if env_kwargs is None else env_kwargs
    with ScenarioRunner(env_id, kwargs) as runner:
        return runner.run(policy.act if hasattr(policy, "act") else policy, config, seed=seed)
