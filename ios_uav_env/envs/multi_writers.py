"""The multi-node env's observation and ``info`` writers, compiled and inlined into the row step
of :mod:`ios_uav_env.envs.multi_step` (its module docstring: the rows' arrays and their columns).

:func:`observe_row` writes a row's observation (the layout of ``MultiNodeEnv``'s docstring: the
base block, one block per node slot, with the energy objective the core's energy features after
them); :func:`info_row` writes its ``info`` row (``multi_table.info_columns``, read by
``multi_table.info_arrays``), the running eq. (10) check being the core's
(``ios_uav_env.envs.core.kernel.violation``). Both index every column by name (``multi_table``).
"""

from __future__ import annotations

import math

import numpy as np

from ios_uav_env.envs.core.kernel import FLAG_ENERGY, observe_energy, violation
from ios_uav_env.envs.multi_table import (
    MEP_BITS_SCALE,
    MEP_CX,
    MEP_CY,
    MEP_D,
    MEP_ELEMENTS,
    MEP_HORIZON,
    MEP_INV_L,
    MEP_IS_IOS,
    MEP_IS_RIS,
    MEP_K,
    MEP_N,
    MEP_PEAK_HINT,
    MEP_QFX,
    MEP_QFY,
    MEP_SERVED_CLIP,
    MINFO_BEST_SCHEDULE_RATE,
    MINFO_DISTANCE_TO_FINAL,
    MINFO_FEASIBLE,
    MINFO_MIN_RATE,
    MINFO_POSITION_X,
    MINFO_POSITION_Y,
    MINFO_REWARD_RATE,
    MINFO_REWARD_REACH,
    MINFO_REWARD_TERMINAL,
    MINFO_SLOT,
    MINFO_TERMINAL_MISS,
    MINFO_WORST_VIOLATION,
    MOBS_DX_FINAL,
    MOBS_DX_IOS,
    MOBS_DY_FINAL,
    MOBS_DY_IOS,
    MOBS_ELEMENTS,
    MOBS_HORIZON,
    MOBS_IS_IOS,
    MOBS_IS_RIS,
    MOBS_SLACK,
    MOBS_TIME_LEFT,
    MOBS_X,
    MOBS_Y,
    MORE_ENERGY,
    MORE_ENERGY_EFFICIENCY,
    MORE_EXPECTED_MIN_RATE,
    MORE_POWER,
    MORE_REWARD_ENERGY,
    MST_ENERGY,
    MST_MIN_RATE,
    MST_MOVES_MADE,
    MST_X,
    MST_Y,
    N_MINFO,
    N_MOBS,
    N_MORE,
    N_NODE,
    N_NODE_PEAK,
    NODE_DX_NODE,
    NODE_DX_PEAK,
    NODE_DY_NODE,
    NODE_DY_PEAK,
    NODE_MASK,
    NODE_RATE,
    NODE_RATE_PEAK,
    NODE_SERVED,
    NODE_SIDE,
    PT_PEAK_RATE,
    PT_PEAK_X,
    PT_PEAK_Y,
    PT_SIDE,
    PT_X,
    PT_Y,
)
from ios_uav_env.jit import jit


@jit(inline=True, fastmath=False)
def observe_row(obs: np.ndarray, i: int, x: float, y: float, left: float, dist: float, episode: np.ndarray,
                points: np.ndarray, served: np.ndarray, rates: np.ndarray, state: np.ndarray,
                flags: np.ndarray) -> None:  # fmt: skip
    """Write observation row ``i`` (the layout of ``MultiNodeEnv``'s docstring; with the energy
    objective the last move / D, the energy weight and the minimum-power move after the blocks)."""
    ep, o = episode[i], obs[i]
    inv_l, n_slots, k_n = ep[MEP_INV_L], ep[MEP_N], int(ep[MEP_K])
    width = N_NODE_PEAK if ep[MEP_PEAK_HINT] != 0.0 else N_NODE
    s = left - dist / ep[MEP_D]
    o[MOBS_X], o[MOBS_Y] = x * inv_l, y * inv_l
    o[MOBS_DX_FINAL], o[MOBS_DY_FINAL] = (ep[MEP_QFX] - x) * inv_l, (ep[MEP_QFY] - y) * inv_l
    o[MOBS_DX_IOS], o[MOBS_DY_IOS] = (ep[MEP_CX] - x) * inv_l, (ep[MEP_CY] - y) * inv_l
    o[MOBS_TIME_LEFT], o[MOBS_SLACK] = left / (n_slots - 1.0), s / (1.0 + abs(s))
    o[MOBS_ELEMENTS], o[MOBS_IS_IOS] = ep[MEP_ELEMENTS], ep[MEP_IS_IOS]
    o[MOBS_IS_RIS], o[MOBS_HORIZON] = ep[MEP_IS_RIS], ep[MEP_HORIZON]
    for k in range(points.shape[1]):
        j = N_MOBS + width * k
        if k < k_n:
            o[j + NODE_MASK] = 1.0
            o[j + NODE_DX_NODE] = (points[i, k, PT_X] - x) * inv_l
            o[j + NODE_DY_NODE] = (points[i, k, PT_Y] - y) * inv_l
            o[j + NODE_SIDE], o[j + NODE_RATE] = points[i, k, PT_SIDE], rates[i, k]
            o[j + NODE_SERVED] = min(served[i, k] / n_slots, ep[MEP_SERVED_CLIP])
            if width == N_NODE_PEAK:
                o[j + NODE_DX_PEAK] = (points[i, k, PT_PEAK_X] - x) * inv_l
                o[j + NODE_DY_PEAK] = (points[i, k, PT_PEAK_Y] - y) * inv_l
                o[j + NODE_RATE_PEAK] = points[i, k, PT_PEAK_RATE]
        else:
            for c in range(width):
                o[j + c] = 0.0
    if flags[FLAG_ENERGY] != 0.0:
        observe_energy(obs, i, N_MOBS + width * points.shape[1], state, episode)


@jit(inline=True, fastmath=False)
def info_row(info: np.ndarray, i: int, state: np.ndarray, episode: np.ndarray, shares: np.ndarray,
             served: np.ndarray, dist: float, left: float, r_rate: float, r_reach: float,
             r_terminal: float, expected: np.ndarray, power: float, r_energy: float) -> None:  # fmt: skip
    """Write ``info`` row ``i`` (``best_schedule_rate`` 0: the caller's, at episode end; the running
    eq. (10) check: ``core.kernel.violation``). Then :data:`MORE`: the move's ``power`` (W), the
    ``energy`` so far (J), the bits per joule so far B dt min_k sum_n alpha_k[n] r_k(q[n]) / E (expected-gain
    rates; 0 before the first move), the energy term, min_k of ``expected`` / N, and each node's
    ``expected`` / N."""
    st, ep, row = state[i], episode[i], info[i]
    k_max = served.shape[1]
    k_n, n_slots = int(ep[MEP_K]), ep[MEP_N]
    deficit, worst, feasible = violation(i, dist, left, state, episode)
    row[MINFO_POSITION_X], row[MINFO_POSITION_Y] = st[MST_X], st[MST_Y]
    row[MINFO_SLOT], row[MINFO_DISTANCE_TO_FINAL] = st[MST_MOVES_MADE] + 1.0, dist
    row[MINFO_MIN_RATE], row[MINFO_BEST_SCHEDULE_RATE] = st[MST_MIN_RATE], 0.0
    row[MINFO_REWARD_RATE], row[MINFO_REWARD_REACH], row[MINFO_REWARD_TERMINAL] = r_rate, r_reach, r_terminal
    row[MINFO_FEASIBLE] = 1.0 if feasible else 0.0
    row[MINFO_WORST_VIOLATION], row[MINFO_TERMINAL_MISS] = worst, deficit
    # the blocks after INFO: shares, node_rates, MORE, expected_node_rates (multi_table.info_arrays)
    node_rates, more = N_MINFO + k_max, N_MINFO + 2 * k_max
    expected_rates = more + N_MORE
    # MORE and expected_node_rates only where the table has them (the energy objective, channel
    # "rician": multi_table.info_columns)
    extended = row.shape[0] > more
    low = math.inf
    for k in range(k_max):
        row[N_MINFO + k] = shares[i, k] if k < k_n else 0.0
        row[node_rates + k] = served[i, k] / n_slots if k < k_n else 0.0
        if extended:
            row[expected_rates + k] = expected[i, k] / n_slots if k < k_n else 0.0
        if k < k_n:
            low = min(low, expected[i, k])
    if extended:
        energy = st[MST_ENERGY]
        row[more + MORE_POWER], row[more + MORE_ENERGY] = power, energy
        row[more + MORE_REWARD_ENERGY], row[more + MORE_EXPECTED_MIN_RATE] = r_energy, low / n_slots
        row[more + MORE_ENERGY_EFFICIENCY] = ep[MEP_BITS_SCALE] * low / energy if energy > 0.0 else 0.0
