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

The kernels address every column by name, never by number: a module-level int per entry of
:data:`STATE`, :data:`EPISODE`, :data:`INFO` and :data:`FLAGS`, named by a prefix and the entry
upper-cased, ``ST_`` (``state[i, ST_MOVES_MADE]``), ``EP_`` (``episode[i, EP_INV_L]``), ``INFO_``
(``info[i, INFO_RATE]``) and ``FLAG_`` (``flags[FLAG_ENERGY]``), and ``OBS_`` for the observation's
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

from ios_uav_env.envs.observation import T_SCALE, instance_values, min_power_move
from ios_uav_env.envs.observation_layout import ENERGY_NAMES, INSTANCE_NAMES, OBS_NAMES, PEAK_NAMES
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


# The columns by name (see the module's docstring).
ST_X = STATE.index("x")
ST_Y = STATE.index("y")
ST_MOVES_MADE = STATE.index("moves_made")
ST_SUM_EXPECTED = STATE.index("sum_expected")
ST_SUM_RATE = STATE.index("sum_rate")
ST_EXCESS = STATE.index("excess")
ST_ENERGY = STATE.index("energy")
ST_MOVE_X = STATE.index("move_x")
ST_MOVE_Y = STATE.index("move_y")

EP_D = EPISODE.index("D")
EP_QFX = EPISODE.index("qfx")
EP_QFY = EPISODE.index("qfy")
EP_MOVES = EPISODE.index("moves")
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
EP_DT = EPISODE.index("dt")
EP_P_BLADE = EPISODE.index("p_blade")
EP_BLADE_K = EPISODE.index("blade_k")
EP_P_INDUCED = EPISODE.index("p_induced")
EP_INDUCED_K = EPISODE.index("induced_k")
EP_DRAG = EPISODE.index("drag")
EP_BITS_SCALE = EPISODE.index("bits_scale")
EP_ENERGY_COST = EPISODE.index("energy_cost")
EP_ENERGY_WEIGHT = EPISODE.index("energy_weight")
EP_MIN_POWER_MOVE = EPISODE.index("min_power_move")
EP_BUDGET = EPISODE.index("budget")
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

FLAG_ARRIVAL_GUARD = FLAGS.index("arrival_guard")
FLAG_RICIAN = FLAGS.index("rician")
FLAG_INSTANCE_FEATURES = FLAGS.index("instance_features")
FLAG_PEAK_HINT = FLAGS.index("peak_hint")
FLAG_REACH_WEIGHT = FLAGS.index("reach_weight")
FLAG_TERMINAL_WEIGHT = FLAGS.index("terminal_weight")
FLAG_ENERGY = FLAGS.index("energy")

# The observation's columns: the base block (OBS_NAMES) from 0, then the blocks that the flags
# append (instance, energy, peak; ``observation_layout.observation_names``), each at its offset
# in its block.
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
OBS_MOVE_X = ENERGY_NAMES.index("move_x")
OBS_MOVE_Y = ENERGY_NAMES.index("move_y")
OBS_ENERGY_WEIGHT = ENERGY_NAMES.index("energy_weight")
OBS_MIN_POWER_MOVE = ENERGY_NAMES.index("min_power_move")
N_ENERGY = len(ENERGY_NAMES)
OBS_DX_PEAK = PEAK_NAMES.index("dx_peak")
OBS_DY_PEAK = PEAK_NAMES.index("dy_peak")
OBS_RATE_PEAK = PEAK_NAMES.index("rate_peak")


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


# The kernels index the 2-D arrays in place (``episode[i, EP_INV_L]``), never through row views
# (``episode[i]``): in compiled code every view costs a reference count, more than the row's
# arithmetic.


@jit(inline=True)
def _observe(obs: np.ndarray, i: int, x: float, y: float, left: float, dist: float, rate: float,
             ep: np.ndarray, flags: np.ndarray, mx: float, my: float) -> None:  # fmt: skip
    """Write observation row ``i`` (the layout of ``IOSUAVEnv``'s docstring); ``ep``: ``episode``,
    (``mx``, ``my``): the last move / D."""
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
        obs[i, k + OBS_MOVE_X], obs[i, k + OBS_MOVE_Y] = mx, my
        obs[i, k + OBS_ENERGY_WEIGHT] = ep[i, EP_ENERGY_WEIGHT]
        obs[i, k + OBS_MIN_POWER_MOVE] = ep[i, EP_MIN_POWER_MOVE]
        k += N_ENERGY
    if flags[FLAG_PEAK_HINT] != 0.0:
        obs[i, k + OBS_DX_PEAK], obs[i, k + OBS_DY_PEAK] = ep[i, EP_PEAK_X_L] - xl, ep[i, EP_PEAK_Y_L] - yl
        obs[i, k + OBS_RATE_PEAK] = ep[i, EP_PEAK_RATE]


@jit(inline=True)
def _info(info: np.ndarray, i: int, st: np.ndarray, ep: np.ndarray, rate: float, expected: float,
          dist: float, left: float, r_rate: float, r_reach: float, r_terminal: float, power: float,
          r_energy: float) -> None:  # fmt: skip
    """Write ``info`` row ``i``: the step's terms and the running eq. (9) score and eq. (10)
    check (``st``: ``state``, ``ep``: ``episode``; with an energy budget, feasible also asks
    E <= E_max (1 + ENERGY_RTOL) of the energy so far, as ``check_trajectory``), the move's power,
    the energy so far and the bits per joule so far, B dt sum_n r(q[n]) / E (0 before the first
    move)."""
    points = st[i, ST_MOVES_MADE] + 1.0  # way-points so far
    deficit = max(0.0, dist - left * ep[i, EP_D])  # how far qF is out of reach (m)
    worst = max(st[i, ST_EXCESS], deficit)
    energy = st[i, ST_ENERGY]
    info[i, INFO_RATE], info[i, INFO_EXPECTED_RATE] = rate, expected
    info[i, INFO_POSITION_X], info[i, INFO_POSITION_Y] = st[i, ST_X], st[i, ST_Y]
    info[i, INFO_DISTANCE_TO_FINAL], info[i, INFO_SLOT] = dist, points
    info[i, INFO_REWARD_RATE], info[i, INFO_REWARD_REACH] = r_rate, r_reach
    info[i, INFO_REWARD_TERMINAL] = r_terminal
    info[i, INFO_AVERAGE_RATE] = st[i, ST_SUM_EXPECTED] / points
    info[i, INFO_MEAN_FADED_RATE] = st[i, ST_SUM_RATE] / points
    within = energy <= ep[i, EP_BUDGET] * (1.0 + ENERGY_RTOL)
    info[i, INFO_FEASIBLE] = 1.0 if worst <= FEASIBILITY_TOL and within else 0.0
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
        state[i, ST_MOVES_MADE], state[i, ST_SUM_EXPECTED], state[i, ST_SUM_RATE] = 0.0, expected, rate
        state[i, ST_EXCESS], state[i, ST_ENERGY] = 0.0, 0.0
        state[i, ST_MOVE_X], state[i, ST_MOVE_Y] = 0.0, 0.0
        dist = math.hypot(episode[i, EP_QFX] - x, episode[i, EP_QFY] - y)
        moves = episode[i, EP_MOVES]
        _observe(obs, i, x, y, moves, dist, expected, episode, flags, 0.0, 0.0)
        _info(info, i, state, episode, rate, expected, dist, moves, 0.0, 0.0, 0.0, 0.0, 0.0)


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
    return slot_power(length, ep[i, EP_DT], ep[i, EP_P_BLADE], ep[i, EP_BLADE_K], ep[i, EP_P_INDUCED],
                      ep[i, EP_INDUCED_K], ep[i, EP_DRAG])  # fmt: skip


@jit(inline=True)
def _move(i: int, actions: np.ndarray, st: np.ndarray, ep: np.ndarray, flags: np.ndarray,
          path: np.ndarray) -> tuple[float, float, float, float]:  # fmt: skip
    """Move row ``i`` (unit-disk projection, then the arrival guard) and book the move's energy;
    return (x, y, moves left, the move's power P in W)."""
    ax, ay = actions[i, 0], actions[i, 1]
    norm = math.hypot(ax, ay)  # no overflow for huge actions
    if norm > 1.0:
        ax, ay = ax / norm, ay / norm
    d, x0, y0 = ep[i, EP_D], st[i, ST_X], st[i, ST_Y]
    x, y = x0 + d * ax, y0 + d * ay
    n = st[i, ST_MOVES_MADE]
    left = ep[i, EP_MOVES] - n - 1.0  # moves left after this one
    if flags[FLAG_ARRIVAL_GUARD] != 0.0:
        x, y = guarded_position((x0, y0), (x, y), (ep[i, EP_QFX], ep[i, EP_QFY]), d, int(left))
    st[i, ST_X], st[i, ST_Y], st[i, ST_MOVES_MADE] = x, y, n + 1.0
    length = math.hypot(x - x0, y - y0)
    st[i, ST_EXCESS] = max(st[i, ST_EXCESS], length - d)
    power = move_power(length, ep, i)
    st[i, ST_ENERGY] += ep[i, EP_DT] * power
    st[i, ST_MOVE_X], st[i, ST_MOVE_Y] = (x - x0) / d, (y - y0) / d
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
    st[i, ST_SUM_EXPECTED] += expected
    st[i, ST_SUM_RATE] += rate
    dist = math.hypot(ep[i, EP_QFX] - x, ep[i, EP_QFY] - y)
    r_reach, r_terminal = penalties(
        dist, left, ep[i, EP_D], flags[FLAG_REACH_WEIGHT], flags[FLAG_TERMINAL_WEIGHT]
    )
    r_energy = 0.0
    if flags[FLAG_ENERGY] != 0.0:
        r_energy = -ep[i, EP_ENERGY_COST] * power
        reward[i] = rate + r_energy + r_reach + r_terminal
    else:
        reward[i] = rate + r_reach + r_terminal
    terminated[i] = left == 0.0
    _observe(obs, i, x, y, left, dist, expected, ep, flags, st[i, ST_MOVE_X], st[i, ST_MOVE_Y])
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
    """One slot of row ``i``: move (unit-disk projection, then the arrival guard), rate (channel
    "rician": the faded rate from ``normals`` (B, 2)), reward, observation and info. ``path``
    (B, N_max, 2) receives the new way-point (at index ``moves made``)."""
    x, y, left, power = _move(i, actions, state, episode, flags, path)
    expected = rate_row(x, y, nodes, params, i)
    rate = expected
    if flags[FLAG_RICIAN] != 0.0:
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
        end = state[i, ST_MOVES_MADE] + planned[i]  # moves made after this entry
        if end >= episode[i, EP_MOVES] or end >= path_length:
            return r
    return -1


@jit(inline=True, fastmath=False)
def toward(i: int, tx: float, ty: float, state: np.ndarray, episode: np.ndarray, actions: np.ndarray) -> None:
    """Row ``i``'s move towards (``tx``, ``ty``) m into ``actions[i, :2]``: full speed (``D`` =
    ``episode[i, EP_D]``), or the rest of the way once within D (``policies.full_speed_move``)."""
    d = episode[i, EP_D]
    mx, my = (tx - state[i, ST_X]) / d, (ty - state[i, ST_Y]) / d
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
