"""The multi-node env's transition as compiled kernels over B rows: one implementation for
``MultiNodeEnv`` (a batch of one) and ``MultiNodeVectorEnv`` (B rows), which call them through
``ios_uav_env.envs.multi_kernels.NodeRows`` (re-exported there).

Row i of a few arrays is episode i (``NodeRows`` holds them; their columns:
``ios_uav_env.envs.multi_table``): ``state`` (``STATE``), ``episode`` (``EPISODE``: the
scenario's constants), ``points`` (B, K_max, 6: each node's
x, y, its side of the IOS and, with ``peak_hint``, its reachable rate peak x, y and rate),
``served`` (B, K_max: S_k) and, per node, the arrays of its rate kernel
(``ios_uav_env.model.channel.RateKernel`` of ``config.node_config(k)``: ``nodes`` (B, K_max, 3, Q),
``params`` (B, K_max, P)). :func:`reset_rows` and :func:`step_rows` write the observations,
rewards and the ``info`` table (``multi_table.info_columns``, read by ``info_arrays``) of the
rows they touch: node k's rate is ``channel.rate_point``, the shares are the softmax of
``share_sharpness`` x the scores of the scenario's K nodes, and the reward terms are those of
``MultiNodeEnv``'s docstring. The move (unit-disk projection, ``guard.guarded_position``, the
step's power and energy), the reward's reach, terminal and energy terms, the reset of the core
state, the running eq. (10) check and the energy features are the row-step core's
(``ios_uav_env.envs.core.kernel``), the ones the single-node view's step runs; the rates, the
shares, the min-rate potential and the observation and ``info`` writers
(``ios_uav_env.envs.multi_writers``) are this view's.
Compiled with numba when installed (``ios_uav_env.jit``). The kernels index every column by
name (``multi_table``'s module docstring), never by number.

Two options of ``flags`` (``core.kernel.flags_of``) change the step: ``energy`` (the
objective ``"energy_efficiency"``) adds the reward's energy term -(lambda_ref / B) P(V_n) and the
energy features after the node blocks; ``rician`` serves each node its faded rate of the slot
(``channel.faded_point`` with the two standard normal draws of ``normals[i, k]``), while
``expected`` (B, K_max) keeps the expected-gain sums sum_n alpha_k[n] r_k(q[n]) that the score
and the energy efficiency are taken on. Every step books the move's propulsion energy
(``core.kernel.slot_power``) whatever the flags.
"""

from __future__ import annotations

import math

import numpy as np

from ios_uav_env.envs.core.kernel import (
    FLAG_RICIAN,
    fly_entry_out_of_range,
    move_row,
    reward_row,
    start_row,
    toward,
)
from ios_uav_env.envs.multi_table import (
    ACT_MOVE_X,
    ACT_MOVE_Y,
    ACT_SCORES,
    MEP_K,
    MEP_MOVES,
    MEP_N,
    MEP_QFX,
    MEP_QFY,
    MEP_SHARPNESS,
    MEP_SOFTMIN_BETA,
    MST_MIN_RATE,
    MST_MOVES_MADE,
    MST_POTENTIAL,
    MST_X,
    MST_Y,
)
from ios_uav_env.envs.multi_writers import info_row, observe_row
from ios_uav_env.jit import jit, prange
from ios_uav_env.model.channel import faded_point, rate_point


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


@jit(inline=True, fastmath=False)
def _rates(
    i: int, x: float, y: float, k_n: int, nodes: np.ndarray, params: np.ndarray, rates: np.ndarray
) -> None:
    """r_k(x, y) of row ``i``'s K nodes into ``rates[i]``."""
    for k in range(k_n):
        rates[i, k] = rate_point(x, y, nodes[i, k], params[i, k])


@jit(inline=True, fastmath=False)
def _served(i: int, x: float, y: float, k_n: int, nodes: np.ndarray, params: np.ndarray, rates: np.ndarray,
            normals: np.ndarray, flags: np.ndarray, k: int) -> float:  # fmt: skip
    """Node ``k``'s rate of row ``i``'s slot as served: its expected-gain rate ``rates[i, k]``, or
    with channel "rician" (``flags[FLAG_RICIAN]``) one faded sample drawn from ``normals[i, k]``."""
    if flags[FLAG_RICIAN] != 0.0:
        return faded_point(x, y, normals[i, k, 0], normals[i, k, 1], nodes[i, k], params[i, k])
    return rates[i, k]


@jit(fastmath=False)
def reset_rows(
    rows: np.ndarray, state: np.ndarray, episode: np.ndarray, points: np.ndarray, nodes: np.ndarray,
    params: np.ndarray, served: np.ndarray, shares: np.ndarray, rates: np.ndarray, obs: np.ndarray,
    info: np.ndarray, share_path: np.ndarray, expected: np.ndarray, normals: np.ndarray, flags: np.ndarray,
) -> None:  # fmt: skip
    """Start the episodes of ``rows`` at the position already in ``state[:, 0:2]`` (q0): slot 1
    shared equally (``shares`` (B, K_max) holds each row's current shares; ``expected`` and
    ``normals`` as in :func:`step_rows_batched`)."""
    for i in rows:
        ep, st = episode[i], state[i]
        x, y, k_n = st[MST_X], st[MST_Y], int(ep[MEP_K])
        _rates(i, x, y, k_n, nodes, params, rates)
        low = math.inf
        for k in range(k_n):
            shares[i, k] = 1.0 / k_n
            served[i, k] = shares[i, k] * _served(i, x, y, k_n, nodes, params, rates, normals, flags, k)
            expected[i, k] = shares[i, k] * rates[i, k]
            share_path[i, 0, k] = shares[i, k]
            low = min(low, served[i, k])
        start_row(i, state)
        st[MST_MIN_RATE], st[MST_POTENTIAL] = low / ep[MEP_N], 0.0  # potential before slot 1: 0
        dist = math.hypot(ep[MEP_QFX] - x, ep[MEP_QFY] - y)
        left = ep[MEP_MOVES]
        observe_row(obs, i, x, y, left, dist, episode, points, served, rates, state, flags)
        info_row(info, i, state, episode, shares, served, dist, left, 0.0, 0.0, 0.0, expected, 0.0, 0.0)


@jit(inline=True, fastmath=False)
def _softmax(i: int, actions: np.ndarray, sharpness: float, k_n: int, shares: np.ndarray) -> None:
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


@jit(inline=True, fastmath=False)
def _step_row(
    i: int, actions: np.ndarray, state: np.ndarray, episode: np.ndarray, points: np.ndarray,
    nodes: np.ndarray, params: np.ndarray, served: np.ndarray, shares: np.ndarray, rates: np.ndarray,
    flags: np.ndarray, obs: np.ndarray, reward: np.ndarray, terminated: np.ndarray, info: np.ndarray,
    path: np.ndarray, share_path: np.ndarray, norms: np.ndarray, expected: np.ndarray, normals: np.ndarray,
    rate_path: np.ndarray,
) -> None:  # fmt: skip
    """One slot of row ``i`` (see :func:`step_rows`); a row whose episode is over (or whose
    ``path`` is full) is left as it is: nothing is written past its slot N. ``rate_path``
    receives the node rates of the new way-point (all K_max columns of ``rates[i]``)."""
    ep, st = episode[i], state[i]
    n_max = min(path.shape[1], share_path.shape[1], rate_path.shape[1])
    if st[MST_MOVES_MADE] >= ep[MEP_MOVES] or st[MST_MOVES_MADE] + 1.0 >= n_max:
        return  # (the envs never step such a row: they check first)
    n_slots, k_n = ep[MEP_N], int(ep[MEP_K])
    _softmax(i, actions, ep[MEP_SHARPNESS], k_n, shares)
    n = st[MST_MOVES_MADE]
    x, y, left, power = move_row(
        i, actions[i, ACT_MOVE_X], actions[i, ACT_MOVE_Y], norms[i], state, episode, flags, path
    )
    _rates(i, x, y, k_n, nodes, params, rates)
    low = math.inf
    for k in range(k_n):
        rate = _served(i, x, y, k_n, nodes, params, rates, normals, flags, k)
        served[i, k] = served[i, k] + shares[i, k] * rate
        expected[i, k] = expected[i, k] + shares[i, k] * rates[i, k]
        share_path[i, int(n) + 1, k] = shares[i, k]
        low = min(low, served[i, k])
    for k in range(rates.shape[1]):
        rate_path[i, int(n) + 1, k] = rates[i, k]
    st[MST_MIN_RATE] = low / n_slots
    beta = ep[MEP_SOFTMIN_BETA]
    previous, st[MST_POTENTIAL] = st[MST_POTENTIAL], soft_minimum(served[i], k_n, n_slots, beta)
    dist = math.hypot(ep[MEP_QFX] - x, ep[MEP_QFY] - y)
    r_rate = n_slots * (st[MST_POTENTIAL] - previous)
    if left == 0.0 and beta != 0.0:
        r_rate += n_slots * (st[MST_MIN_RATE] - st[MST_POTENTIAL])
    r_reach, r_terminal, r_energy = reward_row(
        i, r_rate, dist, left, power, episode, flags, reward, terminated
    )
    observe_row(obs, i, x, y, left, dist, episode, points, served, rates, state, flags)
    info_row(info, i, state, episode, shares, served, dist, left, r_rate, r_reach, r_terminal, expected,
             power, r_energy)  # fmt: skip


@jit(fastmath=False)
def step_rows(
    actions: np.ndarray, state: np.ndarray, episode: np.ndarray, points: np.ndarray, nodes: np.ndarray,
    params: np.ndarray, served: np.ndarray, shares: np.ndarray, rates: np.ndarray, flags: np.ndarray,
    obs: np.ndarray, reward: np.ndarray, terminated: np.ndarray, info: np.ndarray, path: np.ndarray,
    share_path: np.ndarray, active: np.ndarray, norms: np.ndarray, expected: np.ndarray, normals: np.ndarray,
    rate_path: np.ndarray,
) -> None:  # fmt: skip
    """:func:`step_rows_batched` one row after the other (where numba's threads cannot run:
    ``ios_uav_env.jit.parallel_safe``)."""
    for i in range(actions.shape[0]):
        if active[i]:
            _step_row(i, actions, state, episode, points, nodes, params, served, shares, rates, flags, obs,
                      reward, terminated, info, path, share_path, norms, expected, normals,
                      rate_path)  # fmt: skip


@jit(fastmath=False, parallel=True)
def step_rows_batched(
    actions: np.ndarray, state: np.ndarray, episode: np.ndarray, points: np.ndarray, nodes: np.ndarray,
    params: np.ndarray, served: np.ndarray, shares: np.ndarray, rates: np.ndarray, flags: np.ndarray,
    obs: np.ndarray, reward: np.ndarray, terminated: np.ndarray, info: np.ndarray, path: np.ndarray,
    share_path: np.ndarray, active: np.ndarray, norms: np.ndarray, expected: np.ndarray, normals: np.ndarray,
    rate_path: np.ndarray,
) -> None:  # fmt: skip
    """One slot of every active row: move (unit-disk projection, then the arrival guard), shares,
    node rates, served rates, reward, observation and info. ``actions`` (B, 2 + K_max) must be
    finite (the caller checks); ``flags`` as ``core.kernel.flags_of``; ``path`` (B, N_max, 2),
    ``share_path`` and ``rate_path`` (B, N_max, K_max) receive the new way-point, shares and node
    rates (at ``moves made``; the rates kept for the episode's best schedule,
    ``NodeRows.best_values``). ``norms`` (B,): |move| of each row whose move may leave the unit
    disk, 0 for the others (:func:`move_norms`: Python's ``math.hypot``, which the compiled one does not match
    bit for bit). ``expected`` (B, K_max): each node's expected-gain sum sum_n alpha_k[n]
    r_k(q[n]); ``normals`` (B, K_max, 2): the slot's draws of h_SS per node (channel "rician"
    only). The rows run in parallel on numba's threads
    (``MultiNodeVectorEnv(num_threads=...)``). IEEE arithmetic (no fused multiply-add) in the
    kernel's own code, rounded as plain Python rounds it: the arrival guard amplifies a
    last-bit difference when it pulls the UAV home along the reach circle."""
    for i in prange(actions.shape[0]):  # rows are independent, on numba's threads
        if active[i]:
            _step_row(i, actions, state, episode, points, nodes, params, served, shares, rates, flags, obs,
                      reward, terminated, info, path, share_path, norms, expected, normals,
                      rate_path)  # fmt: skip


@jit(fastmath=False)
def fly_rows(
    rows: np.ndarray, targets: np.ndarray, moves: np.ndarray, actions: np.ndarray, state: np.ndarray,
    episode: np.ndarray, points: np.ndarray, nodes: np.ndarray, params: np.ndarray, served: np.ndarray,
    shares: np.ndarray, rates: np.ndarray, flags: np.ndarray, obs: np.ndarray, reward: np.ndarray,
    terminated: np.ndarray, info: np.ndarray, path: np.ndarray, share_path: np.ndarray, norms: np.ndarray,
    expected: np.ndarray, normals: np.ndarray, rate_path: np.ndarray,
) -> int:  # fmt: skip
    """``moves[r]`` slots of row ``rows[r]``, each a full-speed move towards ``targets[r]`` (the rest
    of the way once within D; the arrival guard as always) with equal shares: the steps of
    :func:`step_rows` with those actions (``actions`` and ``norms`` are scratch, (B, 2 + K_max)
    and (B,); no fading draws: the batched env steps Rician rows instead); a row given more than
    once flies its entries in order. Returns -1, or, flying
    nothing, the first entry ``r`` that is out of range: a row outside 0..B-1, a move count
    < 0, or a row whose moves (summed over its entries) would finish its episode or pass the
    end of ``path``."""
    bad = fly_entry_out_of_range(
        rows, targets, moves, state, episode, min(path.shape[1], share_path.shape[1], rate_path.shape[1])
    )
    if bad >= 0:
        return bad
    for r in range(rows.size):
        i = rows[r]
        for k in range(actions.shape[1]):
            actions[i, k] = 0.0  # node scores 0: equal shares
        norms[i] = 0.0  # the move below is on the unit disk already
        for _ in range(moves[r]):
            toward(i, targets[r, 0], targets[r, 1], state, episode, actions)
            _step_row(i, actions, state, episode, points, nodes, params, served, shares, rates, flags, obs,
                      reward, terminated, info, path, share_path, norms, expected, normals,
                      rate_path)  # fmt: skip
    return -1


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
