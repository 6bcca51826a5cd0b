"""The heuristic rows of the suites: ``HoverAt`` flown in the env on one scenario.

A suite's heuristic references are env rollouts by design: the reference policy
(``ios_uav_env.envs.policies.HoverAt``) sees the env's observation, so its row is what that
policy scores in the env. :func:`hover_episode` flies it for one episode on a pinned scenario
and returns the scored :class:`~ios_uav_env.envs.rollout.Episode` (its trajectory, rate,
feasibility, energy and wall time): the single-node suite's ``hover_peak`` / ``hover_ground``
(in the suite's random id) and the mobile suite's tracking rows (in the scenario's own env, on
exact knowledge or on the reports). The reference pipeline (``baselines.references``) builds
those rows through it, not through the envs.

>>> from ios_uav_env import ScenarioConfig
>>> from ios_uav_env.benchmark.heuristics import hover_episode
>>> episode = hover_episode(ScenarioConfig(T=60.0), "peak", env_id="ios_uav_env/IOSUAV-Random-v0")
>>> episode.steps, episode.feasible
(59, True)
"""

from __future__ import annotations

from typing import Any

from ios_uav_env.envs.policies import TARGETS, HoverAt
from ios_uav_env.envs.rollout import Episode, run_episode
from ios_uav_env.envs.single import IOSUAVEnv
from ios_uav_env.model.config import ScenarioConfig

__all__ = ["hover_episode"]


def hover_episode(
    config: ScenarioConfig, target: str, *, env_id: str | None = None, seed: int | None = 0, **env_kwargs: Any
) -> Episode:
    """One episode of ``HoverAt(target)`` (``"peak"`` or ``"ground"``) on the single-node scenario
    ``config``, reset with ``seed`` and ``options={"config": config}``, scored by
    ``ios_uav_env.envs.rollout.run_episode``.

    The env: ``gym.make(env_id, ...)`` (the suite's id), or the scenario's own env
    ``IOSUAVEnv(config, ...)`` when ``env_id`` is None; either with ``env_kwargs`` (e.g.
    ``knowledge="reports"``) and the arguments the policy needs (``peak_hint=True`` for
    ``"peak"``). The policy flies with the scenario's D = v_max dt and the env's L.
    """
    if target not in TARGETS:
        raise ValueError(f"target must be one of {sorted(TARGETS)}, got {target!r}")
    kwargs = {**HoverAt(target).env_kwargs, **env_kwargs}
    if env_id is None:
        env = IOSUAVEnv(config, **kwargs)
    else:
        import gymnasium as gym

        import ios_uav_env  # noqa: F401  (registers the ids)

        env = gym.make(env_id, **kwargs)
    try:
        policy = HoverAt(target, D=config.D, length_scale=env.unwrapped.length_scale)
        return run_episode(env, policy, seed=seed, options={"config": config})
    finally:
        env.close()
