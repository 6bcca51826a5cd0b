"""Compiled moving-node calls of the batched multi-node env: every row's slot in one call.

``MultiNodeVectorEnv`` with moving or roughly known nodes makes, per step, what each row's
template env makes on itself in ``multi_mobile.MobileNodes``: before the step, copy each row's
node kernels of the slot it flies to out of its track (:func:`gather_node_kernels`, the
``_put`` of ``prepare_slot``); after it, tell each row's UAV what it learns of its nodes
(``node_measure.measure_node_rates``, then :func:`tell_nodes`: ``knowledge.observe_nodes`` and the node
features of ``MobileNodes.observe_slot``). The draws stay each row's own: per row the batched
env draws the slot's normals in ONE ``standard_normal(d)`` call of the row's generator
(:func:`draws`: the K reports' 2 K, then two per node for the measured rates; numpy's Generator
gives one call of d the stream of the per-row path's calls), and the kernels do the per-row
arithmetic as the per-row path does: the reports, their clip, the served tally and the features
in IEEE arithmetic (as numpy computes them), the faded rates as ``channel.faded_of_rate`` of the
step's expected-gain rates (IEEE too). So the rows' observations and reports equal the single
env's bit for bit, their measured rates and tally to the rounding of the step's rates
(``node_measure``; tested, with and without numba). The Kalman filter of ``filter_estimate`` stays
Python per row (``knowledge.filter_report`` on the raw reports left in ``raw``).

Row i's track (``knowledge.NodesTrack``) is held as its arrays in lists
(``knowledge_kernels.row_list``): ``paths[i]`` (N, K, 2) and ``reports[i]`` (N, K, 2) m,
``measured[i]`` (K, N), ``tally[i]`` (K,), ``nodes[i]`` (K, N, 3, Q), ``params[i]`` (K, N, P);
the report clip in ``lo`` / ``hi`` (B, K_max, 2). The kernels write the records (``reports``,
``measured``, ``tally``) in place. The row's slot is ``state[i, 2]`` (0-based: 0 at reset, n
after the n-th step), its UAV at ``state[i, 0:2]``, its shares of the slot in ``shares[i]``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ios_uav_env.envs.knowledge_kernels import MODES
from ios_uav_env.envs.multi_table import BASE_FEATURES
from ios_uav_env.jit import copy_into, jit, prange

__all__ = [
    "MODES",
    "N_BASE",
    "draws",
    "gather_node_kernels",
    "tell_nodes",
    "tell_nodes_batched",
]

#: The scenario-level features before the node blocks (``multi_table.BASE_FEATURES``).
N_BASE = len(BASE_FEATURES)


def draws(knowledge: str, k_nodes: int) -> int:
    """Normals a row of ``k_nodes`` nodes draws per slot with this ``knowledge``: the reports'
    2 K (``"reports"``), then two per node for the measured rates (``"reports"``, ``"rates"``)."""
    return {"exact": 0, "reports": 4, "rates": 2}[knowledge] * k_nodes


@jit(fastmath=False)
def gather_node_kernels(
    rows: np.ndarray, state: np.ndarray, track_nodes: Any, track_params: Any, nodes: np.ndarray,
    params: np.ndarray,
) -> None:  # fmt: skip
    """Copy each row's node kernels of the slot it flies to (``state[i, 2] + 1``) out of its track
    into ``nodes[i, :K]`` and ``params[i, :K]``; a row at its episode's end is left as it is. Only
    the surface weights (``nodes[i, k, 2]``) and the scalars are copied: the rest of a node's
    kernel, its surface nodes' coordinates (rows 0 and 1, ``channel.path_kernels``: its kernel
    geometry's in every slot) and the padding beyond the track's width ((0, 1, 0), of zero weight),
    is the same in every slot of the episode, in the row since its first (``MobileNodes._put``)."""
    for j in range(rows.size):
        i = rows[j]
        slot = int(state[i, 2]) + 1
        kernel, scalars = track_nodes[i], track_params[i]
        if slot >= kernel.shape[1]:
            continue
        for k in range(kernel.shape[0]):
            copy_into(nodes[i, k, 2], kernel[k, slot, 2])  # (its first kernel.shape[3] entries)
            copy_into(params[i, k], scalars[k, slot])


@jit(fastmath=False)
def tell_nodes(
    rows: np.ndarray, state: np.ndarray, shares: np.ndarray, paths: Any, reports: Any, tally: Any,
    lo: np.ndarray, hi: np.ndarray, normals: np.ndarray, mode: int, sigma: float, scale: float,
    positions: bool, width: int, told: np.ndarray, obs: np.ndarray, raw: np.ndarray, sizes: np.ndarray,
) -> None:  # fmt: skip
    """The node features of each row's observation ``obs[i]``, in IEEE arithmetic: each node
    block's position (12 + ``width`` k + 1, + 2: the truth, the clipped report of the normals
    ``normals[i, 2k : 2k + 2]`` (recorded in ``reports[i]``, the raw one in ``raw[i, k]``) or 0
    for ``"rates"``; not written when ``positions`` is False: the filter's, written after) and,
    unless knowledge is exact (``mode``: ``MODES``), the served tally (+ share x told rate, over
    N) and the rate feature (the told rate ``told[i, k]`` of ``node_measure.measure_node_rates``,
    0: not served).
    ``sizes[i]``: the row's (K, N) (its track's arrays may be the batch's, longer)."""
    for j in range(rows.size):
        _tell_row(rows[j], state, shares, paths, reports, tally, lo, hi, normals, mode, sigma, scale,
                  positions, width, told, obs, raw, sizes)  # fmt: skip


@jit(fastmath=False, parallel=True)
def tell_nodes_batched(
    rows: np.ndarray, state: np.ndarray, shares: np.ndarray, paths: Any, reports: Any, tally: Any,
    lo: np.ndarray, hi: np.ndarray, normals: np.ndarray, mode: int, sigma: float, scale: float,
    positions: bool, width: int, told: np.ndarray, obs: np.ndarray, raw: np.ndarray, sizes: np.ndarray,
) -> None:  # fmt: skip
    """:func:`tell_nodes` with the rows on numba's threads (each row writes its own entries)."""
    for j in prange(rows.size):
        _tell_row(rows[j], state, shares, paths, reports, tally, lo, hi, normals, mode, sigma, scale,
                  positions, width, told, obs, raw, sizes)  # fmt: skip


@jit(fastmath=False)
def _tell_row(
    i: int, state: np.ndarray, shares: np.ndarray, paths: Any, reports: Any, tally: Any, lo: np.ndarray,
    hi: np.ndarray, normals: np.ndarray, mode: int, sigma: float, scale: float, positions: bool, width: int,
    told: np.ndarray, obs: np.ndarray, raw: np.ndarray, sizes: np.ndarray,
) -> None:  # fmt: skip
    """Row ``i`` of :func:`tell_nodes`."""
    slot = int(state[i, 2])
    path, record, served = paths[i], reports[i], tally[i]
    k_nodes, n_slots = sizes[i, 0], sizes[i, 1]
    for k in range(k_nodes):
        at = N_BASE + width * k
        px, py = path[slot, k, 0], path[slot, k, 1]
        if mode == 1:
            rx = px + sigma * normals[i, 2 * k]
            ry = py + sigma * normals[i, 2 * k + 1]
            raw[i, k, 0], raw[i, k, 1] = rx, ry
            px = min(max(rx, lo[i, k, 0]), hi[i, k, 0])
            py = min(max(ry, lo[i, k, 1]), hi[i, k, 1])
            record[slot, k, 0], record[slot, k, 1] = px, py
        if mode == 2:
            obs[i, at + 1], obs[i, at + 2] = 0.0, 0.0
        elif positions:
            obs[i, at + 1] = (px - state[i, 0]) / scale
            obs[i, at + 2] = (py - state[i, 1]) / scale
        if mode != 0:
            rate = told[i, k]
            if not math.isnan(rate):
                served[k] += shares[i, k] * rate
            obs[i, at + 4] = served[k] / n_slots
            obs[i, at + 5] = 0.0 if math.isnan(rate) else rate
