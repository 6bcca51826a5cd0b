"""The env's transition as array kernels: one implementation for the single and the batched env.

A batch of B episodes is a few arrays (row i = episode i): ``state`` (:data:`STATE`: the UAV
position, moves made, the running sums), ``episode`` (:data:`EPISODE`: the constants of the
episode's scenario and of its observation), and the rate kernel's ``nodes`` / ``params``
(``ios_uav_env.model.channel.RateKernel``; node arrays padded with zero weights). :func:`reset_rows`
and :func:`step_rows` write the observations, rewards and ``info`` columns (:data:`INFO`) of
the rows they touch. ``IOSUAVEnv`` runs them on a batch of one, ``IOSUAVVectorEnv`` on B rows:
the same physics (``channel.rate_row``, ``faded_row``), the same arrival guard
(``guard.guarded_position``) and the same reward, compiled with numba when it is installed.

Every step also flies its move at one constant speed over the slot and books its propulsion
power P(|move| / dt) (:func:`move_power`: eq. (12) of the propulsion model, inlined from the
``episode`` row's constants in the cancellation-free form of ``model.propulsion``), the energy
so far and the bits per joule so far (``info``'s ``power``, ``energy``, ``energy_efficiency``);
the reward's energy term -(lambda_ref / B) P and the energy features of the observation are
added only for the objective ``"energy_efficiency"`` (flag ``energy``).
"""

from __future__ import annotations

import math

import numpy as np

from ios_uav_env.envs.observation import T_SCALE, instance_values, min_power_move
from ios_uav_env.envs.options import EnvOptions
from ios_uav_env.jit import jit, prange
from ios_uav_env.model.channel import faded_row, rate_row
from ios_uav_env.model.config import ENERGY_RTOL, FEASIBILITY_TOL, ScenarioConfig
from ios_uav_env.model.guard import guarded_position

#: Columns of a row of ``state``.
STATE = ("x", "y", "moves_made", "sum_expected", "sum_rate", "excess", "energy", "move_x", "move_y")
#: Columns of a row of ``episode``: the scenario's constants, then the observation's.
EPISODE = (
    "D", "qfx", "qfy", "moves", "inv_l", "fx_l", "fy_l", "gx_l", "gy_l", "cx_l", "cy_l", "inv_moves",
    "left_scale", "elements", "is_ios", "is_ris", "transmit", "horizon", "peak_x_l", "peak_y_l", "peak_rate",
    "dt", "p_blade", "blade_k", "p_induced", "induced_k", "drag", "bits_scale", "energy_cost",
    "energy_weight", "min_power_move", "budget",
)  # fmt: skip
#: Columns of a row of ``info`` (``INFO_KEYS`` with ``position`` as x and y).
INFO = (
    "rate", "expected_rate", "position_x", "position_y", "distance_to_final", "slot", "reward_rate",
    "reward_reach", "reward_terminal", "average_rate", "mean_faded_rate", "feasible", "worst_violation",
    "terminal_miss", "power", "energy", "energy_efficiency", "reward_energy",
)  # fmt: skip
#: Entries of the ``flags`` array: the env options the kernels need (``energy``: the objective
#: is the energy efficiency; its reward term and observation features are on).
FLAGS = (
    "arrival_guard",
    "rician",
    "instance_features",
    "peak_hint",
    "reach_weight",
    "terminal_weight",
    "energy",
)


def flags_of(options: EnvOptions, energy: bool = False) -> np.ndarray:
    """The ``flags`` array of ``options`` (see :data:`FLAGS`); ``energy``: the scenario's objective
    is ``"energy_efficiency"``."""
    return np.array(
        [options.arrival_guard, options.channel == "rician", options.instance_features, options.peak_hint,
         options.reach_weight, options.terminal_weight, energy], dtype=np.float64,
    )  # fmt: skip


def budget_of(config: ScenarioConfig) -> float:
    """``config.energy_budget_j`` (J), inf without a budget: the ``budget`` column of the kernels."""
    return math.inf if config.energy_budget_j is None else float(config.energy_budget_j)


def episode_row(
    config: ScenarioConfig, length_scale: float, peak: tuple[float, float, float], reference: float = 0.0
) -> np.ndarray:
    """The ``episode`` row of ``config`` (see :data:`EPISODE`); ``peak``: the peak hint (x, y, rate);
    ``reference``: lambda_ref (bits/J) of the energy reward (0 for the rate objective). Its last
    column is the energy budget (:func:`budget_of`)."""
    inv_l, moves = 1.0 / length_scale, config.N - 1
    (fx, fy), (gx, gy), (cx, cy) = config.qF, config.ground_node, config.ios_center[:2]
    m = config.propulsion
    cost = reference / config.bandwidth_hz  # bps/Hz per W
    row = [config.D, fx, fy, moves, inv_l, fx * inv_l, fy * inv_l, gx * inv_l, gy * inv_l, cx * inv_l,
           cy * inv_l, 1.0 / moves, config.dt / T_SCALE, *instance_values(config), peak[0] * inv_l,
           peak[1] * inv_l, peak[2], config.dt, m.P0, 3.0 / m.U_tip**2, m.P_i, 1.0 / (2.0 * m.v0**2),
           m.drag_coefficient, config.bandwidth_hz * config.dt, cost, cost * m.hover_power,
           min_power_move(config), budget_of(config)]  # fmt: skip
    return np.array(row, dtype=np.float64)


# The kernels index the 2-D arrays in place (``episode[i, 4]``), never through row views
# (``episode[i]``): in compiled code every view costs a reference count, more than the row's
# arithmetic.


@jit(inline=True)
def _observe(obs: np.ndarray, i: int, x: float, y: float, left: float, dist: float, rate: float,
             ep: np.ndarray, flags: np.ndarray, mx: float, my: float) -> None:  # fmt: skip
    """Write observation row ``i`` (the layout of ``IOSUAVEnv``'s docstring); ``ep``: ``episode``,
    (``mx``, ``my``): the last move / D."""
    inv_l = ep[i, 4]
    xl, yl = x * inv_l, y * inv_l
    s = left - dist / ep[i, 0]
    obs[i, 0], obs[i, 1] = xl, yl
    obs[i, 2], obs[i, 3], obs[i, 4], obs[i, 5] = ep[i, 5] - xl, ep[i, 6] - yl, ep[i, 7] - xl, ep[i, 8] - yl
    obs[i, 6], obs[i, 7] = ep[i, 9] - xl, ep[i, 10] - yl
    obs[i, 8], obs[i, 9], obs[i, 10] = left * ep[i, 11], s / (1.0 + abs(s)), rate
    k = 11
    if flags[2] != 0.0:
        for j in range(5):
            obs[i, k + j] = ep[i, 13 + j]
        obs[i, k + 5] = left * ep[i, 12]
        k += 6
    if flags[6] != 0.0:
        obs[i, k], obs[i, k + 1], obs[i, k + 2], obs[i, k + 3] = mx, my, ep[i, 29], ep[i, 30]
        k += 4
    if flags[3] != 0.0:
        obs[i, k], obs[i, k + 1], obs[i, k + 2] = ep[i, 18] - xl, ep[i, 19] - yl, ep[i, 20]


@jit(inline=True)
def _info(info: np.ndarray, i: int, st: np.ndarray, ep: np.ndarray, rate: float, expected: float,
          dist: float, left: float, r_rate: float, r_reach: float, r_terminal: float, power: float,
          r_energy: float) -> None:  # fmt: skip
    """Write ``info`` row ``i``: the step's terms and the running eq. (9) score and eq. (10)
    check (``st``: ``state``, ``ep``: ``episode``; with an energy budget, feasible also asks
    E <= E_max (1 + ENERGY_RTOL) of the energy so far, as ``check_trajectory``), the move's power,
    the energy so far and the bits per joule so far, B dt sum_n r(q[n]) / E (0 before the first
    move)."""
    points = st[i, 2] + 1.0  # way-points so far
    deficit = max(0.0, dist - left * ep[i, 0])  # how far qF is out of reach (m)
    worst = max(st[i, 5], deficit)
    energy = st[i, 6]
    info[i, 0], info[i, 1], info[i, 2], info[i, 3], info[i, 4] = rate, expected, st[i, 0], st[i, 1], dist
    info[i, 5], info[i, 6], info[i, 7], info[i, 8] = points, r_rate, r_reach, r_terminal
    info[i, 9], info[i, 10] = st[i, 3] / points, st[i, 4] / points
    within = energy <= ep[i, 31] * (1.0 + ENERGY_RTOL)
    info[i, 11] = 1.0 if worst <= FEASIBILITY_TOL and within else 0.0
    info[i, 12], info[i, 13] = worst, deficit
    info[i, 14], info[i, 15], info[i, 17] = power, energy, r_energy
    info[i, 16] = ep[i, 27] * st[i, 3] / energy if energy > 0.0 else 0.0


@jit
def reset_rows(
    rows: np.ndarray, state: np.ndarray, episode: np.ndarray, nodes: np.ndarray, params: np.ndarray,
    normals: np.ndarray, flags: np.ndarray, obs: np.ndarray, info: np.ndarray,
) -> None:  # fmt: skip
    """Start the episodes of ``rows`` at the position already in ``state[:, 0:2]`` (q0)."""
    for i in rows:
        x, y = state[i, 0], state[i, 1]
        expected = rate_row(x, y, nodes, params, i)
        rate = expected
        if flags[1] != 0.0:
            rate = faded_row(x, y, normals[i, 0], normals[i, 1], nodes, params, i)
        state[i, 2], state[i, 3], state[i, 4], state[i, 5] = 0.0, expected, rate, 0.0
        state[i, 6], state[i, 7], state[i, 8] = 0.0, 0.0, 0.0
        dist = math.hypot(episode[i, 1] - x, episode[i, 2] - y)
        _observe(obs, i, x, y, episode[i, 3], dist, expected, episode, flags, 0.0, 0.0)
        _info(info, i, state, episode, rate, expected, dist, episode[i, 3], 0.0, 0.0, 0.0, 0.0, 0.0)


@jit(inline=True)
def slot_power(
    length: float, dt: float, p_blade: float, blade_k: float, p_induced: float, induced_k: float, drag: float
) -> float:
    """P(V) (W) of a move of ``length`` m flown over a slot of ``dt`` s, V = length / dt: eq. (12)
    (``ios_uav_env.propulsion_power``, inlined) with the constants of an ``episode`` row's
    ``p_blade, blade_k, p_induced, induced_k, drag`` columns (both kernels' rows hold them)."""
    v = length / dt
    v2 = v * v
    x = v2 * induced_k
    return p_blade * (1.0 + blade_k * v2) + p_induced / math.sqrt(math.sqrt(1.0 + x * x) + x) + drag * v2 * v


@jit(inline=True)
def move_power(length: float, ep: np.ndarray, i: int) -> float:
    """:func:`slot_power` with row ``i``'s constants."""
    return slot_power(length, ep[i, 21], ep[i, 22], ep[i, 23], ep[i, 24], ep[i, 25], ep[i, 26])


@jit(inline=True)
def _move(i: int, actions: np.ndarray, st: np.ndarray, ep: np.ndarray, flags: np.ndarray,
          path: np.ndarray) -> tuple[float, float, float, float]:  # fmt: skip
    """Move row ``i`` (unit-disk projection, then the arrival guard) and book the move's energy;
    return (x, y, moves left, the move's power P in W)."""
    ax, ay = actions[i, 0], actions[i, 1]
    norm = math.hypot(ax, ay)  # no overflow for huge actions
    if norm > 1.0:
        ax, ay = ax / norm, ay / norm
    d, x0, y0 = ep[i, 0], st[i, 0], st[i, 1]
    x, y = x0 + d * ax, y0 + d * ay
    n = st[i, 2]
    left = ep[i, 3] - n - 1.0  # moves left after this one
    if flags[0] != 0.0:
        x, y = guarded_position((x0, y0), (x, y), (ep[i, 1], ep[i, 2]), d, int(left))
    st[i, 0], st[i, 1], st[i, 2] = x, y, n + 1.0
    length = math.hypot(x - x0, y - y0)
    st[i, 5] = max(st[i, 5], length - d)
    power = move_power(length, ep, i)
    st[i, 6] += ep[i, 21] * power
    st[i, 7], st[i, 8] = (x - x0) / d, (y - y0) / d
    path[i, int(n) + 1, 0], path[i, int(n) + 1, 1] = x, y
    return x, y, left, power


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
def _settle(i: int, x: float, y: float, left: float, rate: float, expected: float, power: float,
            st: np.ndarray, ep: np.ndarray, flags: np.ndarray, obs: np.ndarray, reward: np.ndarray,
            terminated: np.ndarray, info: np.ndarray) -> None:  # fmt: skip
    """Row ``i`` after its move (of ``power`` W): the running sums, the reward terms, the
    observation, the info."""
    st[i, 3] += expected
    st[i, 4] += rate
    dist = math.hypot(ep[i, 1] - x, ep[i, 2] - y)
    r_reach, r_terminal = penalties(dist, left, ep[i, 0], flags[4], flags[5])
    r_energy = 0.0
    if flags[6] != 0.0:
        r_energy = -ep[i, 28] * power
        reward[i] = rate + r_energy + r_reach + r_terminal
    else:
        reward[i] = rate + r_reach + r_terminal
    terminated[i] = left == 0.0
    _observe(obs, i, x, y, left, dist, expected, ep, flags, st[i, 7], st[i, 8])
    _info(info, i, st, ep, rate, expected, dist, left, rate, r_reach, r_terminal, power, r_energy)


@jit(inline=True)
def _finite_actions(actions: np.ndarray, active: np.ndarray) -> int:
    """-1 if every active row's action is finite, else the first row whose action is not."""
    for i in range(actions.shape[0]):
        if active[i] and not (math.isfinite(actions[i, 0]) and math.isfinite(actions[i, 1])):
            return i
    return -1


@jit(inline=True)
def _ended_row(active: np.ndarray, state: np.ndarray, episode: np.ndarray, path: np.ndarray) -> int:
    """-1 if every active row has a move left (and room in ``path``), else the first that has not."""
    for i in range(active.shape[0]):
        if active[i] and (state[i, 2] >= episode[i, 3] or state[i, 2] + 1.0 >= path.shape[1]):
            return i
    return -1


@jit(inline=True)
def _step_row(
    i: int, actions: np.ndarray, state: np.ndarray, episode: np.ndarray, nodes: np.ndarray,
    params: np.ndarray, normals: np.ndarray, flags: np.ndarray, obs: np.ndarray, reward: np.ndarray,
    terminated: np.ndarray, info: np.ndarray, path: np.ndarray,
) -> None:  # fmt: skip
    """One slot of row ``i``: move (unit-disk projection, then the arrival guard), rate (channel
    "rician": the faded rate from ``normals`` (B, 2)), reward, observation and info. ``path``
    (B, N_max, 2) receives the new way-point (at index ``moves made``)."""
    x, y, left, power = _move(i, actions, state, episode, flags, path)
    expected = rate_row(x, y, nodes, params, i)
    rate = expected
    if flags[1] != 0.0:
        rate = faded_row(x, y, normals[i, 0], normals[i, 1], nodes, params, i)
    _settle(i, x, y, left, rate, expected, power, state, episode, flags, obs, reward, terminated, info)


@jit
def step_rows(
    actions: np.ndarray, state: np.ndarray, episode: np.ndarray, nodes: np.ndarray, params: np.ndarray,
    normals: np.ndarray, flags: np.ndarray, obs: np.ndarray, reward: np.ndarray, terminated: np.ndarray,
    info: np.ndarray, path: np.ndarray, active: np.ndarray,
) -> int:  # fmt: skip
    """One slot of every active row (:func:`_step_row`), one after the other: the single env's
    step (one row). Returns -1, or, stepping nothing, the first active row whose action is not
    finite, or else ``B`` + the first active row whose episode is over (nothing is ever written
    past a row's slot N: the envs check first)."""
    bad = _finite_actions(actions, active)
    if bad < 0:
        ended = _ended_row(active, state, episode, path)
        bad = -1 if ended < 0 else actions.shape[0] + ended
    if bad < 0:
        for i in range(actions.shape[0]):
            if active[i]:
                _step_row(i, actions, state, episode, nodes, params, normals, flags, obs, reward, terminated,
                          info, path)  # fmt: skip
    return bad


@jit(parallel=True)
def step_rows_batched(
    actions: np.ndarray, state: np.ndarray, episode: np.ndarray, nodes: np.ndarray, params: np.ndarray,
    normals: np.ndarray, flags: np.ndarray, obs: np.ndarray, reward: np.ndarray, terminated: np.ndarray,
    info: np.ndarray, path: np.ndarray, active: np.ndarray,
) -> int:  # fmt: skip
    """:func:`step_rows` for batches: the rows in parallel on numba's threads
    (``IOSUAVVectorEnv(num_threads=...)``). The loop body is compiled apart, without the
    reference counting that the inlined helpers cost in :func:`step_rows`. (Two functions, not
    one compiled twice: numba's disk cache keys a function by its name, not by its options.)"""
    bad = _finite_actions(actions, active)
    if bad < 0:
        ended = _ended_row(active, state, episode, path)
        bad = -1 if ended < 0 else actions.shape[0] + ended
    if bad < 0:
        for i in prange(actions.shape[0]):  # rows are independent
            if active[i]:
                _step_row(i, actions, state, episode, nodes, params, normals, flags, obs, reward, terminated,
                          info, path)  # fmt: skip
    return bad


@jit(inline=True, fastmath=False)
def fly_entry_out_of_range(rows: np.ndarray, targets: np.ndarray, moves: np.ndarray, state: np.ndarray,
                           episode: np.ndarray, path_length: int) -> int:  # fmt: skip
    """-1 if every entry of a flight (``fly_rows``) may fly, else the first that may not: a row
    outside 0..B-1, a move count < 0, or a row whose moves (summed over its entries) would finish
    its episode or pass ``path_length``; 0 if ``targets`` or ``moves`` are shorter than ``rows``."""
    if targets.shape[0] < rows.size or moves.size < rows.size:
        return 0
    planned = np.zeros(state.shape[0])
    for r in range(rows.size):
        i = rows[r]
        if i < 0 or i >= state.shape[0] or moves[r] < 0:
            return r
        planned[i] += moves[r]
        end = state[i, 2] + planned[i]  # moves made after this entry
        if end >= episode[i, 3] or end >= path_length:
            return r
    return -1


@jit(inline=True, fastmath=False)
def toward(i: int, tx: float, ty: float, state: np.ndarray, episode: np.ndarray, actions: np.ndarray) -> None:
    """Row ``i``'s move towards (``tx``, ``ty``) m into ``actions[i, :2]``: full speed (``D`` =
    ``episode[i, 0]``), or the rest of the way once within D (``policies.full_speed_move``)."""
    d = episode[i, 0]
    mx, my = (tx - state[i, 0]) / d, (ty - state[i, 1]) / d
    length = math.hypot(mx, my)
    if length > 1.0:
        mx, my = mx / length, my / length
    actions[i, 0], actions[i, 1] = mx, my


@jit(fastmath=False)
def fly_rows(
    rows: np.ndarray, targets: np.ndarray, moves: np.ndarray, actions: np.ndarray, state: np.ndarray,
    episode: np.ndarray, nodes: np.ndarray, params: np.ndarray, normals: np.ndarray, flags: np.ndarray,
    obs: np.ndarray, reward: np.ndarray, terminated: np.ndarray, info: np.ndarray, path: np.ndarray,
) -> int:  # fmt: skip
    """``moves[r]`` slots of row ``rows[r]``, each a full-speed move towards ``targets[r]`` (the rest
    of the way once within D; the arrival guard as always): the steps of :func:`step_rows` with
    those actions (``actions``: (B, 2) scratch; the expected rate: no fading draws); a row given
    more than once flies its entries in order. Returns -1, or, flying nothing, the first entry
    ``r`` that is out of range: a row outside 0..B-1, a move count < 0, or a row whose moves
    (summed over its entries) would finish its episode or pass the end of ``path``."""
    bad = fly_entry_out_of_range(rows, targets, moves, state, episode, path.shape[1])
    if bad >= 0:
        return bad
    for r in range(rows.size):
        i = rows[r]
        for _ in range(moves[r]):
            toward(i, targets[r, 0], targets[r, 1], state, episode, actions)
            _step_row(i, actions, state, episode, nodes, params, normals, flags, obs, reward, terminated,
                      info, path)  # fmt: skip
    return -1
