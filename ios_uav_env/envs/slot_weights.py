"""Each moving row's rate kernel of every slot, held in buffers of the batched single-node env.

A moving node's rate kernel changes from slot to slot only in its surface weights (the row
``nodes[2]`` of ``channel.path_kernels``) and in G's scalars (``g_side``, ``gx``, ``gy`` of
``params``): the surface nodes' coordinates and the other scalars are the kernel geometry's,
the same in every slot. :class:`SlotWeights` computes a row's weights of every slot of its
episode when the episode begins, in one compiled call into the row's slice of a buffer the
batch allocates once (``surface.path_weights_into``: ``path_kernels``' own numbers, bit for
bit), and keeps G's scalars per slot; :func:`put_slot_kernels` copies a slot's into the row's
kernel before it is stepped. The row's track (``knowledge.NodeTrack``) then never builds its
(N, 3, n) kernels: no per-episode array of a row's kernels is allocated, written and read back
(the batch's buffers stay mapped and are written in place).

A row whose weights the compiled call does not take (``path_weights_into`` refuses: no numba,
a surface whose weights are not interpolated) or whose surface has fewer nodes than the rows'
kernels hold (padded) reads its track's kernels instead (``slots[i] == 0``): the observation's
measured rate takes the track's kernel, of the track's width, there (``knowledge_kernels``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ios_uav_env.jit import copy_into, jit
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.rate_kernels import PARAM_G_SIDE, PARAM_GX, PARAM_GY
from ios_uav_env.model.surface import path_weights_into

__all__ = ["SlotWeights", "put_slot_kernels"]


class SlotWeights:
    """Rows' surface weights (``weights`` (B, S, n)) and G's scalars (``grounds`` (B, S, 3):
    ``g_side``, ``gx``, ``gy``) of every slot of their episodes, each row's other kernel scalars
    (``base`` (B, P)) and its episode's slot count (``slots`` (B,); 0: the row reads its track).
    ``S``: the most slots of an episode, ``n``: the rows' kernel width."""

    def __init__(self, rows: int, slots: int, width: int, params: int) -> None:
        self.weights = np.zeros((rows, max(slots, 1), width))  # (pages mapped as rows write them)
        self.grounds = np.zeros((rows, max(slots, 1), 3))
        self.base = np.zeros((rows, params))
        self.slots = np.zeros(rows, dtype=np.int64)

    def load(self, i: int, config: ScenarioConfig, paths: np.ndarray, params: np.ndarray) -> bool:
        """Row ``i``'s kernels of every slot of the episode on ``config`` (one node) whose node walks
        ``paths`` ((N, 1, 2) m; ``params``: the kernel scalars of the episode's scenario, G's
        replaced per slot), as ``channel.path_kernels(config, paths[:, 0])`` has them. False (the
        row is left to read its track) where the compiled weights do not apply."""
        n, points = config.N, paths[:, 0]
        self.slots[i] = 0
        if n > self.weights.shape[1] or not path_weights_into(
            config.node_config(0), points, self.weights[i, :n]
        ):
            return False
        grounds = self.grounds[i, :n]
        grounds[:, 0] = np.sign(points[:, 0] - config.ios_center[0])
        grounds[:, 1:] = points
        self.base[i] = params
        self.slots[i] = n
        return True

    def first(self, i: int, nodes: np.ndarray, params: np.ndarray) -> None:
        """Row ``i``'s kernel of its episode's first slot into ``nodes[i, 2, :n]`` and ``params[i]``."""
        nodes[i, 2, : self.weights.shape[2]] = self.weights[i, 0]
        params[i] = self.base[i]
        params[i, PARAM_G_SIDE], params[i, PARAM_GX], params[i, PARAM_GY] = self.grounds[i, 0]

    def put(self, rows: np.ndarray, state: np.ndarray, ahead: int, track_nodes: Any, track_params: Any,
            nodes: np.ndarray, params: np.ndarray) -> None:  # fmt: skip
        """:func:`put_slot_kernels` of these buffers."""
        put_slot_kernels(rows, state, ahead, self.slots, self.weights, self.grounds, self.base, track_nodes,
                         track_params, nodes, params)  # fmt: skip


@jit(fastmath=False)
def put_slot_kernels(
    rows: np.ndarray, state: np.ndarray, ahead: int, slots: np.ndarray, weights: np.ndarray,
    grounds: np.ndarray, base: np.ndarray, track_nodes: Any, track_params: Any, nodes: np.ndarray,
    params: np.ndarray,
) -> None:  # fmt: skip
    """Copy each row's rate kernel of slot ``state[i, 2] + ahead`` (``ahead`` 1: the slot it flies
    to; 0: its current one) into ``nodes[i, 2, :n]`` and ``params[i]``: from the buffers
    (:class:`SlotWeights`) where ``slots[i]`` > 0, else out of its track (``track_nodes[i]`` (N, 3,
    k), ``track_params[i]`` (N, P)); a row past its episode's end is left as it is (the step
    refuses it). Only the surface weights and the scalars are copied: a kernel's node coordinates
    (rows 0 and 1) are its geometry's in every slot, in the row since its episode began."""
    for j in range(rows.size):
        i = rows[j]
        slot = int(state[i, 2]) + ahead
        if slots[i] > 0:
            if slot < slots[i]:
                copy_into(nodes[i, 2], weights[i, slot])  # (its first weights.shape[2] entries)
                copy_into(params[i], base[i])
                params[i, PARAM_G_SIDE] = grounds[i, slot, 0]
                params[i, PARAM_GX] = grounds[i, slot, 1]
                params[i, PARAM_GY] = grounds[i, slot, 2]
            continue
        kernel = track_nodes[i]
        if slot < kernel.shape[0]:
            copy_into(nodes[i, 2], kernel[slot, 2])
            copy_into(params[i], track_params[i][slot])
