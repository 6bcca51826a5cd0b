"""A trivial policy for the multi-node env, the floor of the multi-node leaderboard.

:class:`StraightEqualShares` flies straight to qF at full speed, hovers there, and shares every
slot equally between the nodes (equal scores: the softmax gives 1/K each). It reads only the
observation of ``MultiNodeEnv`` (qF relative to the UAV, components 2 and 3) and its length
(12 + 6 K_max, so the action has 2 + K_max entries):

>>> import gymnasium as gym
>>> import ios_uav_env
>>> from ios_uav_env.benchmark.multi_policies import StraightEqualShares
>>> env = gym.make("ios_uav_env/IOSUAV-MultiNode-v0")
>>> obs, _ = env.reset(seed=0)
>>> StraightEqualShares()(obs).round(3).tolist()
[1.0, 0.0, 0.0, 0.0, 0.0]
"""

from __future__ import annotations

import math

import numpy as np

from ios_uav_env.envs.policies import move_toward

#: Components of the multi-node observation before the node blocks, and per node block.
BASE, PER_NODE = 12, 6


class StraightEqualShares:
    """Fly straight to qF at full speed, hover there, equal shares (``D`` and ``length_scale``:
    the env's D = v_max dt and L, m)."""

    name = "fly straight to qF, equal shares (trivial)"

    def __init__(self, D: float = 25.0, length_scale: float = 400.0) -> None:
        for label, value in (("D", D), ("length_scale", length_scale)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{label} must be a finite number > 0 (m), got {value!r}")
        self.D, self.length_scale = float(D), float(length_scale)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float64)
        k_max, extra = divmod(obs.shape[-1] - BASE, PER_NODE)
        if extra or k_max < 1:
            raise ValueError(f"obs must be a multi-node observation (12 + 6 K_max entries), got {obs.shape}")
        move = move_toward(obs[2:4] * self.length_scale, self.D)
        return np.concatenate([move, np.zeros(k_max, dtype=np.float32)])
