"""The node-block view's part of the one compiled row step (``ios_uav_env.envs.row_step``):
what a multi-node row books of its K nodes and writes, the helpers the row step calls where
its row is a node block.

Row i of a few arrays is episode i (``ios_uav_env.envs.multi_kernels.NodeRows`` holds them;
their columns: ``ios_uav_env.envs.multi_table``): ``state`` (``STATE``), ``episode``
(``EPISODE``: the scenario's constants), ``points`` (B, K_max, 6: each node's x, y, its side of
the IOS and, with ``peak_hint``, its reachable rate peak x, y and rate), ``served`` (B, K_max:
S_k) and, per node, the arrays of its rate kernel (``ios_uav_env.model.channel.RateKernel`` of
``config.node_config(k)``: ``nodes`` (B, K_max, 3, Q), ``params`` (B, K_max, P), which the row
step reads with the node axis folded into the rows, node k of row i at row i K_max + k). The
compiled entry points ``reset_node_rows``, ``step_node_rows``, ``step_node_rows_batched`` and
``fly_node_rows`` (``ios_uav_env.envs.view_steps``, re-exported by ``multi_kernels`` as
``reset_rows`` ...) call the one row step, which writes the observations, rewards and the
``info`` table (``multi_table.info_columns``, read by ``info_arrays``) of the rows they touch:
node k's rate is ``channel.rate_row`` of its folded row (the single-node view's rate: a
single-node row is the K = 1 case), the shares are the softmax of ``share_sharpness`` x the
scores of the scenario's K nodes (:func:`softmax_shares`), and the reward terms are those of
``MultiNodeEnv``'s docstring. The move, the reach, terminal and energy terms, the reset of the
core state, the running eq. (10) check and the energy features are the row-step core's
(``ios_uav_env.envs.core.kernel``); the shares, the served sums (:func:`add_node_rate`), the
min-rate potential (:func:`rate_term`, :func:`soft_minimum`) and the observation and ``info``
writers (:func:`observe_nodes`, :func:`info_nodes`) are this view's. The kernels index every
column by name (``multi_table``'s module docstring), never by number.

Two options of ``flags`` (``core.kernel.flags_of``) change the step: ``energy`` (the
objective ``"energy_efficiency"``) adds the reward's energy term -(lambda_ref / B) P(V_n) and the
energy features after the node blocks; ``rician`` serves each node its faded rate of the slot
(``channel.faded_row`` with the two standard normal draws of ``normals[i, k]``), while
``expected`` (B, K_max) keeps the expected-gain sums sum_n alpha_k[n] r_k(q[n]) that the score
and the energy efficiency are taken on. Every step books the move's propulsion energy
(``core.kernel.slot_power``) whatever the flags.
"""

from __future__ import annotations

import math

import numpy as np

from ios_uav_env.envs.core.kernel import (
    FLAG_ENERGY,
    observe_energy,
    violation,
)
from ios_uav_env.envs.multi_table import (
    ACT_SCORES,
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
    MEP_SOFTMIN_BETA,
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
    MST_POTENTIAL,
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


@jit(fastmath=False)
def soft_minimum(served: np.ndarray, k_n: int, n_slots: float, beta: float) -> float:
    """The potential of the rate term (``multi.rate_potential``) of the served rates
    v_k = ``served[k]`` / ``n_slots`` of the first ``k_n`` nodes: min_k v_k for ``beta`` = 0,
    else -(1/beta) log((1/K) sum_k exp(-beta v_k)), computed from the minimum."""
    low = math.inf
    for k in range(k_n):
        low = min(low, served[k] / n_slots)
    if beta == 0.0:
        return low
    total = 0.0
    for k in range(k_n):
        total += math.exp(-beta * (served[k] / n_slots - low))
    return low - math.log(total / k_n) / beta


@jit(inline=True)
def observe_nodes(obs: np.ndarray, i: int, x: float, y: float, left: float, dist: float, episode: np.ndarray,
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


@jit(inline=True)
def info_nodes(info: np.ndarray, i: int, state: np.ndarray, episode: np.ndarray, shares: np.ndarray,
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


@jit(inline=True)
def softmax_shares(i: int, actions: np.ndarray, sharpness: float, k_n: int, shares: np.ndarray) -> None:
    """Row ``i``'s shares: the softmax of ``sharpness`` x its K node scores (``actions[i, ACT_SCORES + k]``),
    each clipped to the action space's [-1, 1] first (so any finite score gives finite shares)."""
    top = -math.inf
    for k in range(k_n):
        top = max(top, sharpness * min(1.0, max(-1.0, actions[i, ACT_SCORES + k])))
    total = 0.0
    for k in range(k_n):
        shares[i, k] = math.exp(sharpness * min(1.0, max(-1.0, actions[i, ACT_SCORES + k])) - top)
        total += shares[i, k]
    for k in range(k_n):
        shares[i, k] /= total


@jit(fastmath=False)
def keep_rates(rows: np.ndarray, state: np.ndarray, rates: np.ndarray, rate_path: np.ndarray) -> None:
    """Store the node rates ``rates[i]`` of each of ``rows`` (int64) at its way-point, slot
    ``moves made`` + 1 of ``rate_path`` (B, N_max, K_max): the rates :func:`reset_rows` just
    computed, kept for the episode's best schedule (``NodeRows.best_values``; a step writes its
    own)."""
    for i in rows:
        n = int(state[i, MST_MOVES_MADE])
        for k in range(rates.shape[1]):
            rate_path[i, n, k] = rates[i, k]


@jit(inline=True)
def start_nodes(i: int, k_n: int, shares: np.ndarray, served: np.ndarray, expected: np.ndarray) -> None:
    """Row ``i``'s slot 1, before its rates are added: shared equally among its ``k_n`` nodes,
    the served and expected-gain sums 0."""
    for k in range(k_n):
        shares[i, k], served[i, k], expected[i, k] = 1.0 / k_n, 0.0, 0.0


@jit(inline=True)
def add_node_rate(
    i: int, k: int, slot: int, expected_rate: float, rate: float, shares: np.ndarray, rates: np.ndarray,
    served: np.ndarray, expected: np.ndarray, share_path: np.ndarray,
) -> float:  # fmt: skip
    """Book node ``k``'s rates of row ``i``'s way-point ``slot`` (its index in the paths): the
    expected-gain rate r_k in ``rates``, the share-weighted ``rate`` as served and r_k added to
    the sums ``served`` and ``expected`` (slot 1's to the zeros of :func:`start_nodes`: 0 + x is
    x exactly), the share in ``share_path``. Returns the node's served sum."""
    rates[i, k] = expected_rate
    served[i, k] = served[i, k] + shares[i, k] * rate
    expected[i, k] = expected[i, k] + shares[i, k] * expected_rate
    share_path[i, slot, k] = shares[i, k]
    return served[i, k]


@jit(inline=True)
def rate_term(
    i: int, slot: int, left: float, low: float, state: np.ndarray, episode: np.ndarray, served: np.ndarray,
    rates: np.ndarray, rate_path: np.ndarray,
) -> float:  # fmt: skip
    """Row ``i``'s rate term after a step to way-point ``slot`` (``left`` moves to go; ``low``:
    the least served sum): the min rate so far, the potential's change x N (:func:`soft_minimum`)
    and, at the last slot with a soft minimum, the gap to the true minimum; ``rate_path``
    receives the node rates of the way-point (all K_max columns of ``rates[i]``)."""
    for k in range(rates.shape[1]):
        rate_path[i, slot, k] = rates[i, k]
    n_slots, k_n, beta = episode[i, MEP_N], int(episode[i, MEP_K]), episode[i, MEP_SOFTMIN_BETA]
    state[i, MST_MIN_RATE] = low / n_slots
    previous, state[i, MST_POTENTIAL] = state[i, MST_POTENTIAL], soft_minimum(served[i], k_n, n_slots, beta)
    r_rate = n_slots * (state[i, MST_POTENTIAL] - previous)
    if left == 0.0 and beta != 0.0:
        r_rate += n_slots * (state[i, MST_MIN_RATE] - state[i, MST_POTENTIAL])
    return r_rate


@jit(inline=True)
def start_rate_term(i: int, low: float, state: np.ndarray, episode: np.ndarray) -> None:
    """Row ``i``'s min rate after slot 1 (``low``: the least served sum) and the potential before
    slot 1: 0."""
    state[i, MST_MIN_RATE], state[i, MST_POTENTIAL] = low / episode[i, MEP_N], 0.0
