"""The one compiled row step: the reset, the step (serial and on numba's threads) and the flight
of B rows, for the single-node and the node-block view alike.

A row of either view is one UAV over K nodes (``episode``'s ``K`` column; a single-node row is
the K = 1 case): its ``state`` and ``episode`` rows begin with the core's columns
(``ios_uav_env.envs.core.kernel``), its nodes' rate kernels are rows of ``nodes`` (R, 3, Q) and
``params`` (R, P) with the node axis folded into the rows (node k of row i at row i K + k, K the
rows' node capacity ``served.shape[1]``; R = B for the single-node view) and its fading draws
rows of ``normals`` (R, 2). Each slot runs the same code whatever the view: the core's move
(``move_row``: unit-disk projection, arrival guard, power and energy), each node's
expected-gain rate (``channel.rate_row``) and, with channel "rician", its faded rate
(``channel.faded_row``), the core's reward (``reward_row``: reach, terminal and energy terms).
What the view adds is chosen by ``node_blocks``: the single-node view's running rate sums and
v0 writers (``ios_uav_env.envs.single_kernels``), or the node-block view's shares, served sums,
min-rate potential and node-block writers (``ios_uav_env.envs.multi_step``). Arrays a view does
not use are passed as any array of the same type (the entry points of
``ios_uav_env.envs.view_steps`` pass the view's own).

Both views run these functions, compiled once per view: :func:`reset_rows`, :func:`step_rows`
and :func:`fly_rows` are inlined into the views' entry points (a call of a compiled function
with 22 arrays cost the single env about 0.2 us a step, its arrays' reference counts), and
:func:`step_rows_batched`, called, is compiled for each view's constant ``node_blocks``, which
numba types as a literal (read from the flags at run time instead, one compilation for both
views, the batched single-node step took about 13 % longer per row). An entry point compiles
the inlined functions with its own flags: it declares theirs.

Arithmetic: the fast-math flags of ``ios_uav_env.jit`` (the node sums vectorise), in the step
and the reset; the flight (:func:`fly_rows`) in IEEE arithmetic, as plain Python rounds it,
whichever view. The
functions these call compiled on their own keep their own flags: the arrival guard's
projection (``model.guard``), the b-bit phase search (``rate_kernels.discrete_zeta_row``) and
the soft minimum (``multi_step.soft_minimum``).
"""

from __future__ import annotations

import math

import numpy as np

from ios_uav_env.envs.core.kernel import (
    E_MOVES,
    E_QFX,
    E_QFY,
    FLAG_RICIAN,
    S_MOVES_MADE,
    S_X,
    S_Y,
    fly_entry_out_of_range,
    move_row,
    reward_row,
    start_row,
    toward,
)
from ios_uav_env.envs.multi_step import (
    add_node_rate,
    info_nodes,
    observe_nodes,
    rate_term,
    softmax_shares,
    start_nodes,
    start_rate_term,
)
from ios_uav_env.envs.multi_table import ACT_MOVE_X, ACT_MOVE_Y, MEP_K, MEP_SHARPNESS
from ios_uav_env.envs.single_kernels import add_rates, info_single, observe_single, start_rates
from ios_uav_env.jit import jit, prange
from ios_uav_env.model.channel import faded_row, rate_row

__all__ = ["fly_rows", "reset_rows", "step_rows", "step_rows_batched"]


@jit(inline=True)
def _node_rates(j: int, x: float, y: float, nodes: np.ndarray, params: np.ndarray, normals: np.ndarray,
                flags: np.ndarray) -> tuple[float, float]:  # fmt: skip
    """(expected-gain rate, rate as served) of the node of folded row ``j`` at (x, y): with
    channel "rician" one faded sample drawn from ``normals[j]``."""
    expected = rate_row(x, y, nodes, params, j)
    if flags[FLAG_RICIAN] != 0.0:
        return expected, faded_row(x, y, normals[j, 0], normals[j, 1], nodes, params, j)
    return expected, expected


@jit(inline=True)
def reset_rows(
    rows: np.ndarray, state: np.ndarray, episode: np.ndarray, points: np.ndarray, nodes: np.ndarray,
    params: np.ndarray, served: np.ndarray, shares: np.ndarray, rates: np.ndarray, flags: np.ndarray,
    obs: np.ndarray, info: np.ndarray, share_path: np.ndarray, expected: np.ndarray, normals: np.ndarray,
    node_blocks: bool,
) -> None:  # fmt: skip
    """Start the episodes of ``rows`` at the position already in ``state``'s ``x``, ``y`` (q0): the
    core state (``start_row``), slot 1's rates (node blocks: shared equally) and the first
    observation and ``info``."""
    k_max = served.shape[1] if node_blocks else 1
    for i in rows:
        x, y = state[i, S_X], state[i, S_Y]
        k_n = int(episode[i, MEP_K]) if node_blocks else 1
        if node_blocks:
            start_nodes(i, k_n, shares, served, expected)
        else:
            start_rates(i, state)
        first, first_served, low = 0.0, 0.0, math.inf
        for k in range(k_n):
            e, r = _node_rates(i * k_max + k, x, y, nodes, params, normals, flags)
            if node_blocks:
                low = min(low, add_node_rate(i, k, 0, e, r, shares, rates, served, expected, share_path))
            else:
                add_rates(i, e, r, state)
                first, first_served = e, r
        start_row(i, state)
        dist = math.hypot(episode[i, E_QFX] - x, episode[i, E_QFY] - y)
        left = episode[i, E_MOVES]
        if node_blocks:
            start_rate_term(i, low, state, episode)
            observe_nodes(obs, i, x, y, left, dist, episode, points, served, rates, state, flags)
            info_nodes(info, i, state, episode, shares, served, dist, left, 0.0, 0.0, 0.0, expected, 0.0, 0.0)
        else:
            observe_single(obs, i, x, y, left, dist, first, state, episode, flags)
            info_single(info, i, state, episode, first_served, first, dist, left, 0.0, 0.0, 0.0, 0.0, 0.0)


@jit(inline=True)
def _step_each(
    lo: int, hi: int, active: np.ndarray, n_max: int, actions: np.ndarray, state: np.ndarray,
    episode: np.ndarray, points: np.ndarray, nodes: np.ndarray, params: np.ndarray, served: np.ndarray,
    shares: np.ndarray, rates: np.ndarray, flags: np.ndarray, obs: np.ndarray, reward: np.ndarray,
    terminated: np.ndarray, info: np.ndarray, path: np.ndarray, share_path: np.ndarray, norms: np.ndarray,
    expected: np.ndarray, normals: np.ndarray, rate_path: np.ndarray, node_blocks: bool,
) -> None:  # fmt: skip
    """One slot of each active row ``i`` in ``lo`` .. ``hi`` - 1 (node blocks: that has a move left
    and room in paths of ``n_max`` way-points): node blocks take their shares from the scores
    (``softmax_shares``); the core's move; each node's rates; the view's rate term (the served
    rate, or the potential's change); the core's reward; the view's observation and ``info``.
    ``path`` (B, N_max, 2) receives the new way-point (at index ``moves made``). ``norms[i]``: the
    move's length where it may exceed 1 (node blocks: ``multi_kernels.move_norms``; a single-node
    row takes its own). The rows' loop is inside: inlined in a serial loop, each array argument
    is bound (and reference-counted) once per call, not once per row."""
    k_max = served.shape[1] if node_blocks else 1
    for i in range(lo, hi):
        if not active[i] or (node_blocks and not _steps(state, episode, i, n_max)):
            continue
        k_n = int(episode[i, MEP_K]) if node_blocks else 1
        ax, ay = actions[i, ACT_MOVE_X], actions[i, ACT_MOVE_Y]
        if node_blocks:
            softmax_shares(i, actions, episode[i, MEP_SHARPNESS], k_n, shares)
            norm = norms[i]
        else:
            norm = math.hypot(ax, ay)
        slot = int(state[i, S_MOVES_MADE]) + 1  # the new way-point's index
        x, y, left, power = move_row(i, ax, ay, norm, state, episode, flags, path)
        first, first_served, low = 0.0, 0.0, math.inf
        for k in range(k_n):
            e, r = _node_rates(i * k_max + k, x, y, nodes, params, normals, flags)
            if node_blocks:
                low = min(low, add_node_rate(i, k, slot, e, r, shares, rates, served, expected, share_path))
            else:
                add_rates(i, e, r, state)
                first, first_served = e, r
        dist = math.hypot(episode[i, E_QFX] - x, episode[i, E_QFY] - y)
        r_rate = first_served
        if node_blocks:
            r_rate = rate_term(i, slot, left, low, state, episode, served, rates, rate_path)
        r_reach, r_terminal, r_energy = reward_row(
            i, r_rate, dist, left, power, episode, flags, reward, terminated
        )
        if node_blocks:
            observe_nodes(obs, i, x, y, left, dist, episode, points, served, rates, state, flags)
            info_nodes(info, i, state, episode, shares, served, dist, left, r_rate, r_reach, r_terminal,
                       expected, power, r_energy)  # fmt: skip
        else:
            observe_single(obs, i, x, y, left, dist, first, state, episode, flags)
            info_single(info, i, state, episode, first_served, first, dist, left, r_rate, r_reach,
                        r_terminal, power, r_energy)  # fmt: skip


@jit(inline=True)
def _refused(actions: np.ndarray, state: np.ndarray, episode: np.ndarray, active: np.ndarray, n_max: int,
             node_blocks: bool) -> int:  # fmt: skip
    """-1 if every active row may step, else (a single-node view's check: the node-block envs check
    first and the step leaves such a row as it is) the first active row whose move is not finite,
    or ``B`` + the first active row whose episode is over (or whose paths are full)."""
    if node_blocks:
        return -1
    b = actions.shape[0]
    for i in range(b):
        if active[i] and not (
            math.isfinite(actions[i, ACT_MOVE_X]) and math.isfinite(actions[i, ACT_MOVE_Y])
        ):
            return i
    for i in range(b):
        if active[i] and (
            state[i, S_MOVES_MADE] >= episode[i, E_MOVES] or state[i, S_MOVES_MADE] + 1.0 >= n_max
        ):
            return b + i
    return -1


@jit(inline=True)
def _steps(state: np.ndarray, episode: np.ndarray, i: int, n_max: int) -> bool:
    """Whether row ``i`` has a move left and room for it in paths of ``n_max`` way-points (a
    single-node batch is checked whole first: :func:`_refused`)."""
    return state[i, S_MOVES_MADE] < episode[i, E_MOVES] and state[i, S_MOVES_MADE] + 1.0 < n_max


@jit(inline=True)
def _path_room(path: np.ndarray, share_path: np.ndarray, rate_path: np.ndarray, node_blocks: bool) -> int:
    """The way-points the paths hold (node blocks: the shortest of the three)."""
    if node_blocks:
        return min(path.shape[1], share_path.shape[1], rate_path.shape[1])
    return path.shape[1]


@jit(inline=True)
def step_rows(
    actions: np.ndarray, state: np.ndarray, episode: np.ndarray, points: np.ndarray, nodes: np.ndarray,
    params: np.ndarray, served: np.ndarray, shares: np.ndarray, rates: np.ndarray, flags: np.ndarray,
    obs: np.ndarray, reward: np.ndarray, terminated: np.ndarray, info: np.ndarray, path: np.ndarray,
    share_path: np.ndarray, active: np.ndarray, norms: np.ndarray, expected: np.ndarray, normals: np.ndarray,
    rate_path: np.ndarray, node_blocks: bool,
) -> int:  # fmt: skip
    """One slot of every active row (:func:`_step_each`), one row after the other. Returns -1, or,
    stepping nothing, the refusal of a single-node batch (:func:`_refused`); a node-block row
    whose episode is over is left as it is."""
    n_max = _path_room(path, share_path, rate_path, node_blocks)
    bad = _refused(actions, state, episode, active, n_max, node_blocks)
    if bad < 0:
        _step_each(0, actions.shape[0], active, n_max, actions, state, episode, points, nodes, params, served,
                   shares, rates, flags, obs, reward, terminated, info, path, share_path, norms, expected,
                   normals, rate_path, node_blocks)  # fmt: skip
    return bad


@jit(parallel=True)
def step_rows_batched(
    actions: np.ndarray, state: np.ndarray, episode: np.ndarray, points: np.ndarray, nodes: np.ndarray,
    params: np.ndarray, served: np.ndarray, shares: np.ndarray, rates: np.ndarray, flags: np.ndarray,
    obs: np.ndarray, reward: np.ndarray, terminated: np.ndarray, info: np.ndarray, path: np.ndarray,
    share_path: np.ndarray, active: np.ndarray, norms: np.ndarray, expected: np.ndarray, normals: np.ndarray,
    rate_path: np.ndarray, node_blocks: bool,
) -> int:  # fmt: skip
    """:func:`step_rows` with the rows in parallel on numba's threads (the envs' ``num_threads``).
    The loop body is compiled apart, without the reference counting that the inlined helpers
    cost in :func:`step_rows`. (Two functions, not one compiled twice: numba's disk cache keys a
    function by its name, not by its options.)"""
    n_max = _path_room(path, share_path, rate_path, node_blocks)
    bad = _refused(actions, state, episode, active, n_max, node_blocks)
    if bad < 0:
        for i in prange(actions.shape[0]):  # rows are independent
            _step_each(i, i + 1, active, n_max, actions, state, episode, points, nodes, params, served,
                       shares, rates, flags, obs, reward, terminated, info, path, share_path, norms, expected,
                       normals, rate_path, node_blocks)  # fmt: skip
    return bad


@jit(inline=True, fastmath=False)
def fly_rows(
    rows: np.ndarray, targets: np.ndarray, moves: np.ndarray, actions: np.ndarray, state: np.ndarray,
    episode: np.ndarray, points: np.ndarray, nodes: np.ndarray, params: np.ndarray, served: np.ndarray,
    shares: np.ndarray, rates: np.ndarray, flags: np.ndarray, obs: np.ndarray, reward: np.ndarray,
    terminated: np.ndarray, info: np.ndarray, path: np.ndarray, share_path: np.ndarray, norms: np.ndarray,
    expected: np.ndarray, normals: np.ndarray, rate_path: np.ndarray, node_blocks: bool,
) -> int:  # fmt: skip
    """``moves[r]`` slots of row ``rows[r]``, each a full-speed move towards ``targets[r]`` (the rest
    of the way once within D; the arrival guard as always; node blocks with equal shares): the
    steps of :func:`step_rows` with those actions (``actions`` and ``norms``: scratch, (B, 2 +
    scores) and (B,); no fading draws: the batched envs step Rician rows instead); a row given
    more than once flies its entries in order. Returns -1, or, flying nothing, the first entry
    ``r`` that is out of range (``core.kernel.fly_entry_out_of_range``)."""
    n_max = _path_room(path, share_path, rate_path, node_blocks)
    bad = fly_entry_out_of_range(rows, targets, moves, state, episode, n_max)
    if bad >= 0:
        return bad
    everyone = np.ones(state.shape[0], dtype=np.bool_)
    for r in range(rows.size):
        i = rows[r]
        for k in range(actions.shape[1]):
            actions[i, k] = 0.0  # node scores 0: equal shares
        norms[i] = 0.0  # the moves below are on the unit disk already
        for _ in range(moves[r]):
            toward(i, targets[r, 0], targets[r, 1], state, episode, actions)
            _step_each(i, i + 1, everyone, n_max, actions, state, episode, points, nodes, params, served,
                       shares, rates, flags, obs, reward, terminated, info, path, share_path, norms, expected,
                       normals, rate_path, node_blocks)  # fmt: skip
    return -1
