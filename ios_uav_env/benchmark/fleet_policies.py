"""A heuristic policy for the several-UAV env, the floor of the several-UAV leaderboard, and on one
UAV the tracker of several walking nodes that the multi-node memory learner is cloned from.

:class:`NearestWorstNode` is one policy for every agent (as parameter-shared learners are): each
UAV takes the nodes nearer to it than to any other UAV, flies at full speed toward the one of
them that needs it most, the one of least ``served + travel x distance / L`` (``travel`` 0: the
least served so far), and gives it the slot (its score 1, the others -1), with a neutral bid (0)
for the surface; a UAV with no node of its own flies toward its final point. The arrival guard
brings every UAV to its final point in time and the separation guard keeps them apart. It reads
the observation by name (``bind(env.observation_names)``, as
:func:`~ios_uav_env.benchmark.fleet_scoring.evaluate_fleet` and ``benchmark.evaluate`` do for
every scenario): qF's offset, the node blocks (``mask_<k>``, ``dx_node_<k>``, ``dy_node_<k>`` and
``served_<k>``, or ``served_measured_<k>``, the UAV's own tally, where the nodes are known
through reports) and the other UAVs' offsets (``dx_uav_<v>``, ``dy_uav_<v>``), all in units of
the length scale. It takes one observation or a batch of them.

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

from ios_uav_env.envs.policies import FeatureReader, full_speed_move

__all__ = ["NearestWorstNode"]


class NearestWorstNode(FeatureReader):
    """Each UAV to the neediest of its nearest nodes (module docstring). ``D`` and ``length_scale``:
    the env's D = v_max dt and L (m); ``travel`` (bps/Hz per length L, >= 0): the service a move of
    L must be worth, so a UAV stays on a node while its service is within ``travel`` x its
    distance to another node of that node's. On one UAV (``MultiNodeEnv``'s layout: no other UAV,
    no bid) it flies to the neediest node: with walking nodes known through reports
    (``ios_uav_env/IOSUAV-MultiNode-Mobile-v0`` with ``filter_estimate=True``) ``travel=0.2``
    (chosen on training draws of the id) is the expert of
    ``agents/hyperparams/fast_ppo_memory_multi.yml``."""

    name = "each UAV to the least-served of its nearest nodes (heuristic)"
    #: The features it needs (it reads every node block, its served feature and every other UAV
    #: the layout has).
    observation_features = ("dx_final", "dy_final", "mask_0", "dx_node_0", "dy_node_0")
    #: It takes a batch of observations too ((B, obs_dim) -> (B, action size)).
    batched = True

    def __init__(self, D: float = 25.0, length_scale: float = 400.0, travel: float = 0.0) -> None:
        for label, value in (("D", D), ("length_scale", length_scale)):
            if isinstance(value, bool) or not (
                isinstance(value, (int, float)) and math.isfinite(value) and value > 0
            ):
                raise ValueError(f"{label} must be a finite number > 0 (m), got {value!r}")
        if isinstance(travel, bool) or not (
            isinstance(travel, (int, float)) and math.isfinite(travel) and travel >= 0
        ):
            raise ValueError(f"travel must be a finite number >= 0 (bps/Hz per length L), got {travel!r}")
        self.D, self.length_scale, self.travel = float(D), float(length_scale), float(travel)

    def bind(self, names: Sequence[str]) -> NearestWorstNode:
        """A copy that reads the layout ``names`` (``FeatureReader.bind``: ``ValueError`` naming a
        missing feature): its node blocks (the served feature ``served_<k>``, else
        ``served_measured_<k>``) and the other UAVs' offsets, by name."""
        bound: NearestWorstNode = super().bind(names)
        layout = tuple(names)
        nodes = sorted(int(m.group(1)) for n in layout if (m := re.fullmatch(r"mask_(\d+)", n)))
        others = sorted(int(m.group(1)) for n in layout if (m := re.fullmatch(r"dx_uav_(\d+)", n)))
        served = "served" if "served_0" in layout else "served_measured"
        needed = [f"{c}_{k}" for k in nodes for c in ("dx_node", "dy_node", served)]
        needed += [f"dy_uav_{v}" for v in others]
        missing = [n for n in needed if n not in layout]
        if missing:
            raise ValueError(f"{self!r}: the layout has node or UAV blocks without {missing}")
        at = layout.index
        bound._final = [at("dx_final"), at("dy_final")]
        bound._mask = [at(f"mask_{k}") for k in nodes]
        bound._node = [[at(f"dx_node_{k}"), at(f"dy_node_{k}")] for k in nodes]
        bound._served = [at(f"{served}_{k}") for k in nodes]
        bound._others = [[at(f"dx_uav_{v}"), at(f"dy_uav_{v}")] for v in others]
        bound._bid = 1 if others else 0  # the surface bid: the last action entry of a fleet of several
        return bound

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        if self.layout is None:
            raise ValueError(f"{self!r} is unbound: bind it to the env (policy.bind(env.observation_names))")
        o = np.atleast_2d(np.asarray(obs, dtype=np.float64))
        self._columns(o)  # the layout's width (ValueError otherwise)
        live = o[:, self._mask] > 0.5  # (B, K_max)
        nodes = o[:, np.array(self._node)]  # (B, K_max, 2): each node relative to this UAV
        distance = np.linalg.norm(nodes, axis=2)
        mine = live.copy()
        for v in range(len(self._others)):
            off = o[:, self._others[v]][:, None, :]
            mine &= distance <= np.linalg.norm(nodes - off, axis=2)
        need = np.where(mine, o[:, self._served] + self.travel * distance, np.inf)
        k = np.argmin(need, axis=1)
        rows = np.arange(len(o))
        has = mine.any(axis=1)
        target = np.where(has[:, None], nodes[rows, k], o[:, self._final])
        scores = -np.ones((len(o), len(self._mask)))
        scores[rows[has], k[has]] = 1.0
        move = full_speed_move(target * self.length_scale, self.D)
        action = np.concatenate([move, scores, np.zeros((len(o), self._bid))], axis=1).astype(np.float32)
        return action if np.ndim(obs) == 2 else action[0]

    def act(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
        """SB3-style alias of ``__call__`` (the policy is deterministic)."""
        return self(obs)

    def __repr__(self) -> str:
        travel = f", travel={self.travel:g}" if self.travel else ""
        return f"NearestWorstNode(D={self.D:g}, length_scale={self.length_scale:g}{travel})"
