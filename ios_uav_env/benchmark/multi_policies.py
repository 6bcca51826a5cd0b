"""A trivial policy for the multi-node env, the floor of the multi-node leaderboard.

:class:`StraightEqualShares` flies straight to qF at full speed, hovers there, and shares every
slot equally between the nodes (equal scores: the softmax gives 1/K each). It reads only the
observation of ``MultiNodeEnv``: qF relative to the UAV (``dx_final``, ``dy_final``) and the
number of node slots K_max (the ``mask_<k>`` features; the action has 2 + K_max entries). Bound to
an env's layout (``bind(env.unwrapped.observation_names)``, as ``run_episode`` and ``evaluate``
do) it reads them by name, whatever else the layout holds (the peak hint, the energy features of
``objective="energy_efficiency"`` after the node blocks), and is refused on a single-node env;
unbound, it takes an observation of 12 + 6 K_max components (no peak hint, no energy features)
with qF's offset at components 2 and 3 (an energy layout, 12 + 6 K_max + 4 or 12 + 9 K_max + 4
long, is never that: refused):

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
import re
from collections.abc import Sequence

import numpy as np

from ios_uav_env.envs.policies import FeatureReader, move_toward

#: Components of the multi-node observation before the node blocks, and per node block.
BASE, PER_NODE = 12, 6


class StraightEqualShares(FeatureReader):
    """Fly straight to qF at full speed, hover there, equal shares (``D`` and ``length_scale``:
    the env's D = v_max dt and L, m)."""

    name = "fly straight to qF, equal shares (trivial)"
    #: The features it reads: qF's offset, and the first node slot's mask (a multi-node layout).
    observation_features = ("dx_final", "dy_final", "mask_0")

    def __init__(self, D: float = 25.0, length_scale: float = 400.0) -> None:
        for label, value in (("D", D), ("length_scale", length_scale)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{label} must be a finite number > 0 (m), got {value!r}")
        self.D, self.length_scale = float(D), float(length_scale)

    def bind(self, names: Sequence[str]) -> StraightEqualShares:
        """A copy that reads the multi-node layout ``names`` (``FeatureReader.bind``): K_max is its
        count of ``mask_<k>`` features."""
        bound: StraightEqualShares = super().bind(names)
        bound._k_max = sum(1 for name in names if re.fullmatch(r"mask_\d+", name))
        return bound

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float64)
        if self.layout is None:
            k_max, extra = divmod(obs.shape[-1] - BASE, PER_NODE)
            if extra or k_max < 1:
                raise ValueError(
                    f"obs must be a multi-node observation (12 + 6 K_max entries), got {obs.shape}: bind the "
                    "policy to its env's layout (policy.bind(env.unwrapped.observation_names)); an unbound "
                    "policy cannot tell the peak hint or the energy features (move_x, move_y, "
                    "energy_weight, min_power_move) from node blocks"
                )
            fx, fy = 2, 3
        else:
            fx, fy, _ = self._columns(obs)
            k_max = self._k_max
        move = move_toward(obs[[fx, fy]] * self.length_scale, self.D)
        return np.concatenate([move, np.zeros(k_max, dtype=np.float32)])

    def __repr__(self) -> str:
        return f"StraightEqualShares(D={self.D:g}, length_scale={self.length_scale:g})"
