"""The views' compiled entry points into the one row step (``ios_uav_env.envs.row_step``): each
takes its view's arrays (the signatures the envs call) and passes them on, in compiled code, to
the one ``reset_rows`` / ``step_rows`` / ``step_rows_batched`` / ``fly_rows``.

The single-node view (``IOSUAVEnv`` on a batch of one, ``IOSUAVVectorEnv`` on B rows; arrays:
``ios_uav_env.envs.single_kernels``) calls :func:`reset_rows`, :func:`step_rows`,
:func:`step_rows_batched` and :func:`fly_rows`; its rows are the row step's K = 1 case and the
node-block arrays it has no use for are its own arrays of the same types, never read. The
node-block view (``ios_uav_env.envs.multi_kernels.NodeRows``; arrays:
``ios_uav_env.envs.multi_step``) calls :func:`reset_node_rows`, :func:`step_node_rows`,
:func:`step_node_rows_batched` and :func:`fly_node_rows`, which fold the node axis of ``nodes``,
``params`` and ``normals`` into the rows (a reshape of C-ordered arrays: views, no copies).

The entry points are thin so that what the envs pay per call stays their view's: numba's
dispatcher converts each argument at every call from Python, so a view passes only its own
arrays (the single env's step, 13 of them); the rest is built here, where a call costs no
conversion. The row step's reset, serial step and flight are inlined here (compiled with the
flags each entry point declares: the row step's, fast-math, and IEEE for the flights), its
parallel step is called. (Numba's disk cache keys a compiled function by its own module's
source: after a change of ``row_step`` or of what it inlines, delete the ``*.nbi`` / ``*.nbc``
files of this module too.)
"""

from __future__ import annotations

import numpy as np

from ios_uav_env.envs import row_step as one
from ios_uav_env.jit import jit

__all__ = [
    "fly_node_rows", "fly_rows", "reset_node_rows", "reset_rows", "step_node_rows", "step_node_rows_batched",
    "step_rows", "step_rows_batched",
]  # fmt: skip


@jit
def reset_rows(
    rows: np.ndarray, state: np.ndarray, episode: np.ndarray, nodes: np.ndarray, params: np.ndarray,
    normals: np.ndarray, flags: np.ndarray, obs: np.ndarray, info: np.ndarray,
) -> None:  # fmt: skip
    """Start the single-node episodes of ``rows`` at the position already in ``state``'s ``x``,
    ``y`` (q0): ``row_step.reset_rows``."""
    one.reset_rows(rows, state, episode, nodes, nodes, params, state, state, state, flags, obs, info, nodes,
                   state, normals, False)  # fmt: skip


@jit
def step_rows(
    actions: np.ndarray, state: np.ndarray, episode: np.ndarray, nodes: np.ndarray, params: np.ndarray,
    normals: np.ndarray, flags: np.ndarray, obs: np.ndarray, reward: np.ndarray, terminated: np.ndarray,
    info: np.ndarray, path: np.ndarray, active: np.ndarray,
) -> int:  # fmt: skip
    """One slot of every active single-node row, one after the other (the single env's step):
    ``row_step.step_rows``. ``normals`` (B, 2): the slot's draws of h_SS (channel "rician");
    ``path`` (B, N_max, 2) receives the new way-points. Returns -1, or, stepping nothing, the
    first active row whose action is not finite, or else ``B`` + the first active row whose
    episode is over (nothing is ever written past a row's slot N: the envs check first)."""
    return one.step_rows(actions, state, episode, path, nodes, params, state, state, state, flags, obs,
                         reward, terminated, info, path, path, active, reward, state, normals, path,
                         False)  # fmt: skip


@jit
def step_rows_batched(
    actions: np.ndarray, state: np.ndarray, episode: np.ndarray, nodes: np.ndarray, params: np.ndarray,
    normals: np.ndarray, flags: np.ndarray, obs: np.ndarray, reward: np.ndarray, terminated: np.ndarray,
    info: np.ndarray, path: np.ndarray, active: np.ndarray,
) -> int:  # fmt: skip
    """:func:`step_rows` with the rows in parallel on numba's threads
    (``IOSUAVVectorEnv(num_threads=...)``): ``row_step.step_rows_batched``."""
    return one.step_rows_batched(actions, state, episode, path, nodes, params, state, state, state, flags,
                                 obs, reward, terminated, info, path, path, active, reward, state, normals,
                                 path, False)  # fmt: skip


@jit(fastmath=False)
def fly_rows(
    rows: np.ndarray, targets: np.ndarray, moves: np.ndarray, actions: np.ndarray, state: np.ndarray,
    episode: np.ndarray, nodes: np.ndarray, params: np.ndarray, normals: np.ndarray, flags: np.ndarray,
    obs: np.ndarray, reward: np.ndarray, terminated: np.ndarray, info: np.ndarray, path: np.ndarray,
) -> int:  # fmt: skip
    """``moves[r]`` full-speed single-node slots of row ``rows[r]`` towards ``targets[r]``
    (``actions``: (B, 2) scratch): ``row_step.fly_rows``. Returns -1, or, flying nothing, the
    first entry ``r`` that is out of range."""
    return one.fly_rows(rows, targets, moves, actions, state, episode, path, nodes, params, state, state,
                        state, flags, obs, reward, terminated, info, path, path, reward, state, normals, path,
                        False)  # fmt: skip


@jit(inline=True)
def _folded(nodes: np.ndarray, params: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, ...]:
    """``nodes`` (B, K, 3, Q), ``params`` (B, K, P), ``normals`` (B, K, 2) with node k of row i at
    row i K + k."""
    r = nodes.shape[0] * nodes.shape[1]
    return (nodes.reshape((r, nodes.shape[2], nodes.shape[3])), params.reshape((r, params.shape[2])),
            normals.reshape((r, normals.shape[2])))  # fmt: skip


@jit
def reset_node_rows(
    rows: np.ndarray, state: np.ndarray, episode: np.ndarray, points: np.ndarray, nodes: np.ndarray,
    params: np.ndarray, served: np.ndarray, shares: np.ndarray, rates: np.ndarray, obs: np.ndarray,
    info: np.ndarray, share_path: np.ndarray, expected: np.ndarray, normals: np.ndarray, flags: np.ndarray,
) -> None:  # fmt: skip
    """Start the node-block episodes of ``rows`` at the position already in ``state``'s ``x``, ``y``
    (q0), slot 1 shared equally (``shares`` (B, K_max) holds each row's current shares):
    ``row_step.reset_rows``."""
    f_nodes, f_params, f_normals = _folded(nodes, params, normals)
    one.reset_rows(rows, state, episode, points, f_nodes, f_params, served, shares, rates, flags, obs, info,
                   share_path, expected, f_normals, True)  # fmt: skip


@jit
def step_node_rows(
    actions: np.ndarray, state: np.ndarray, episode: np.ndarray, points: np.ndarray, nodes: np.ndarray,
    params: np.ndarray, served: np.ndarray, shares: np.ndarray, rates: np.ndarray, flags: np.ndarray,
    obs: np.ndarray, reward: np.ndarray, terminated: np.ndarray, info: np.ndarray, path: np.ndarray,
    share_path: np.ndarray, active: np.ndarray, norms: np.ndarray, expected: np.ndarray, normals: np.ndarray,
    rate_path: np.ndarray,
) -> None:  # fmt: skip
    """:func:`step_node_rows_batched` one row after the other (where numba's threads cannot run:
    ``ios_uav_env.jit.parallel_safe``): ``row_step.step_rows``."""
    f_nodes, f_params, f_normals = _folded(nodes, params, normals)
    one.step_rows(actions, state, episode, points, f_nodes, f_params, served, shares, rates, flags, obs,
                  reward, terminated, info, path, share_path, active, norms, expected, f_normals, rate_path,
                  True)  # fmt: skip


@jit
def step_node_rows_batched(
    actions: np.ndarray, state: np.ndarray, episode: np.ndarray, points: np.ndarray, nodes: np.ndarray,
    params: np.ndarray, served: np.ndarray, shares: np.ndarray, rates: np.ndarray, flags: np.ndarray,
    obs: np.ndarray, reward: np.ndarray, terminated: np.ndarray, info: np.ndarray, path: np.ndarray,
    share_path: np.ndarray, active: np.ndarray, norms: np.ndarray, expected: np.ndarray, normals: np.ndarray,
    rate_path: np.ndarray,
) -> None:  # fmt: skip
    """One slot of every active node-block row: move (unit-disk projection, then the arrival
    guard), shares, node rates, served rates, reward, observation and info
    (``row_step.step_rows_batched``, the rows on numba's threads). ``actions`` (B, 2 + K_max)
    must be finite (the caller checks); ``flags`` as ``core.kernel.flags_of``; ``path`` (B,
    N_max, 2), ``share_path`` and ``rate_path`` (B, N_max, K_max) receive the new way-point,
    shares and node rates (at ``moves made``; the rates kept for the episode's best schedule,
    ``NodeRows.best_values``). ``norms`` (B,): |move| of each row whose move may leave the unit
    disk, 0 for the others (``multi_kernels.move_norms``: Python's ``math.hypot``, which the
    compiled one does not match bit for bit). ``expected`` (B, K_max): each node's expected-gain
    sum sum_n alpha_k[n] r_k(q[n]); ``normals`` (B, K_max, 2): the slot's draws of h_SS per node
    (channel "rician" only). A row whose episode is over (or whose paths are full) is left as it
    is."""
    f_nodes, f_params, f_normals = _folded(nodes, params, normals)
    one.step_rows_batched(actions, state, episode, points, f_nodes, f_params, served, shares, rates, flags,
                          obs, reward, terminated, info, path, share_path, active, norms, expected, f_normals,
                          rate_path, True)  # fmt: skip


@jit(fastmath=False)
def fly_node_rows(
    rows: np.ndarray, targets: np.ndarray, moves: np.ndarray, actions: np.ndarray, state: np.ndarray,
    episode: np.ndarray, points: np.ndarray, nodes: np.ndarray, params: np.ndarray, served: np.ndarray,
    shares: np.ndarray, rates: np.ndarray, flags: np.ndarray, obs: np.ndarray, reward: np.ndarray,
    terminated: np.ndarray, info: np.ndarray, path: np.ndarray, share_path: np.ndarray, norms: np.ndarray,
    expected: np.ndarray, normals: np.ndarray, rate_path: np.ndarray,
) -> int:  # fmt: skip
    """``moves[r]`` full-speed node-block slots of row ``rows[r]`` towards ``targets[r]`` with equal
    shares (``actions`` and ``norms``: scratch, (B, 2 + K_max) and (B,)): ``row_step.fly_rows``.
    Returns -1, or, flying nothing, the first entry ``r`` that is out of range."""
    f_nodes, f_params, f_normals = _folded(nodes, params, normals)
    return one.fly_rows(rows, targets, moves, actions, state, episode, points, f_nodes, f_params, served,
                        shares, rates, flags, obs, reward, terminated, info, path, share_path, norms,
                        expected, f_normals, rate_path, True)  # fmt: skip
