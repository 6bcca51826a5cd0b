"""A heuristic policy for the several-UAV env, the floor of the several-UAV leaderboard.

:class:`NearestWorstNode` is one policy for every agent (as parameter-shared learners are): each
UAV takes the nodes nearer to it than to any other UAV, flies at full speed toward the one of
them the team has served least so far and gives it the slot (its score 1, the others -1), with a
neutral bid (0) for the surface; a UAV with no node of its own flies toward its final point. The
arrival guard brings every UAV to its final point in time and the separation guard keeps them
apart. It reads the parallel env's observation by name (``bind(env.observation_names)``, as
:func:`~ios_uav_env.benchmark.fleet_scoring.evaluate_fleet` does for every scenario): qF's offset,
the node blocks (``mask_<k>``, ``dx_node_<k>``, ``dy_node_<k>``, ``served_<k>``) and the other
UAVs' offsets (``dx_uav_<v>``, ``dy_uav_<v>``), all in units of the length scale.

>>> import ios_uav_env
>>> from ios_uav_env.benchmark.fleet_policies import NearestWorstNode
>>> env = ios_uav_env.parallel_env(uavs=2)
>>> obs, _ = env.reset(seed=0)
>>> policy = NearestWorstNode().bind(env.observation_names)
>>> policy(obs["uav_0"]).astype(float).round(3).tolist()
[0.982, 0.191, -1.0, -1.0, 1.0, 0.0]
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence

import numpy as np

from ios_uav_env.envs.policies import FeatureReader, move_toward

__all__ = ["NearestWorstNode"]


class NearestWorstNode(FeatureReader):
    """Each UAV to the least-served of its nearest nodes (module docstring). ``D`` and
    ``length_scale``: the env's D = v_max dt and L (m). On one UAV (``MultiNodeEnv``'s layout: no
    other UAV, no bid) it flies to the least-served node."""

    name = "each UAV to the least-served of its nearest nodes (heuristic)"
    #: The features it needs (it reads every node block and every other UAV the layout has).
    observation_features = ("dx_final", "dy_final", "mask_0", "dx_node_0", "dy_node_0", "served_0")

    def __init__(self, D: float = 25.0, length_scale: float = 400.0) -> None:
        for label, value in (("D", D), ("length_scale", length_scale)):
            if isinstance(value, bool) or not (
                isinstance(value, (int, float)) and math.isfinite(value) and value > 0
            ):
                raise ValueError(f"{label} must be a finite number > 0 (m), got {value!r}")
        self.D, self.length_scale = float(D), float(length_scale)

    def bind(self, names: Sequence[str]) -> NearestWorstNode:
        """A copy that reads the layout ``names`` (``FeatureReader.bind``: ``ValueError`` naming a
        missing feature): its node blocks and the other UAVs' offsets, by name."""
        bound: NearestWorstNode = super().bind(names)
        layout = tuple(names)
        nodes = sorted(int(m.group(1)) for n in layout if (m := re.fullmatch(r"mask_(\d+)", n)))
        others = sorted(int(m.group(1)) for n in layout if (m := re.fullmatch(r"dx_uav_(\d+)", n)))
        needed = [f"{c}_{k}" for k in nodes for c in ("dx_node", "dy_node", "served")]
        needed += [f"dy_uav_{v}" for v in others]
        missing = [n for n in needed if n not in layout]
        if missing:
            raise ValueError(f"{self!r}: the layout has node or UAV blocks without {missing}")
        at = layout.index
        bound._final = [at("dx_final"), at("dy_final")]
        bound._mask = [at(f"mask_{k}") for k in nodes]
        bound._node = [[at(f"dx_node_{k}"), at(f"dy_node_{k}")] for k in nodes]
        bound._served = [at(f"served_{k}") for k in nodes]
        bound._others = [[at(f"dx_uav_{v}"), at(f"dy_uav_{v}")] for v in others]
        bound._bid = 1 if others else 0  # the surface bid: the last action entry of a fleet of several
        return bound

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        if self.layout is None:
            raise ValueError(f"{self!r} is unbound: bind it to the env (policy.bind(env.observation_names))")
        o = np.asarray(obs, dtype=np.float64)
        self._columns(o)  # the layout's width (ValueError otherwise)
        live = o[self._mask] > 0.5
        nodes = o[np.array(self._node)]  # (K_max, 2): each node relative to this UAV
        mine = live.copy()
        for off in o[np.array(self._others)] if self._others else np.empty((0, 2)):
            mine &= np.linalg.norm(nodes, axis=1) <= np.linalg.norm(nodes - off, axis=1)
        scores = -np.ones(len(self._mask))
        if mine.any():
            served = np.where(mine, o[self._served], np.inf)
            k = int(np.argmin(served))
            move, scores[k] = move_toward(nodes[k] * self.length_scale, self.D), 1.0
        else:
            move = move_toward(o[self._final] * self.length_scale, self.D)
        return np.concatenate([move, scores, np.zeros(self._bid)]).astype(np.float32)

    def __repr__(self) -> str:
        return f"NearestWorstNode(D={self.D:g}, length_scale={self.length_scale:g})"
