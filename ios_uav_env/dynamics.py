"""The env's transition as array kernels: one implementation for the single and the batched env.

A batch of B episodes is a few arrays (row i = episode i): ``state`` (:data:`STATE`: the UAV
position, moves made, the running sums), ``episode`` (:data:`EPISODE`: the constants of the
episode's scenario and of its observation), and the rate kernel's ``nodes`` / ``params``
(``ios_uav_env.channel.RateKernel``; node arrays padded with zero weights). :func:`reset_rows`
and :func:`step_rows` write the observations, rewards and ``info`` columns (:data:`INFO`) of
the rows they touch. ``IOSUAVEnv`` runs them on a batch of one, ``IOSUAVVectorEnv`` on B rows:
the same physics (``channel.rate_point``, ``faded_point``), the same arrival guard
(``guard.guarded_position``) and the same reward, compiled with numba when it is installed.
"""

from __future__ import annotations

import math

import numpy as np

from ios_uav_env.channel import faded_point, rate_point
from ios_uav_env.config import FEASIBILITY_TOL, ScenarioConfig
from ios_uav_env.guard import guarded_position
from ios_uav_env.jit import jit
from ios_uav_env.observation import T_SCALE, instance_values
from ios_uav_env.options import EnvOptions

#: Columns of a row of ``state``.
STATE = ("x", "y", "moves_made", "sum_expected", "sum_rate", "excess")
#: Columns of a row of ``episode``: the scenario's constants, then the observation's.
EPISODE = (
    "D", "qfx", "qfy", "moves", "inv_l", "fx_l", "fy_l", "gx_l", "gy_l", "cx_l", "cy_l", "inv_moves",
    "left_scale", "elements", "is_ios", "is_ris", "transmit", "horizon", "peak_x_l", "peak_y_l", "peak_rate",
)  # fmt: skip
#: Columns of a row of ``info`` (``INFO_KEYS`` with ``position`` as x and y).
INFO = (
    "rate", "expected_rate", "position_x", "position_y", "distance_to_final", "slot", "reward_rate",
    "reward_reach", "reward_terminal", "average_rate", "mean_faded_rate", "feasible", "worst_violation",
    "terminal_miss",
)  # fmt: skip
#: Entries of the ``flags`` array: the env options the kernels need.
FLAGS = ("arrival_guard", "rician", "instance_features", "peak_hint", "reach_weight", "terminal_weight")


def flags_of(options: EnvOptions) -> np.ndarray:
    """The ``flags`` array of ``options`` (see :data:`FLAGS`)."""
    return np.array(
        [options.arrival_guard, options.channel == "rician", options.instance_features, options.peak_hint,
         options.reach_weight, options.terminal_weight], dtype=np.float64,
    )  # fmt: skip


def episode_row(config: ScenarioConfig, length_scale: float, peak: tuple[float, float, float]) -> np.ndarray:
    """The ``episode`` row of ``config`` (see :data:`EPISODE`); ``peak``: the peak hint (x, y, rate)."""
    inv_l, moves = 1.0 / length_scale, config.N - 1
    (fx, fy), (gx, gy), (cx, cy) = config.qF, config.ground_node, config.ios_center[:2]
    row = [config.D, fx, fy, moves, inv_l, fx * inv_l, fy * inv_l, gx * inv_l, gy * inv_l, cx * inv_l,
           cy * inv_l, 1.0 / moves, config.dt / T_SCALE, *instance_values(config), peak[0] * inv_l,
           peak[1] * inv_l, peak[2]]  # fmt: skip
    return np.array(row, dtype=np.float64)


@jit(inline=True)
def _observe(obs: np.ndarray, i: int, x: float, y: float, left: float, dist: float, rate: float,
             episode: np.ndarray, flags: np.ndarray) -> None:  # fmt: skip
    """Write observation row ``i`` (the layout of ``IOSUAVEnv``'s docstring)."""
    ep, obs = episode[i], obs[i]
    xl, yl = x * ep[4], y * ep[4]
    s = left - dist / ep[0]
    obs[0], obs[1] = xl, yl
    obs[2], obs[3], obs[4], obs[5], obs[6], obs[7] = (
        ep[5] - xl,
        ep[6] - yl,
        ep[7] - xl,
        ep[8] - yl,
        ep[9] - xl,
        ep[10] - yl,
    )
    obs[8], obs[9], obs[10] = left * ep[11], s / (1.0 + abs(s)), rate
    k = 11
    if flags[2] != 0.0:
        for j in range(5):
            obs[k + j] = ep[13 + j]
        obs[k + 5] = left * ep[12]
        k += 6
    if flags[3] != 0.0:
        obs[k], obs[k + 1], obs[k + 2] = ep[18] - xl, ep[19] - yl, ep[20]


@jit(inline=True)
def _info(info: np.ndarray, i: int, state: np.ndarray, episode: np.ndarray, rate: float, expected: float,
          dist: float, left: float, r_rate: float, r_reach: float, r_terminal: float) -> None:  # fmt: skip
    """Write ``info`` row ``i``: the step's terms and the running eq. (9) score and eq. (10) check."""
    info, state, ep = info[i], state[i], episode[i]
    points = state[2] + 1.0  # way-points so far
    deficit = max(0.0, dist - left * ep[0])  # how far qF is out of reach (m)
    worst = max(state[5], deficit)
    info[0], info[1], info[2], info[3], info[4] = rate, expected, state[0], state[1], dist
    info[5], info[6], info[7], info[8] = points, r_rate, r_reach, r_terminal
    info[9], info[10] = state[3] / points, state[4] / points
    info[11] = 1.0 if worst <= FEASIBILITY_TOL else 0.0
    info[12], info[13] = worst, deficit


@jit
def reset_rows(
    rows: np.ndarray, state: np.ndarray, episode: np.ndarray, nodes: np.ndarray, params: np.ndarray,
    normals: np.ndarray, flags: np.ndarray, obs: np.ndarray, info: np.ndarray,
) -> None:  # fmt: skip
    """Start the episodes of ``rows`` at the position already in ``state[:, 0:2]`` (q0)."""
    for i in rows:
        x, y, ep = state[i, 0], state[i, 1], episode[i]
        expected = rate_point(x, y, nodes[i], params[i])
        rate = (
            faded_point(x, y, normals[i, 0], normals[i, 1], nodes[i], params[i])
            if flags[1] != 0.0
            else expected
        )
        state[i, 2], state[i, 3], state[i, 4], state[i, 5] = 0.0, expected, rate, 0.0
        dist = math.hypot(ep[1] - x, ep[2] - y)
        _observe(obs, i, x, y, ep[3], dist, expected, episode, flags)
        _info(info, i, state, episode, rate, expected, dist, ep[3], 0.0, 0.0, 0.0)


@jit(inline=True)
def _move(i: int, actions: np.ndarray, state: np.ndarray, episode: np.ndarray, flags: np.ndarray,
          path: np.ndarray) -> tuple[float, float, float]:  # fmt: skip
    """Move row ``i`` (unit-disk projection, then the arrival guard); return (x, y, moves left)."""
    ep, st = episode[i], state[i]
    ax, ay = actions[i, 0], actions[i, 1]
    norm = math.hypot(ax, ay)  # no overflow for huge actions
    if norm > 1.0:
        ax, ay = ax / norm, ay / norm
    d, x0, y0 = ep[0], st[0], st[1]
    x, y = x0 + d * ax, y0 + d * ay
    n = st[2]
    left = ep[3] - n - 1.0  # moves left after this one
    if flags[0] != 0.0:
        x, y = guarded_position((x0, y0), (x, y), (ep[1], ep[2]), d, int(left))
    st[0], st[1], st[2] = x, y, n + 1.0
    st[5] = max(st[5], math.hypot(x - x0, y - y0) - d)
    path[i, int(n) + 1, 0], path[i, int(n) + 1, 1] = x, y
    return x, y, left


@jit(inline=True)
def penalties(dist: float, left: float, d: float, w_reach: float, w_terminal: float) -> tuple[float, float]:
    """The reach and terminal reward terms of a UAV ``dist`` m from qF with ``left`` moves of at
    most ``d`` m to go: -w_reach x the distance it can no longer cover (in moves), and at the
    last slot (``left == 0``) -w_terminal x (miss + sqrt(miss)), the miss in moves."""
    reach = max(0.0, dist - left * d - FEASIBILITY_TOL) / d
    r_reach = -w_reach * reach if reach > 0.0 else 0.0
    r_terminal = 0.0
    if left == 0.0:
        miss = max(0.0, dist - FEASIBILITY_TOL) / d
        if miss > 0.0:
            r_terminal = -w_terminal * (miss + math.sqrt(miss))
    return r_reach, r_terminal


@jit(inline=True)
def _settle(i: int, x: float, y: float, left: float, rate: float, expected: float, state: np.ndarray,
            episode: np.ndarray, flags: np.ndarray, obs: np.ndarray, reward: np.ndarray,
            terminated: np.ndarray, info: np.ndarray) -> None:  # fmt: skip
    """Row ``i`` after its move: the running sums, the reward terms, the observation, the info."""
    ep, st = episode[i], state[i]
    d = ep[0]
    st[3] += expected
    st[4] += rate
    dist = math.hypot(ep[1] - x, ep[2] - y)
    r_reach, r_terminal = penalties(dist, left, d, flags[4], flags[5])
    done = left == 0.0
    reward[i] = rate + r_reach + r_terminal
    terminated[i] = done
    _observe(obs, i, x, y, left, dist, expected, episode, flags)
    _info(info, i, state, episode, rate, expected, dist, left, rate, r_reach, r_terminal)


def _step_rows(
    actions: np.ndarray, state: np.ndarray, episode: np.ndarray, nodes: np.ndarray, params: np.ndarray,
    normals: np.ndarray, flags: np.ndarray, obs: np.ndarray, reward: np.ndarray, terminated: np.ndarray,
    info: np.ndarray, path: np.ndarray, active: np.ndarray,
) -> None:  # fmt: skip
    """One slot of every active row: move (unit-disk projection, then the arrival guard), rate
    (channel "rician": the faded rate from ``normals`` (B, 2)), reward, observation and info.
    ``actions`` (B, 2) must be finite (the caller checks); ``path`` (B, N_max, 2) receives each
    row's new way-point (at index ``moves made``)."""
    rician = flags[1] != 0.0
    for i in range(actions.shape[0]):
        if active[i]:
            x, y, left = _move(i, actions, state, episode, flags, path)
            expected = rate_point(x, y, nodes[i], params[i])
            rate = (
                faded_point(x, y, normals[i, 0], normals[i, 1], nodes[i], params[i]) if rician else expected
            )
            _settle(i, x, y, left, rate, expected, state, episode, flags, obs, reward, terminated, info)


#: :func:`_step_rows`, compiled (numba) when it is installed.
step_rows = jit(_step_rows)
