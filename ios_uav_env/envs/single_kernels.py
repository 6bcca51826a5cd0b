"""The env's transition as array kernels: one implementation for the single and the batched env.

A batch of B episodes is a few arrays (row i = episode i): ``state`` (:data:`STATE`: the core's
columns, the UAV position, moves made, excess, energy and last move, then the running sums),
``episode`` (:data:`EPISODE`: the core's constants of the episode's scenario, then those of its
observation), and the rate kernel's ``nodes`` / ``params`` (``ios_uav_env.model.channel.RateKernel``;
node arrays padded with zero weights). :func:`reset_rows` and :func:`step_rows` write the
observations, rewards and ``info`` columns (:data:`INFO`) of the rows they touch. ``IOSUAVEnv``
runs them on a batch of one, ``IOSUAVVectorEnv`` on B rows: the same physics
(``channel.rate_row``, ``faded_row``) and the row-step core that the node-block view's step runs
too (``ios_uav_env.envs.core.kernel``: the move through the arrival guard, the propulsion power,
the reward's reach, terminal and energy terms), compiled with numba when it is installed. What is
this view's own: the node's rate, the running rate sums and the v0 observation and ``info`` writers.

Every step flies its move at one constant speed over the slot and books its propulsion power
P(|move| / dt) (``core.kernel.move_row``), the energy so far and the bits per joule so far
(``info``'s ``power``, ``energy``, ``energy_efficiency``); the reward's energy term -(lambda_ref
/ B) P and the energy features of the observation are added only for the objective
``"energy_efficiency"`` (flag ``energy``). The kernels here are compiled with the fast-math flags
of ``ios_uav_env.jit`` (the node sums vectorise), which the inlined core takes on.

The kernels address every column by name, never by number: a module-level int per entry of
:data:`STATE`, :data:`EPISODE` and :data:`INFO`, named by a prefix and the entry upper-cased,
``ST_`` (``state[i, ST_MOVES_MADE]``), ``EP_`` (``episode[i, EP_INV_L]``) and ``INFO_``
(``info[i, INFO_RATE]``), the core's ``FLAG_`` (``flags[FLAG_ENERGY]``), and ``OBS_`` for the observation's
components (the names of ``observation_layout``: ``obs[i, OBS_X]``; a component of an appended block
at its offset in the block, ``obs[i, k + OBS_MOVE_X]`` with ``k`` where the block starts, ``N_*``
the blocks' lengths). Each is ``TUPLE.index("name")``: a plain int, which numba freezes into the
compiled code as a constant (the machine code of a literal index) and plain Python reads as any
global. A run of columns is its named first column plus an offset (``ep[i, EP_ELEMENTS + j]``).
``tests/envs/test_kernel_columns.py`` refuses a literal column index.
"""

from __future__ import annotations

import math

import numpy as np

from ios_uav_env.envs.core.kernel import (
    CORE_EPISODE,
    CORE_STATE,
    E_ENERGY_COST,
    E_ENERGY_WEIGHT,
    FLAG_ENERGY,
    FLAG_INSTANCE_FEATURES,
    FLAG_PEAK_HINT,
    FLAG_RICIAN,
    FLAGS,
    N_ENERGY,
    core_episode_values,
    fly_entry_out_of_range,
    move_row,
    observe_energy,
    reward_row,
    start_row,
    toward,
    violation,
)
from ios_uav_env.envs.observation import T_SCALE, instance_values
from ios_uav_env.envs.observation_layout import INSTANCE_NAMES, OBS_NAMES, PEAK_NAMES
from ios_uav_env.jit import jit, prange
from ios_uav_env.model.channel import faded_row, rate_row
from ios_uav_env.model.config import ScenarioConfig

__all__ = [
    "EPISODE", "FLAGS", "INFO", "STATE", "episode_row", "fly_rows", "reset_rows", "step_rows",
    "step_rows_batched",
]  # fmt: skip

#: Columns of a row of ``state``: the core's (``core.kernel.CORE_STATE``: the UAV position,
#: moves made, the step excess, the energy, the last move), then the running rate sums.
STATE = CORE_STATE + ("sum_expected", "sum_rate")
#: Columns of a row of ``episode``: the core's (``core.kernel.CORE_EPISODE``), then the
#: observation's constants.
EPISODE = CORE_EPISODE + (
    "fx_l", "fy_l", "gx_l", "gy_l", "cx_l", "cy_l", "inv_moves", "left_scale", "elements", "is_ios",
    "is_ris", "transmit", "horizon", "peak_x_l", "peak_y_l", "peak_rate",
)  # fmt: skip
#: Columns of a row of ``info`` (``INFO_KEYS`` with ``position`` as x and y).
INFO = (
    "rate", "expected_rate", "position_x", "position_y", "distance_to_final", "slot", "reward_rate",
    "reward_reach", "reward_terminal", "average_rate", "mean_faded_rate", "feasible", "worst_violation",
    "terminal_miss", "power", "energy", "energy_efficiency", "reward_energy",
)  # fmt: skip
# The entries of the ``flags`` array are the core's (``core.kernel.FLAGS``, ``core.kernel.flags_of``).


# The columns by name (see the module's docstring); the core's columns (``S_``, ``E_``) are the
# same columns under the core's names.
ST_X = STATE.index("x")
ST_Y = STATE.index("y")
ST_MOVES_MADE = STATE.index("moves_made")
ST_EXCESS = STATE.index("excess")
ST_ENERGY = STATE.index("energy")
ST_MOVE_X = STATE.index("move_x")
ST_MOVE_Y = STATE.index("move_y")
ST_SUM_EXPECTED = STATE.index("sum_expected")
ST_SUM_RATE = STATE.index("sum_rate")

EP_D = EPISODE.index("D")
EP_QFX = EPISODE.index("qfx")
EP_QFY = EPISODE.index("qfy")
EP_MOVES = EPISODE.index("moves")
EP_DT = EPISODE.index("dt")
EP_P_BLADE = EPISODE.index("p_blade")
EP_BLADE_K = EPISODE.index("blade_k")
EP_P_INDUCED = EPISODE.index("p_induced")
EP_INDUCED_K = EPISODE.index("induced_k")
EP_DRAG = EPISODE.index("drag")
EP_BUDGET = EPISODE.index("budget")
EP_ENERGY_COST = EPISODE.index("energy_cost")
EP_ENERGY_WEIGHT = EPISODE.index("energy_weight")
EP_MIN_POWER_MOVE = EPISODE.index("min_power_move")
EP_BITS_SCALE = EPISODE.index("bits_scale")
EP_INV_L = EPISODE.index("inv_l")
EP_FX_L = EPISODE.index("fx_l")
EP_FY_L = EPISODE.index("fy_l")
EP_GX_L = EPISODE.index("gx_l")
EP_GY_L = EPISODE.index("gy_l")
EP_CX_L = EPISODE.index("cx_l")
EP_CY_L = EPISODE.index("cy_l")
EP_INV_MOVES = EPISODE.index("inv_moves")
EP_LEFT_SCALE = EPISODE.index("left_scale")
EP_ELEMENTS = EPISODE.index("elements")
EP_IS_IOS = EPISODE.index("is_ios")
EP_IS_RIS = EPISODE.index("is_ris")
EP_TRANSMIT = EPISODE.index("transmit")
EP_HORIZON = EPISODE.index("horizon")
EP_PEAK_X_L = EPISODE.index("peak_x_l")
EP_PEAK_Y_L = EPISODE.index("peak_y_l")
EP_PEAK_RATE = EPISODE.index("peak_rate")
#: The instance values (``instance_values``: elements .. horizon), columns EP_ELEMENTS on, in the
#: order of the observation's instance block.
N_INSTANCE_VALUES = EP_HORIZON + 1 - EP_ELEMENTS

INFO_RATE = INFO.index("rate")
INFO_EXPECTED_RATE = INFO.index("expected_rate")
INFO_POSITION_X = INFO.index("position_x")
INFO_POSITION_Y = INFO.index("position_y")
INFO_DISTANCE_TO_FINAL = INFO.index("distance_to_final")
INFO_SLOT = INFO.index("slot")
INFO_REWARD_RATE = INFO.index("reward_rate")
INFO_REWARD_REACH = INFO.index("reward_reach")
INFO_REWARD_TERMINAL = INFO.index("reward_terminal")
INFO_AVERAGE_RATE = INFO.index("average_rate")
INFO_MEAN_FADED_RATE = INFO.index("mean_faded_rate")
INFO_FEASIBLE = INFO.index("feasible")
INFO_WORST_VIOLATION = INFO.index("worst_violation")
INFO_TERMINAL_MISS = INFO.index("terminal_miss")
INFO_POWER = INFO.index("power")
INFO_ENERGY = INFO.index("energy")
INFO_ENERGY_EFFICIENCY = INFO.index("energy_efficiency")
INFO_REWARD_ENERGY = INFO.index("reward_energy")

# The observation's columns: the base block (OBS_NAMES) from 0, then the blocks that the flags
# append (instance, energy, peak; ``observation_layout.observation_names``), each at its offset
# in its block (the energy block: ``core.kernel.observe_energy``).
OBS_X = OBS_NAMES.index("x")
OBS_Y = OBS_NAMES.index("y")
OBS_DX_FINAL = OBS_NAMES.index("dx_final")
OBS_DY_FINAL = OBS_NAMES.index("dy_final")
OBS_DX_GROUND = OBS_NAMES.index("dx_ground")
OBS_DY_GROUND = OBS_NAMES.index("dy_ground")
OBS_DX_IOS = OBS_NAMES.index("dx_ios")
OBS_DY_IOS = OBS_NAMES.index("dy_ios")
OBS_TIME_LEFT = OBS_NAMES.index("time_left")
OBS_SLACK = OBS_NAMES.index("slack")
OBS_RATE = OBS_NAMES.index("rate")
N_OBS = len(OBS_NAMES)
OBS_ELEMENTS = INSTANCE_NAMES.index("elements")
OBS_SECONDS_LEFT = INSTANCE_NAMES.index("seconds_left")
N_INSTANCE = len(INSTANCE_NAMES)
OBS_DX_PEAK = PEAK_NAMES.index("dx_peak")
OBS_DY_PEAK = PEAK_NAMES.index("dy_peak")
OBS_RATE_PEAK = PEAK_NAMES.index("rate_peak")


def episode_row(
    config: ScenarioConfig, length_scale: float, peak: tuple[float, float, float], reference: float = 0.0
) -> np.ndarray:
    """The ``episode`` row of ``config`` (see :data:`EPISODE`); ``peak``: the peak hint (x, y, rate);
    ``reference``: lambda_ref (bits/J) of the energy reward (0 for the rate objective)."""
    inv_l, moves = 1.0 / length_scale, config.N - 1
    (fx, fy), (gx, gy), (cx, cy) = config.qF, config.ground_node, config.ios_center[:2]
    row = core_episode_values(config, length_scale)
    cost = reference / config.bandwidth_hz  # bps/Hz per W
    row[E_ENERGY_COST], row[E_ENERGY_WEIGHT] = cost, cost * config.propulsion.hover_power
    row += [fx * inv_l, fy * inv_l, gx * inv_l, gy * inv_l, cx * inv_l, cy * inv_l, 1.0 / moves,
            config.dt / T_SCALE, *instance_values(config), peak[0] * inv_l, peak[1] * inv_l,
            peak[2]]  # fmt: skip
    return np.array(row, dtype=np.float64)


# The kernels index the 2-D arrays in place (``episode[i, EP_INV_L]``), never through row views
# (``episode[i]``): in compiled code every view costs a reference count, more than the row's
# arithmetic.


@jit(inline=True)
def _observe(obs: np.ndarray, i: int, x: float, y: float, left: float, dist: float, rate: float,
             st: np.ndarray, ep: np.ndarray, flags: np.ndarray) -> None:  # fmt: skip
    """Write observation row ``i`` (the layout of ``IOSUAVEnv``'s docstring); ``st``: ``state``,
    ``ep``: ``episode``."""
    inv_l = ep[i, EP_INV_L]
    xl, yl = x * inv_l, y * inv_l
    s = left - dist / ep[i, EP_D]
    obs[i, OBS_X], obs[i, OBS_Y] = xl, yl
    obs[i, OBS_DX_FINAL], obs[i, OBS_DY_FINAL] = ep[i, EP_FX_L] - xl, ep[i, EP_FY_L] - yl
    obs[i, OBS_DX_GROUND], obs[i, OBS_DY_GROUND] = ep[i, EP_GX_L] - xl, ep[i, EP_GY_L] - yl
    obs[i, OBS_DX_IOS], obs[i, OBS_DY_IOS] = ep[i, EP_CX_L] - xl, ep[i, EP_CY_L] - yl
    obs[i, OBS_TIME_LEFT] = left * ep[i, EP_INV_MOVES]
    obs[i, OBS_SLACK], obs[i, OBS_RATE] = s / (1.0 + abs(s)), rate
    k = N_OBS  # where the next block starts
    if flags[FLAG_INSTANCE_FEATURES] != 0.0:
        for j in range(N_INSTANCE_VALUES):
            obs[i, k + OBS_ELEMENTS + j] = ep[i, EP_ELEMENTS + j]
        obs[i, k + OBS_SECONDS_LEFT] = left * ep[i, EP_LEFT_SCALE]
        k += N_INSTANCE
    if flags[FLAG_ENERGY] != 0.0:
        observe_energy(obs, i, k, st, ep)
        k += N_ENERGY
    if flags[FLAG_PEAK_HINT] != 0.0:
        obs[i, k + OBS_DX_PEAK], obs[i, k + OBS_DY_PEAK] = ep[i, EP_PEAK_X_L] - xl, ep[i, EP_PEAK_Y_L] - yl
        obs[i, k + OBS_RATE_PEAK] = ep[i, EP_PEAK_RATE]


@jit(inline=True)
def _info(info: np.ndarray, i: int, st: np.ndarray, ep: np.ndarray, rate: float, expected: float,
          dist: float, left: float, r_rate: float, r_reach: float, r_terminal: float, power: float,
          r_energy: float) -> None:  # fmt: skip
    """Write ``info`` row ``i``: the step's terms and the running eq. (9) score and eq. (10)
    check (``st``: ``state``, ``ep``: ``episode``; ``core.kernel.violation``), the move's power,
    the energy so far and the bits per joule so far, B dt sum_n r(q[n]) / E (0 before the first
    move)."""
    points = st[i, ST_MOVES_MADE] + 1.0  # way-points so far
    deficit, worst, feasible = violation(i, dist, left, st, ep)
    energy = st[i, ST_ENERGY]
    info[i, INFO_RATE], info[i, INFO_EXPECTED_RATE] = rate, expected
    info[i, INFO_POSITION_X], info[i, INFO_POSITION_Y] = st[i, ST_X], st[i, ST_Y]
    info[i, INFO_DISTANCE_TO_FINAL], info[i, INFO_SLOT] = dist, points
    info[i, INFO_REWARD_RATE], info[i, INFO_REWARD_REACH] = r_rate, r_reach
    info[i, INFO_REWARD_TERMINAL] = r_terminal
    info[i, INFO_AVERAGE_RATE] = st[i, ST_SUM_EXPECTED] / points
    info[i, INFO_MEAN_FADED_RATE] = st[i, ST_SUM_RATE] / points
    info[i, INFO_FEASIBLE] = 1.0 if feasible else 0.0
    info[i, INFO_WORST_VIOLATION], info[i, INFO_TERMINAL_MISS] = worst, deficit
    info[i, INFO_POWER], info[i, INFO_ENERGY], info[i, INFO_REWARD_ENERGY] = power, energy, r_energy
    info[i, INFO_ENERGY_EFFICIENCY] = (
        ep[i, EP_BITS_SCALE] * st[i, ST_SUM_EXPECTED] / energy if energy > 0.0 else 0.0
    )


@jit
def reset_rows(
    rows: np.ndarray, state: np.ndarray, episode: np.ndarray, nodes: np.ndarray, params: np.ndarray,
    normals: np.ndarray, flags: np.ndarray, obs: np.ndarray, info: np.ndarray,
) -> None:  # fmt: skip
    """Start the episodes of ``rows`` at the position already in ``state``'s ``x``, ``y`` (q0)."""
    for i in rows:
        x, y = state[i, ST_X], state[i, ST_Y]
        expected = rate_row(x, y, nodes, params, i)
        rate = expected
        if flags[FLAG_RICIAN] != 0.0:
            rate = faded_row(x, y, normals[i, 0], normals[i, 1], nodes, params, i)
        start_row(i, state)
        state[i, ST_SUM_EXPECTED], state[i, ST_SUM_RATE] = expected, rate
        dist = math.hypot(episode[i, EP_QFX] - x, episode[i, EP_QFY] - y)
        moves = episode[i, EP_MOVES]
        _observe(obs, i, x, y, moves, dist, expected, state, episode, flags)
        _info(info, i, state, episode, rate, expected, dist, moves, 0.0, 0.0, 0.0, 0.0, 0.0)


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
        if active[i] and (
            state[i, ST_MOVES_MADE] >= episode[i, EP_MOVES] or state[i, ST_MOVES_MADE] + 1.0 >= path.shape[1]
        ):
            return i
    return -1


@jit(inline=True)
def _step_row(
    i: int, actions: np.ndarray, state: np.ndarray, episode: np.ndarray, nodes: np.ndarray,
    params: np.ndarray, normals: np.ndarray, flags: np.ndarray, obs: np.ndarray, reward: np.ndarray,
    terminated: np.ndarray, info: np.ndarray, path: np.ndarray,
) -> None:  # fmt: skip
    """One slot of row ``i``: the core's move (``core.kernel.move_row``: unit-disk projection,
    arrival guard, power), the rate (channel "rician": the faded rate from ``normals`` (B, 2)), the
    running sums, the core's reward (``core.kernel.reward_row``), observation and info. ``path``
    (B, N_max, 2) receives the new way-point (at index ``moves made``)."""
    ax, ay = actions[i, 0], actions[i, 1]
    x, y, left, power = move_row(i, ax, ay, math.hypot(ax, ay), state, episode, flags, path)
    expected = rate_row(x, y, nodes, params, i)
    rate = expected
    if flags[FLAG_RICIAN] != 0.0:
        rate = faded_row(x, y, normals[i, 0], normals[i, 1], nodes, params, i)
    state[i, ST_SUM_EXPECTED] += expected
    state[i, ST_SUM_RATE] += rate
    dist = math.hypot(episode[i, EP_QFX] - x, episode[i, EP_QFY] - y)
    r_reach, r_terminal, r_energy = reward_row(i, rate, dist, left, power, episode, flags, reward, terminated)
    _observe(obs, i, x, y, left, dist, expected, state, episode, flags)
    _info(info, i, state, episode, rate, expected, dist, left, rate, r_reach, r_terminal, power, r_energy)


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
