"""The measured rates of the batched multi-node env's moving rows, serial or on numba's threads.

After each step, a row whose knowledge is ``"reports"`` or ``"rates"`` measures the faded rate of
each node it served (``knowledge.observe_nodes``, the single env's path) on the node's kernel of
the slot: the row's own where the compiled weights put it there (``node_weights.put_node_weights``),
else its track's. :func:`measure_node_rates` does it for the rows one after the other,
:func:`measure_node_rates_batched` with the rows on numba's threads (each row writes only its own
records and told rates), and :func:`measure_rows` picks one of them.

The rate is ``channel.measured_rate``: ``faded_row`` in IEEE arithmetic, a compiled function of its
own. A fast-math rate inlined into each kernel is optimised with that kernel, and its copies in a
serial and a threaded kernel (or in a kernel loaded from numba's cache) differed in the last bit
of about one rate in 70; IEEE instructions round alike in every copy, so both kernels equal the
single env bit for bit (tested, fresh and from the cache).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ios_uav_env.jit import jit, prange, run_batched
from ios_uav_env.model.channel import measured_rate
from ios_uav_env.model.reports import SERVED_SHARE

__all__ = ["measure_node_rates", "measure_node_rates_batched", "measure_rows"]


@jit(inline=True)
def _measure_row(
    i: int, state: np.ndarray, shares: np.ndarray, counts: np.ndarray, widths: np.ndarray, slots: np.ndarray,
    measured: Any, track_nodes: Any, track_params: Any, row_nodes: np.ndarray, row_params: np.ndarray,
    normals: np.ndarray, reported: bool, rate_high: float, told: np.ndarray,
) -> None:  # fmt: skip
    """Row ``i``'s measured rates (:func:`measure_node_rates`)."""
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
                rate = measured_rate(state[i, 0], state[i, 1], n_re, n_im, mine, row_params[i], k)
            else:
                rate = measured_rate(state[i, 0], state[i, 1], n_re, n_im, track_nodes[i][k],
                                     track_params[i][k], slot)  # fmt: skip
            record[k, slot] = rate
            told[i, k] = rate_high if rate_high < rate else rate


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
        _measure_row(rows[j], state, shares, counts, widths, slots, measured, track_nodes, track_params,
                     row_nodes, row_params, normals, reported, rate_high, told)  # fmt: skip


@jit(parallel=True)
def measure_node_rates_batched(
    rows: np.ndarray, state: np.ndarray, shares: np.ndarray, counts: np.ndarray, widths: np.ndarray,
    slots: np.ndarray, measured: Any, track_nodes: Any, track_params: Any, row_nodes: np.ndarray,
    row_params: np.ndarray, normals: np.ndarray, reported: bool, rate_high: float, told: np.ndarray,
) -> None:  # fmt: skip
    """:func:`measure_node_rates` with the rows on numba's threads (``rows`` distinct: a row
    writes only its own records and ``told[i]``)."""
    for j in prange(rows.size):
        _measure_row(rows[j], state, shares, counts, widths, slots, measured, track_nodes, track_params,
                     row_nodes, row_params, normals, reported, rate_high, told)  # fmt: skip


def measure_rows(num_threads: int | None, *args: Any) -> None:
    """:func:`measure_node_rates` of ``args`` on one thread (``num_threads == 1``), else
    :func:`measure_node_rates_batched` on ``num_threads`` of numba's threads (None: numba's
    current setting; the serial kernel where they cannot run, ``jit.parallel_safe``)."""
    if num_threads == 1:
        measure_node_rates(*args)
    else:
        run_batched(measure_node_rates_batched, measure_node_rates, num_threads, *args)
