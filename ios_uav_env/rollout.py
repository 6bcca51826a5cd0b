"""One episode of a policy in an env, scored by the one model: the episode loop of every report.

A policy is any callable from an observation to an action (an SB3 agent's ``act``, a
:class:`~ios_uav_env.policies.HoverAt`, a lambda). :func:`run_episode` resets the env, steps
it until the episode ends and scores the trajectory (``env.unwrapped.trajectory``) with
``average_rate`` (eq. (9); with several ground nodes, ``scheduled_rates`` of the agent's own
shares ``env.unwrapped.shares``, its min_k R_k) and ``check_trajectory`` (eq. (10)), as every
planner's plan is.

>>> import gymnasium as gym
>>> import ios_uav_env
>>> from ios_uav_env.policies import HoverAt
>>> env = gym.make("ios_uav_env/IOSUAV-v0", T=60, peak_hint=True)
>>> episode = run_episode(env, HoverAt("peak"), seed=0)
>>> episode.steps, episode.feasible
(59, True)

"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ios_uav_env.config import ScenarioConfig
from ios_uav_env.multinode import scheduled_rates
from ios_uav_env.trajectory import average_rate, check_trajectory

Policy = Callable[[np.ndarray], Any]


@dataclass(frozen=True)
class Episode:
    """One finished episode, scored by the model."""

    config: ScenarioConfig  # the episode's scenario (env.unwrapped.config)
    trajectory: np.ndarray = field(repr=False)  # (n, 2) m, the way-points q[1..n]
    average_rate: float  # bps/Hz, the score: eq. (9) (average_rate); K > 1 nodes: the agent's own min_k R_k
    feasible: bool  # eq. (10) within FEASIBILITY_TOL
    terminal_miss: float  # m, |q[n] - qF|
    max_step: float  # m, longest move
    worst_violation: float  # m, worst breach of eq. (10)
    episode_return: float  # sum of the rewards
    mean_faded_rate: float  # bps/Hz, mean of the per-slot rate terms (= average_rate for "expected", K > 1)
    steps: int  # env steps taken
    seconds: float  # wall time from the reset to the last step (policy and env)


def run_episode(
    env: Any,
    policy: Policy,
    *,
    seed: int | None = None,
    options: Mapping[str, Any] | None = None,
    max_steps: int = 100_000,
) -> Episode:
    """Roll ``policy`` out for one episode of ``env`` (reset with ``seed`` and ``options``).

    The episode ends when the env says so (terminated or truncated); ``max_steps`` guards
    against an env that never does (``RuntimeError``). The trajectory must be complete
    (N way-points) to be scored: a truncated episode raises ``ValueError`` from the scorer.
    """
    start = time.perf_counter()
    obs, info = env.reset(seed=seed, options=None if options is None else dict(options))
    total, steps, done = 0.0, 0, False
    while not done:
        if steps >= max_steps:
            raise RuntimeError(f"the episode did not end within max_steps={max_steps} steps")
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        total += float(reward)
        steps += 1
        done = bool(terminated or truncated)
    seconds = time.perf_counter() - start
    base = env.unwrapped
    trajectory = base.trajectory
    report = check_trajectory(base.config, trajectory)
    if base.config.K > 1:  # several nodes: the agent's own shares (scheduled_rates), the one scorer
        score = float(scheduled_rates(base.config, trajectory, base.shares).min())
    else:
        score = average_rate(base.config, trajectory)
    return Episode(
        config=base.config,
        trajectory=trajectory,
        average_rate=score,
        feasible=report.feasible,
        terminal_miss=report.end_error,
        max_step=report.max_step,
        worst_violation=report.worst_violation,
        episode_return=total,
        mean_faded_rate=float(info.get("mean_faded_rate", score)),
        steps=steps,
        seconds=seconds,
    )
