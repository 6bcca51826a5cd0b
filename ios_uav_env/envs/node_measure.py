"""The measured rates of the batched multi-node env: one compiled call over the rows.

After each step (and at reset), a row whose knowledge is ``"reports"`` or ``"rates"`` measures the
faded rate of each node it served (``knowledge.observe_nodes``, the single env's path). The step
has just computed every node's expected-gain rate r_k at the UAV's position on the node's kernel
of the slot (``NodeRows.rates``), so the sample is ``channel.faded_of_rate`` of it:
log2(1 + (2^r_k - 1) |h|^2), the slot's fading |h|^2 from the node's two normals and its kernel's
scalars (``NodeRows.params``). No sum over the surface is taken again. Measured rates exist for
one antenna, continuous phases and expected fading only (``components.world`` refuses the
others), where r_k = log2(1 + eta zeta_k^2) exactly.

The arithmetic is IEEE (``faded_of_rate`` is a function of its own, compiled without fast-math),
so a row rounds as the single env's Python call does from the same r. The batch's r come from its
parallel step kernel and the single env's from the serial one, whose fast-math node sums round
differently in the last bits: the measured rates and the served tally equal the single envs' to
that rounding (``BATCH_MEASURED_REL`` of ``tests/tolerances.py``; tested), the observations bit
for bit.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ios_uav_env.jit import jit
from ios_uav_env.model.channel import faded_of_rate
from ios_uav_env.model.reports import SERVED_SHARE

__all__ = ["measure_node_rates"]


@jit(fastmath=False)
def measure_node_rates(
    rows: np.ndarray, state: np.ndarray, shares: np.ndarray, counts: np.ndarray, measured: Any,
    rates: np.ndarray, params: np.ndarray, normals: np.ndarray, reported: bool, rate_high: float,
    told: np.ndarray,
) -> None:  # fmt: skip
    """Each served node's measured rate of the slot (``share > SERVED_SHARE``; node k's normals
    ``normals[i, f + 2k : f + 2k + 2]``, f = 2 K after the reports' normals when ``reported``, else
    0) from its expected-gain rate ``rates[i, k]`` and kernel scalars ``params[i, k]`` at the row's
    UAV (``state[i, 0:2]``): recorded unclipped in ``measured[i][k, slot]`` (slot ``state[i, 2]``)
    and told clipped to ``rate_high`` in ``told[i, k]`` (NaN: not served), for the row's
    ``counts[i]`` nodes."""
    for j in range(rows.size):
        i = rows[j]
        slot = int(state[i, 2])
        record = measured[i]
        k_nodes = counts[i]
        first = 2 * k_nodes if reported else 0
        for k in range(k_nodes):
            told[i, k] = np.nan
            if shares[i, k] > SERVED_SHARE:
                n_re, n_im = normals[i, first + 2 * k], normals[i, first + 2 * k + 1]
                rate = faded_of_rate(rates[i, k], state[i, 0], state[i, 1], n_re, n_im, params[i], k)
                record[k, slot] = rate
                told[i, k] = rate_high if rate_high < rate else rate
