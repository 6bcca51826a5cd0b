"""The policy rows of the suites: a reference policy flown in the env on one scenario.

A suite's heuristic references are env rollouts by design: the reference policy (``HoverAt`` of
``ios_uav_env.envs.policies``, ``StraightEqualShares`` of ``benchmark.multi_policies``) sees the
env's observation, so its row is what that policy scores in the env. :func:`fly` flies a policy
for one episode on a pinned scenario and returns its :class:`Flight` (the scored
:class:`~ios_uav_env.envs.rollout.Episode`, the trajectory, the shares it chose, the wall time);
:func:`hover_episode` is ``HoverAt``'s: the single-node suite's ``hover_peak`` / ``hover_ground``
(in the suite's random id) and the mobile suite's tracking rows (in the scenario's own env, on
exact knowledge or on the reports). The reference pipeline (``baselines.references``) builds
those rows through them, not through the envs.

>>> from ios_uav_env import ScenarioConfig
>>> from ios_uav_env.benchmark.heuristics import hover_episode
>>> episode = hover_episode(ScenarioConfig(T=60.0), "peak", env_id="ios_uav_env/IOSUAV-Random-v0")
>>> episode.steps, episode.feasible
(59, True)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ios_uav_env.envs.multi import MultiNodeEnv
from ios_uav_env.envs.options import EnvOptions
from ios_uav_env.envs.policies import TARGETS, HoverAt
from ios_uav_env.envs.rollout import Episode, Policy, run_episode
from ios_uav_env.envs.single import IOSUAVEnv
from ios_uav_env.model.config import ScenarioConfig

__all__ = ["Flight", "fly", "hover_episode"]


@dataclass(frozen=True)
class Flight:
    """One episode of a policy on a scenario (:func:`fly`)."""

    episode: Episode  # scored by run_episode: the env's own score (K > 1: the policy's own min_k R_k)
    shares: np.ndarray | None = field(repr=False)  # (K, N) the shares the policy chose; None for one node

    @property
    def trajectory(self) -> np.ndarray:
        """The flown way-points (N, 2) m."""
        return self.episode.trajectory

    @property
    def seconds(self) -> float:
        """Wall time of the episode from the reset to the last step (policy and env)."""
        return self.episode.seconds


def fly(
    policy: Policy,
    config: ScenarioConfig,
    *,
    env_id: str | None = None,
    seed: int | None = 0,
    **env_kwargs: Any,
) -> Flight:
    """One episode of ``policy`` (any observation -> action callable; one that reads features by
    name is bound to the env's layout first) on the scenario ``config``, reset with ``seed`` and
    ``options={"config": config}``, scored by ``ios_uav_env.envs.rollout.run_episode``.

    The env: ``gym.make(env_id, ...)`` (a suite's id), or the scenario's own env when ``env_id``
    is None (``IOSUAVEnv(config, ...)`` for one node, ``MultiNodeEnv(config, ...)`` for several);
    either with the policy's own ``env_kwargs`` (e.g. ``peak_hint=True``) and ``env_kwargs``
    (e.g. ``knowledge="reports"``).
    """
    kwargs = {**dict(getattr(policy, "env_kwargs", None) or {}), **env_kwargs}
    if env_id is None:
        env = (IOSUAVEnv if config.K == 1 else MultiNodeEnv)(config, **kwargs)
    else:
        import gymnasium as gym

        import ios_uav_env  # noqa: F401  (registers the ids)

        env = gym.make(env_id, **kwargs)
    try:
        episode = run_episode(env, policy, seed=seed, options={"config": config})
        shares = env.unwrapped.shares if config.K > 1 else None
    finally:
        env.close()
    return Flight(episode, shares)


def hover_episode(
    config: ScenarioConfig, target: str, *, env_id: str | None = None, seed: int | None = 0, **env_kwargs: Any
) -> Episode:
    """One episode of ``HoverAt(target)`` (``"peak"`` or ``"ground"``) on the single-node scenario
    ``config``, reset with ``seed`` and ``options={"config": config}``, scored by
    ``ios_uav_env.envs.rollout.run_episode``.

    The env: ``gym.make(env_id, ...)`` (the suite's id), or the scenario's own env
    ``IOSUAVEnv(config, ...)`` when ``env_id`` is None; either with ``env_kwargs`` (e.g.
    ``knowledge="reports"``) and the arguments the policy needs (``peak_hint=True`` for
    ``"peak"``) (:func:`fly`). The policy flies with the scenario's D = v_max dt and the env's L.
    """
    if target not in TARGETS:
        raise ValueError(f"target must be one of {sorted(TARGETS)}, got {target!r}")
    scale = env_kwargs.get("length_scale", EnvOptions.length_scale)  # the env's L
    policy = HoverAt(target, D=config.D, length_scale=scale)
    return fly(policy, config, env_id=env_id, seed=seed, **env_kwargs).episode
