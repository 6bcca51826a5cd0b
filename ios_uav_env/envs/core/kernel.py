"""The row-step core that both compiled steps run: one UAV's move, arrival guard, propulsion power
and reward assembly on a row of the kernels' arrays, whatever the view.

Both row layouts, the single-node view's (``ios_uav_env.envs.single_kernels``, one node) and the
node-block view's (``ios_uav_env.envs.multi_step`` over K nodes, columns in
``ios_uav_env.envs.multi_table``), begin with the columns named here: ``state`` with
:data:`CORE_STATE` (the UAV's position, moves made, its largest step excess, the propulsion
energy so far and its last move / D) and ``episode`` with :data:`CORE_EPISODE` (the step length
D, qF, the moves of an episode, the propulsion constants of :func:`slot_power`, the energy
budget and the energy reward's constants, 1 / L). Each view appends its own columns: the
single-node view its running rate sums, the node-block view its min-rate potential, and their
observation's constants. The flags (:data:`FLAGS`, :func:`flags_of`) are the same array in both.

What is the same in both views lives here, once: :func:`move_row` (unit-disk projection, arrival
guard, the step's excess, power and energy, the last move and the way-point), :func:`reward_row`
(the reach and terminal terms, the energy term, the reward and ``terminated``),
:func:`start_row` (the core columns at reset), :func:`violation` (the running eq. (10) check)
and :func:`observe_energy` (the energy features). What differs is the view's: its rates (one
node's ``rate_row``, or K nodes' ``rate_point`` with shares), its running sums and its
observation and ``info`` writers.

The helpers are inlined (``jit(inline=True)``) into each view's compiled entry points, so each
is compiled with its view's arithmetic: the single-node step with the fast-math flags of
``ios_uav_env.jit`` (its vectorised node sums), the node-block step in IEEE arithmetic
(``fastmath=False``: it reproduces plain Python bit for bit through the arrival guard).

Columns are addressed by name, as in the views' modules: ``S_`` (:data:`CORE_STATE`: ``state[i,
S_ENERGY]``), ``E_`` (:data:`CORE_EPISODE`: ``episode[i, E_DT]``) and ``FLAG_`` (:data:`FLAGS`).
``tests/envs/test_kernel_columns.py`` refuses a literal column index here too.
"""

from __future__ import annotations

import math

import numpy as np

from ios_uav_env.envs.observation import min_power_move
from ios_uav_env.envs.observation_layout import ENERGY_NAMES
from ios_uav_env.envs.options import EnvOptions
from ios_uav_env.jit import jit
from ios_uav_env.model.config import ENERGY_RTOL, FEASIBILITY_TOL, ScenarioConfig
from ios_uav_env.model.guard import guarded_position

__all__ = [
    "CORE_EPISODE", "CORE_STATE", "FLAGS", "budget_of", "core_episode_values", "flags_of",
    "fly_entry_out_of_range", "move_row", "observe_energy", "penalties", "reward_row", "slot_power",
    "start_row", "toward", "violation",
]  # fmt: skip

#: The first columns of every view's ``state`` row.
CORE_STATE = ("x", "y", "moves_made", "excess", "energy", "move_x", "move_y")
#: The first columns of every view's ``episode`` row.
CORE_EPISODE = (
    "D", "qfx", "qfy", "moves", "dt", "p_blade", "blade_k", "p_induced", "induced_k", "drag", "budget",
    "energy_cost", "energy_weight", "min_power_move", "bits_scale", "inv_l",
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

S_X = CORE_STATE.index("x")
S_Y = CORE_STATE.index("y")
S_MOVES_MADE = CORE_STATE.index("moves_made")
S_EXCESS = CORE_STATE.index("excess")
S_ENERGY = CORE_STATE.index("energy")
S_MOVE_X = CORE_STATE.index("move_x")
S_MOVE_Y = CORE_STATE.index("move_y")

E_D = CORE_EPISODE.index("D")
E_QFX = CORE_EPISODE.index("qfx")
E_QFY = CORE_EPISODE.index("qfy")
E_MOVES = CORE_EPISODE.index("moves")
E_DT = CORE_EPISODE.index("dt")
E_P_BLADE = CORE_EPISODE.index("p_blade")
E_BLADE_K = CORE_EPISODE.index("blade_k")
E_P_INDUCED = CORE_EPISODE.index("p_induced")
E_INDUCED_K = CORE_EPISODE.index("induced_k")
E_DRAG = CORE_EPISODE.index("drag")
E_BUDGET = CORE_EPISODE.index("budget")
E_ENERGY_COST = CORE_EPISODE.index("energy_cost")
E_ENERGY_WEIGHT = CORE_EPISODE.index("energy_weight")
E_MIN_POWER_MOVE = CORE_EPISODE.index("min_power_move")
E_BITS_SCALE = CORE_EPISODE.index("bits_scale")
E_INV_L = CORE_EPISODE.index("inv_l")

FLAG_ARRIVAL_GUARD = FLAGS.index("arrival_guard")
FLAG_RICIAN = FLAGS.index("rician")
FLAG_INSTANCE_FEATURES = FLAGS.index("instance_features")
FLAG_PEAK_HINT = FLAGS.index("peak_hint")
FLAG_REACH_WEIGHT = FLAGS.index("reach_weight")
FLAG_TERMINAL_WEIGHT = FLAGS.index("terminal_weight")
FLAG_ENERGY = FLAGS.index("energy")

# The energy features (``observation_layout.ENERGY_NAMES``), at their offset in their block.
OBS_MOVE_X = ENERGY_NAMES.index("move_x")
OBS_MOVE_Y = ENERGY_NAMES.index("move_y")
OBS_ENERGY_WEIGHT = ENERGY_NAMES.index("energy_weight")
OBS_MIN_POWER_MOVE = ENERGY_NAMES.index("min_power_move")
N_ENERGY = len(ENERGY_NAMES)


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


def core_episode_values(config: ScenarioConfig, length_scale: float) -> list[float]:
    """The :data:`CORE_EPISODE` values of ``config`` without the energy reward's (``energy_cost``,
    ``energy_weight``: 0, written by the view), in order."""
    m = config.propulsion
    return [
        config.D, *config.qF, config.N - 1, config.dt, m.P0, 3.0 / m.U_tip**2, m.P_i, 1.0 / (2.0 * m.v0**2),
        m.drag_coefficient, budget_of(config), 0.0, 0.0, min_power_move(config),
        config.bandwidth_hz * config.dt, 1.0 / length_scale,
    ]  # fmt: skip


# The helpers index the 2-D arrays in place (``episode[i, E_DT]``), never through row views
# (``episode[i]``): in compiled code every view costs a reference count.


@jit(inline=True)
def slot_power(
    length: float, dt: float, p_blade: float, blade_k: float, p_induced: float, induced_k: float, drag: float
) -> float:
    """P(V) (W) of a move of ``length`` m flown over a slot of ``dt`` s, V = length / dt: eq. (12)
    (``ios_uav_env.propulsion_power``, inlined, in the cancellation-free form of
    ``model.propulsion``) with the constants of an ``episode`` row's ``p_blade, blade_k,
    p_induced, induced_k, drag`` columns."""
    v = length / dt
    v2 = v * v
    x = v2 * induced_k
    return p_blade * (1.0 + blade_k * v2) + p_induced / math.sqrt(math.sqrt(1.0 + x * x) + x) + drag * v2 * v


@jit(inline=True)
def move_power(length: float, episode: np.ndarray, i: int) -> float:
    """:func:`slot_power` with row ``i``'s constants."""
    return slot_power(length, episode[i, E_DT], episode[i, E_P_BLADE], episode[i, E_BLADE_K],
                      episode[i, E_P_INDUCED], episode[i, E_INDUCED_K], episode[i, E_DRAG])  # fmt: skip


@jit(inline=True)
def move_row(i: int, ax: float, ay: float, norm: float, state: np.ndarray, episode: np.ndarray,
             flags: np.ndarray, path: np.ndarray) -> tuple[float, float, float, float]:  # fmt: skip
    """Fly row ``i``'s move (``ax``, ``ay``) x D: projected on the unit disk when ``norm`` (its
    length) exceeds 1, then through the arrival guard (``flags``); book the step's excess over D,
    its propulsion power and energy and the last move / D in ``state``, and the way-point in
    ``path`` (at index ``moves made``). Return (x, y, moves left after this one, the power in W)."""
    if norm > 1.0:
        ax, ay = ax / norm, ay / norm
    d, x0, y0 = episode[i, E_D], state[i, S_X], state[i, S_Y]
    x, y = x0 + d * ax, y0 + d * ay
    n = state[i, S_MOVES_MADE]
    left = episode[i, E_MOVES] - n - 1.0  # moves left after this one
    if flags[FLAG_ARRIVAL_GUARD] != 0.0:
        x, y = guarded_position((x0, y0), (x, y), (episode[i, E_QFX], episode[i, E_QFY]), d, int(left))
    state[i, S_X], state[i, S_Y], state[i, S_MOVES_MADE] = x, y, n + 1.0
    length = math.hypot(x - x0, y - y0)
    state[i, S_EXCESS] = max(state[i, S_EXCESS], length - d)
    power = move_power(length, episode, i)
    state[i, S_ENERGY] += episode[i, E_DT] * power
    state[i, S_MOVE_X], state[i, S_MOVE_Y] = (x - x0) / d, (y - y0) / d
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
def reward_row(
    i: int, r_rate: float, dist: float, left: float, power: float, episode: np.ndarray, flags: np.ndarray,
    reward: np.ndarray, terminated: np.ndarray,
) -> tuple[float, float, float]:  # fmt: skip
    """Row ``i``'s reward after its move (of ``power`` W, ``dist`` m from qF with ``left`` moves to
    go): the view's rate term ``r_rate``, the energy term -(lambda_ref / B) P with the energy
    objective, the reach and terminal terms (:func:`penalties`); ``terminated`` at the last move.
    Return (reach term, terminal term, energy term)."""
    r_reach, r_terminal = penalties(
        dist, left, episode[i, E_D], flags[FLAG_REACH_WEIGHT], flags[FLAG_TERMINAL_WEIGHT]
    )
    r_energy = 0.0
    if flags[FLAG_ENERGY] != 0.0:
        r_energy = -episode[i, E_ENERGY_COST] * power
        reward[i] = r_rate + r_energy + r_reach + r_terminal
    else:
        reward[i] = r_rate + r_reach + r_terminal
    terminated[i] = left == 0.0
    return r_reach, r_terminal, r_energy


@jit(inline=True)
def start_row(i: int, state: np.ndarray) -> None:
    """Row ``i``'s core state at reset (the UAV at q0, already in ``state``): no move made, no
    excess, no energy, no last move."""
    state[i, S_MOVES_MADE], state[i, S_EXCESS], state[i, S_ENERGY] = 0.0, 0.0, 0.0
    state[i, S_MOVE_X], state[i, S_MOVE_Y] = 0.0, 0.0


@jit(inline=True)
def violation(
    i: int, dist: float, left: float, state: np.ndarray, episode: np.ndarray
) -> tuple[float, float, bool]:
    """The running eq. (10) check of row ``i`` (``dist`` m from qF, ``left`` moves to go): (how far
    qF is out of reach, the worst violation so far, feasible). With an energy budget, feasible
    also asks E <= E_max (1 + ENERGY_RTOL) of the energy so far, as ``check_trajectory`` does."""
    deficit = max(0.0, dist - left * episode[i, E_D])
    worst = max(state[i, S_EXCESS], deficit)
    within = state[i, S_ENERGY] <= episode[i, E_BUDGET] * (1.0 + ENERGY_RTOL)
    return deficit, worst, worst <= FEASIBILITY_TOL and within


@jit(inline=True)
def observe_energy(obs: np.ndarray, i: int, k: int, state: np.ndarray, episode: np.ndarray) -> None:
    """The energy features of row ``i`` from observation column ``k`` on: the last move / D, the
    energy weight, the minimum-power move."""
    obs[i, k + OBS_MOVE_X], obs[i, k + OBS_MOVE_Y] = state[i, S_MOVE_X], state[i, S_MOVE_Y]
    obs[i, k + OBS_ENERGY_WEIGHT] = episode[i, E_ENERGY_WEIGHT]
    obs[i, k + OBS_MIN_POWER_MOVE] = episode[i, E_MIN_POWER_MOVE]


@jit(inline=True, fastmath=False)
def fly_entry_out_of_range(rows: np.ndarray, targets: np.ndarray, moves: np.ndarray, state: np.ndarray,
                           episode: np.ndarray, path_length: int) -> int:  # fmt: skip
    """-1 if every entry of a flight (a view's ``fly_rows``) may fly, else the first that may not: a
    row outside 0..B-1, a move count < 0, or a row whose moves (summed over its entries) would
    finish its episode or pass ``path_length``; 0 if ``targets`` or ``moves`` are shorter than ``rows``."""
    if targets.shape[0] < rows.size or moves.size < rows.size:
        return 0
    planned = np.zeros(state.shape[0])
    for r in range(rows.size):
        i = rows[r]
        if i < 0 or i >= state.shape[0] or moves[r] < 0:
            return r
        planned[i] += moves[r]
        end = state[i, S_MOVES_MADE] + planned[i]  # moves made after this entry
        if end >= episode[i, E_MOVES] or end >= path_length:
            return r
    return -1


@jit(inline=True, fastmath=False)
def toward(i: int, tx: float, ty: float, state: np.ndarray, episode: np.ndarray, actions: np.ndarray) -> None:
    """Row ``i``'s move towards (``tx``, ``ty``) m into ``actions[i, :2]``: full speed (D), or the
    rest of the way once within D (``policies.full_speed_move``)."""
    d = episode[i, E_D]
    mx, my = (tx - state[i, S_X]) / d, (ty - state[i, S_Y]) / d
    length = math.hypot(mx, my)
    if length > 1.0:
        mx, my = mx / length, my / length
    actions[i, 0], actions[i, 1] = mx, my
