"""The measured rates of the batched multi-node env's moving rows: one compiled call over the rows.

After each step, a row whose knowledge is ``"reports"`` or ``"rates"`` measures the faded rate of
each node it served (``knowledge.observe_nodes``, the single env's path) on the node's kernel of
the slot: the row's own where the compiled weights put it there (``node_weights.put_node_weights``),
else its track's. :func:`measure_node_rates` does it for the rows one after the other.

The rows stay on one thread. The rate (``channel.faded_row``, fast-math) is inlined into each
kernel and optimised with it, so a threaded copy of this loop (or one behind a compiled-function
boundary) may round a rate differently from the serial kernel and the single env, and then the
batch no longer equals its single envs bit for bit. A rate in IEEE arithmetic rounds alike in
every copy, but its surface sum's divisions no longer vectorise: slower than the fast-math
serial loop even on two threads (``results/log.md`` has the figures).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ios_uav_env.jit import jit
from ios_uav_env.model.channel import faded_row
from ios_uav_env.model.reports import SERVED_SHARE

__all__ = ["measure_node_rates"]


@jit
def measure_node_rates(
    rows: np.ndarray, state: np.ndarray, shares: np.ndarray, counts: np.ndarray, widths: np.ndarray,
    slots: np.ndarray, measured: Any, track_nodes: Any, track_params: Any, row_nodes: np.ndarray,
    row_params: np.ndarray, normals: np.ndarray, reported: bool, rate_high: float, told: np.ndarray,
) -> None:  # fmt: skip
    """``nodes_kernels.measure_nodes`` for rows of both kinds: a row with ``slots[i]`` > 0 (its
    kernels computed in the row, ``node_weights.put_node_weights``) measures on the row's kernels,
    of its own width ``widths[i]`` (a C-ordered copy where the rows are wider: the numbers and the
    sum of the track's kernel); the others as ``measure_nodes`` does (``counts[i]`` nodes). Node
    k's rate, unclipped, goes to ``measured[i][k, slot]`` and, clipped to ``rate_high``, to
    ``told[i, k]`` (NaN: not served)."""
    for j in range(rows.size):
        i = rows[j]
        slot = int(state[i, 2])
        record = measured[i]
        k_nodes = counts[i]
        first = 2 * k_nodes if reported else 0
        fresh = slots[i] > 0
        own = fresh and widths[i] == row_nodes.shape[3]
        mine = row_nodes[i]
        if fresh and not own:
            mine = np.ascontiguousarray(row_nodes[i, :, :, : widths[i]])
        elif not fresh:
            own = track_nodes[i].shape[3] == row_nodes.shape[3]
        for k in range(k_nodes):
            told[i, k] = np.nan
            if shares[i, k] > SERVED_SHARE:
                n_re, n_im = normals[i, first + 2 * k], normals[i, first + 2 * k + 1]
                if fresh or own:
                    rate = faded_row(state[i, 0], state[i, 1], n_re, n_im, mine, row_params[i], k)
                else:
                    rate = faded_row(state[i, 0], state[i, 1], n_re, n_im, track_nodes[i][k],
                                     track_params[i][k], slot)  # fmt: skip
                record[k, slot] = rate
                told[i, k] = rate_high if rate_high < rate else rate
