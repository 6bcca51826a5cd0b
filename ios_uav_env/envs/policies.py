"""Simple policies on the observation alone: fly to a point at full speed and hover there.

They are the baselines that an RL policy must beat (and the demo's policy): with the arrival
guard (the env's default) hovering anywhere still ends at qF at slot N, so "where to hover"
is the whole plan. :class:`HoverAt` reads the point from the observation, so it runs on any
scenario of an id without knowing the config:

>>> import gymnasium as gym
>>> import ios_uav_env
>>> from ios_uav_env.envs.rollout import run_episode
>>> policy = HoverAt("peak")
>>> env = gym.make("ios_uav_env/IOSUAV-v0", T=60, **policy.env_kwargs)
>>> round(run_episode(env, policy).average_rate, 4)
1.2702

"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ios_uav_env.envs.observation import OBS_NAMES, PEAK_NAMES

#: Observation slices of the offsets (P - q) / L that :class:`HoverAt` can fly to. The
#: peak hint is always the last 3 components (``PEAK_NAMES``), whatever precedes it.
TARGETS: dict[str, tuple[int, int]] = {
    "ground": (OBS_NAMES.index("dx_ground"), OBS_NAMES.index("dy_ground") + 1),
    "peak": (-len(PEAK_NAMES), -len(PEAK_NAMES) + 2),
}


def full_speed_move(offset: np.ndarray, D: Any) -> np.ndarray:
    """The move in units of D (in the unit disk, float64) that goes ``offset`` (m) in one step if
    it is at most D long, else D along it: full speed towards the point, then stop on it.
    ``offset`` (2,) or a batch (B, 2); ``D`` a number or one per row, (B, 1)."""
    move = np.asarray(offset, dtype=np.float64) / D
    norm = np.hypot(move[..., 0], move[..., 1])[..., None]
    return move / np.maximum(norm, 1.0)


def move_toward(offset: np.ndarray, D: float) -> np.ndarray:
    """:func:`full_speed_move` as an action of the envs' float32 action space."""
    return full_speed_move(offset, D).astype(np.float32)


class HoverAt:
    """Fly at full speed towards a point given by the observation and hover there.

    ``target``: ``"peak"`` (the reachable rate peak of the scenario, the ``peak_hint``
    features; make the env with :attr:`env_kwargs`) or ``"ground"`` (the ground node G).
    ``D`` (m) and ``length_scale`` (m) must be the env's D = v_max dt and L.
    """

    #: It takes a batch of observations too ((B, obs_dim) -> (B, 2)).
    batched = True

    def __init__(self, target: str = "peak", D: float = 25.0, length_scale: float = 400.0) -> None:
        if target not in TARGETS:
            raise ValueError(f"target must be one of {sorted(TARGETS)}, got {target!r}")
        for name, value in (("D", D), ("length_scale", length_scale)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0 (m), got {value!r}")
        self.target, self.D, self.length_scale = target, float(D), float(length_scale)
        self._slice = slice(*TARGETS[target])

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """The env arguments this policy needs (the peak hint for ``"peak"``)."""
        return {"peak_hint": True} if self.target == "peak" else {}

    @property
    def name(self) -> str:
        what = "the reachable rate peak" if self.target == "peak" else "G"
        return f"fly to {what} and hover (heuristic)"

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        offset = np.asarray(obs, dtype=np.float64)[..., self._slice] * self.length_scale
        return move_toward(offset, self.D)

    def act(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
        """SB3-style alias of ``__call__`` (the policy is deterministic)."""
        return self(obs)

    def __repr__(self) -> str:
        return f"HoverAt({self.target!r}, D={self.D:g}, length_scale={self.length_scale:g})"
