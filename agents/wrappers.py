"""Gymnasium wrappers for training (named in the zoo's ``env_wrapper`` key of a hyperparameter file).

They change what the learner sees, never the episode: trajectories, ``info`` and the
evaluation (``agents.rollout``, on the plain env) are those of the env.
"""

from __future__ import annotations

import math
from typing import Any, SupportsFloat

import gymnasium as gym


class ShiftReward(gym.RewardWrapper):
    """Reward ``scale * (reward - offset)``.

    Every episode of the fixed ids has exactly N - 1 steps, so subtracting a constant leaves
    the optimal policy unchanged, but it changes what a bootstrapped critic has to fit: with
    the raw rate (~2.4 bps/Hz per slot) SAC's Q-values run from ~190 at the start to ~2 at
    the end of an episode (gamma 0.99, 149 steps), and the differences between hover points (a few
    hundredths of a bps/Hz per slot) drown in that time trend. With ``offset`` near the
    rate of the best hover point the trend nearly vanishes and the critic spends its
    capacity on where to fly. The monitor (``monitor/``) still logs the env's own rewards.
    """

    def __init__(self, env: gym.Env, offset: float = 0.0, scale: float = 1.0) -> None:
        super().__init__(env)
        for name, value in (("offset", offset), ("scale", scale)):
            if not (isinstance(value, (int, float)) and math.isfinite(value)):
                raise ValueError(f"ShiftReward {name} must be a finite number, got {value!r}")
        if scale <= 0:
            raise ValueError(f"ShiftReward scale must be > 0, got {scale!r}")
        self.offset, self.scale = float(offset), float(scale)

    def reward(self, reward: SupportsFloat) -> float:
        return self.scale * (float(reward) - self.offset)


def apply_wrappers(env: gym.Env, wrappers: list[tuple[Any, dict[str, Any]]]) -> gym.Env:
    """Wrap ``env`` in each ``(class, kwargs)`` of ``wrappers``, in order."""
    for cls, kwargs in wrappers:
        env = cls(env, **kwargs)
    return env
