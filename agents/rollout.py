"""Policies on given scenarios, each in the env it was trained in; the episode loop is
``ios_uav_env.envs.rollout.run_episode`` and the result its ``Episode``.

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

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from ios_uav_env import ENV_IDS, ScenarioConfig
from ios_uav_env.envs.rollout import Episode, run_episode, run_episodes

Policy = Callable[[np.ndarray], Any]


def _check_policy_env(policy: Any, env: gym.Env) -> None:
    """An agent's (``agents.loading.Agent``, or its bound ``act``) observation size must be the env's."""
    agent = getattr(policy, "__self__", policy)
    if hasattr(agent, "check_env"):
        agent.check_env(env)


def surface_id(config: ScenarioConfig) -> str:
    """The fixed id of ``config``'s surface (``ios_uav_env.ENV_IDS``)."""
    return next(i for i, kw in ENV_IDS.items() if kw["surface"] == config.surface)


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
            env = gym.make(surface_id(config), **{**self.env_kwargs, "config": config})
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


def run_scenarios(
    policy: Policy,
    configs: Sequence[ScenarioConfig],
    env_id: str,
    env_kwargs: Mapping[str, Any] | None = None,
    *,
    seed: int | None = 0,
) -> list[Episode]:
    """One deterministic episode of ``policy`` per scenario of ``configs``, each reset with
    ``seed``. On a randomised id: all of them at once, row i of the id's batched env pinned to
    ``configs[i]`` (``ios_uav_env.envs.rollout.run_episodes``; the same episodes as one env pinned per
    scenario, to 1e-9, in about the time of one); on a fixed id: one env per scenario
    (:class:`ScenarioRunner`), since its observation space is the scenario's own."""
    configs = list(configs)
    if env_id in ENV_IDS or not configs:
        with ScenarioRunner(env_id, env_kwargs) as runner:
            return [runner.run(policy, c, seed=seed) for c in configs]
    return _batched(policy, env_id, env_kwargs, len(configs), [seed] * len(configs), {"configs": configs})


def run_seeds(
    policy: Policy,
    config: ScenarioConfig | None,
    env_id: str,
    env_kwargs: Mapping[str, Any] | None = None,
    seeds: int = 20,
) -> list[Episode]:
    """``seeds`` episodes of ``policy`` on ``config`` (None: the env's own), reset with seeds
    0 .. seeds - 1 (e.g. Rician fading draws): the episodes of :class:`ScenarioRunner`'s
    ``run(policy, config, seed=s)``, all at once in the batched env (row s: seed s)."""
    if seeds < 1:
        raise ValueError(f"seeds must be >= 1, got {seeds}")
    kwargs, options = dict(env_kwargs or {}), None
    if config is not None and env_id in ENV_IDS:
        env_id, kwargs = surface_id(config), {**kwargs, "config": config}
    elif config is not None:
        options = {"configs": [config] * seeds}
    return _batched(policy, env_id, kwargs, seeds, 0, options)


def _batched(
    policy: Policy,
    env_id: str,
    env_kwargs: Mapping[str, Any] | None,
    num_envs: int,
    seed: int | list[int | None] | None,
    options: Mapping[str, Any] | None,
) -> list[Episode]:
    """``run_episodes`` of ``policy`` in ``env_id``'s batched env of ``num_envs`` rows (closed after)."""
    vec = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point",
                       **dict(env_kwargs or {}))  # fmt: skip
    try:
        _check_policy_env(policy, vec.unwrapped.envs[0])
        return run_episodes(vec, policy, seed=seed, options=options)
    finally:
        vec.close()


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
