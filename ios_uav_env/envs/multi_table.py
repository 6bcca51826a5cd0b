"""The rows' layout of the multi-node kernels (``ios_uav_env.envs.multi_kernels``): the columns
of ``state``, ``episode``, ``points``, ``actions``, the observation and the ``info`` table, the
``info`` keys of each setting (more with the energy objective and with channel "rician") and
their views of the table, and each scenario's ``episode`` row and node ``points``.

The kernels address every column by name, never by number, as ``single_kernels`` does (its
module docstring): a module-level int per entry of each column tuple, ``TUPLE.index("name")``,
named by a prefix that no name of ``single_kernels`` uses and the entry upper-cased: ``MST_``
(:data:`STATE`: ``state[i, MST_MOVES_MADE]``), ``MEP_`` (:data:`EPISODE`: ``ep[MEP_INV_L]``),
``PT_`` (:data:`POINT`: ``points[i, k, PT_SIDE]``), ``ACT_`` (:data:`ACTION`: ``actions[i,
ACT_SCORES + k]``), ``MINFO_`` (:data:`INFO`) and ``MORE_`` (:data:`MORE`, at its offset in the
block: ``row[more + MORE_POWER]``), ``MOBS_`` (the observation's :data:`BASE_FEATURES`) and
``NODE_`` (the features of a node block, at their offset in the block: ``o[j + NODE_SERVED]``;
:data:`NODE_FEATURES`, then with ``peak_hint`` :data:`NODE_PEAK_FEATURES`). ``N_*`` are the
lengths of the blocks. ``state`` and ``episode`` begin with the core's columns
(``core.kernel.CORE_STATE``, ``CORE_EPISODE``: ``MST_X`` is ``S_X``, ``MEP_DT`` is ``E_DT``),
which the row-step core shared with the single-node view reads; the flags and the energy features
after the node blocks are the core's too (``core.kernel.FLAG_*``, ``observe_energy``).
``tests/envs/test_kernel_columns.py`` refuses a literal column index.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import numpy as np

from ios_uav_env.envs.core.kernel import CORE_EPISODE, CORE_STATE, core_episode_values
from ios_uav_env.envs.observation import M_SCALE, T_SCALE
from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.peak import rate_peak

__all__ = [
    "ACTION", "BASE_FEATURES", "BEST", "ENERGY_INFO_KEYS", "EPISODE", "INFO", "MORE", "MULTI_INFO_KEYS",
    "NODE_FEATURES", "NODE_PEAK_FEATURES", "POINT", "RICIAN_INFO_KEYS", "STATE", "episode_row", "info_arrays",
    "info_columns", "info_keys", "node_peaks", "node_points", "set_reference",
]  # fmt: skip

#: Columns of a row of ``state``: the core's (``core.kernel.CORE_STATE``: the UAV position, moves
#: made, the step excess, the propulsion energy so far (J), the last move / D), then the min rate
#: so far and the rate term's potential.
STATE = CORE_STATE + ("min_rate", "potential")
#: Columns of a row of ``episode``: the core's (``core.kernel.CORE_EPISODE``), then the node-block
#: view's.
EPISODE = CORE_EPISODE + (
    "N", "cx", "cy", "K", "sharpness", "elements", "is_ios", "is_ris", "horizon", "softmin_beta",
    "peak_hint", "served_clip",
)  # fmt: skip
#: Columns of a row of ``points`` (per node).
POINT = ("x", "y", "side", "peak_x", "peak_y", "peak_rate")
#: The scalar columns of the ``info`` table; then ``shares`` (K_max), ``node_rates`` (K_max),
#: :data:`MORE` and ``expected_node_rates`` (K_max).
INFO = (
    "position_x", "position_y", "slot", "distance_to_final", "min_rate", "best_schedule_rate",
    "reward_rate", "reward_reach", "reward_terminal", "feasible", "worst_violation", "terminal_miss",
)  # fmt: skip
#: The scalar columns of the ``info`` table after ``node_rates``: the energy objective's and the
#: Rician channel's (written on every row; ``info`` shows them only where they mean something).
MORE = ("power", "energy", "energy_efficiency", "reward_energy", "expected_min_rate")
#: Columns of a row of ``actions``: the move, then from ``scores`` on one score per node slot.
ACTION = ("move_x", "move_y", "scores")
#: The scenario-level observation, before the node blocks.
BASE_FEATURES = (
    "x", "y", "dx_final", "dy_final", "dx_ios", "dy_ios", "time_left", "slack",
    "elements", "is_ios", "is_ris", "horizon",
)  # fmt: skip
#: Per-node observation block: mask, (w_k - q) / L, side of the IOS, served rate R_k so far, r_k(q).
NODE_FEATURES = ("mask", "dx_node", "dy_node", "side", "served", "rate")
#: Per-node hint appended to each node block with ``peak_hint=True``: the node's reachable rate
#: peak P_k (``rate_peak(config.node_config(k))``) relative to the UAV, (P_k - q) / L, and r_k(P_k).
NODE_PEAK_FEATURES = ("dx_peak", "dy_peak", "rate_peak")

# The columns by name (see the module's docstring).
MST_X = STATE.index("x")
MST_Y = STATE.index("y")
MST_MOVES_MADE = STATE.index("moves_made")
MST_EXCESS = STATE.index("excess")
MST_ENERGY = STATE.index("energy")
MST_MOVE_X = STATE.index("move_x")
MST_MOVE_Y = STATE.index("move_y")
MST_MIN_RATE = STATE.index("min_rate")
MST_POTENTIAL = STATE.index("potential")

MEP_D = EPISODE.index("D")
MEP_QFX = EPISODE.index("qfx")
MEP_QFY = EPISODE.index("qfy")
MEP_MOVES = EPISODE.index("moves")
MEP_DT = EPISODE.index("dt")
MEP_P_BLADE = EPISODE.index("p_blade")
MEP_BLADE_K = EPISODE.index("blade_k")
MEP_P_INDUCED = EPISODE.index("p_induced")
MEP_INDUCED_K = EPISODE.index("induced_k")
MEP_DRAG = EPISODE.index("drag")
MEP_BUDGET = EPISODE.index("budget")
MEP_ENERGY_COST = EPISODE.index("energy_cost")
MEP_ENERGY_WEIGHT = EPISODE.index("energy_weight")
MEP_MIN_POWER_MOVE = EPISODE.index("min_power_move")
MEP_BITS_SCALE = EPISODE.index("bits_scale")
MEP_INV_L = EPISODE.index("inv_l")
MEP_N = EPISODE.index("N")
MEP_CX = EPISODE.index("cx")
MEP_CY = EPISODE.index("cy")
MEP_K = EPISODE.index("K")
MEP_SHARPNESS = EPISODE.index("sharpness")
MEP_ELEMENTS = EPISODE.index("elements")
MEP_IS_IOS = EPISODE.index("is_ios")
MEP_IS_RIS = EPISODE.index("is_ris")
MEP_HORIZON = EPISODE.index("horizon")
MEP_SOFTMIN_BETA = EPISODE.index("softmin_beta")
MEP_PEAK_HINT = EPISODE.index("peak_hint")
MEP_SERVED_CLIP = EPISODE.index("served_clip")

PT_X = POINT.index("x")
PT_Y = POINT.index("y")
PT_SIDE = POINT.index("side")
PT_PEAK_X = POINT.index("peak_x")
PT_PEAK_Y = POINT.index("peak_y")
PT_PEAK_RATE = POINT.index("peak_rate")

ACT_MOVE_X = ACTION.index("move_x")
ACT_MOVE_Y = ACTION.index("move_y")
ACT_SCORES = ACTION.index("scores")
#: The move's columns (adjacent: x, then y), as a slice.
ACT_MOVE = slice(ACT_MOVE_X, ACT_MOVE_Y + 1)

# The ``info`` table: INFO from 0, then the blocks shares, node_rates (K_max each), MORE (each at
# its offset in the block) and expected_node_rates (K_max).
MINFO_POSITION_X = INFO.index("position_x")
MINFO_POSITION_Y = INFO.index("position_y")
MINFO_SLOT = INFO.index("slot")
MINFO_DISTANCE_TO_FINAL = INFO.index("distance_to_final")
MINFO_MIN_RATE = INFO.index("min_rate")
MINFO_BEST_SCHEDULE_RATE = INFO.index("best_schedule_rate")
MINFO_REWARD_RATE = INFO.index("reward_rate")
MINFO_REWARD_REACH = INFO.index("reward_reach")
MINFO_REWARD_TERMINAL = INFO.index("reward_terminal")
MINFO_FEASIBLE = INFO.index("feasible")
MINFO_WORST_VIOLATION = INFO.index("worst_violation")
MINFO_TERMINAL_MISS = INFO.index("terminal_miss")
N_MINFO = len(INFO)
#: The position's columns (adjacent: x, then y), as a slice.
MINFO_POSITION = slice(MINFO_POSITION_X, MINFO_POSITION_Y + 1)
MORE_POWER = MORE.index("power")
MORE_ENERGY = MORE.index("energy")
MORE_ENERGY_EFFICIENCY = MORE.index("energy_efficiency")
MORE_REWARD_ENERGY = MORE.index("reward_energy")
MORE_EXPECTED_MIN_RATE = MORE.index("expected_min_rate")
N_MORE = len(MORE)
#: Column of ``best_schedule_rate`` (filled in by the caller: an LP, at episode end only).
BEST = MINFO_BEST_SCHEDULE_RATE

# The observation: BASE_FEATURES from 0, then K_max node blocks of N_NODE (N_NODE_PEAK with
# ``peak_hint``) features each, then with the energy objective the energy block.
MOBS_X = BASE_FEATURES.index("x")
MOBS_Y = BASE_FEATURES.index("y")
MOBS_DX_FINAL = BASE_FEATURES.index("dx_final")
MOBS_DY_FINAL = BASE_FEATURES.index("dy_final")
MOBS_DX_IOS = BASE_FEATURES.index("dx_ios")
MOBS_DY_IOS = BASE_FEATURES.index("dy_ios")
MOBS_TIME_LEFT = BASE_FEATURES.index("time_left")
MOBS_SLACK = BASE_FEATURES.index("slack")
MOBS_ELEMENTS = BASE_FEATURES.index("elements")
MOBS_IS_IOS = BASE_FEATURES.index("is_ios")
MOBS_IS_RIS = BASE_FEATURES.index("is_ris")
MOBS_HORIZON = BASE_FEATURES.index("horizon")
N_MOBS = len(BASE_FEATURES)
NODE_MASK = NODE_FEATURES.index("mask")
NODE_DX_NODE = NODE_FEATURES.index("dx_node")
NODE_DY_NODE = NODE_FEATURES.index("dy_node")
NODE_SIDE = NODE_FEATURES.index("side")
NODE_SERVED = NODE_FEATURES.index("served")
NODE_RATE = NODE_FEATURES.index("rate")
N_NODE = len(NODE_FEATURES)
NODE_DX_PEAK = N_NODE + NODE_PEAK_FEATURES.index("dx_peak")
NODE_DY_PEAK = N_NODE + NODE_PEAK_FEATURES.index("dy_peak")
NODE_RATE_PEAK = N_NODE + NODE_PEAK_FEATURES.index("rate_peak")
N_NODE_PEAK = N_NODE + len(NODE_PEAK_FEATURES)

#: The keys of ``info`` (the same on every step and at reset): :func:`info_arrays`.
MULTI_INFO_KEYS = (
    "position", "slot", "distance_to_final", "shares", "node_rates", "min_rate", "best_schedule_rate",
    "reward_rate", "reward_reach", "reward_terminal", "feasible", "worst_violation", "terminal_miss",
)  # fmt: skip
#: The keys ``info`` adds with the objective ``"energy_efficiency"``.
ENERGY_INFO_KEYS = ("power", "energy", "energy_efficiency", "reward_energy")
#: The keys ``info`` adds with channel ``"rician"``.
RICIAN_INFO_KEYS = ("expected_node_rates", "expected_min_rate")


def info_keys(energy: bool = False, rician: bool = False) -> tuple[str, ...]:
    """The keys of ``info``: :data:`MULTI_INFO_KEYS`, then :data:`ENERGY_INFO_KEYS` with the energy
    objective, then :data:`RICIAN_INFO_KEYS` with channel ``"rician"``."""
    return MULTI_INFO_KEYS + (ENERGY_INFO_KEYS if energy else ()) + (RICIAN_INFO_KEYS if rician else ())


def info_columns(max_nodes: int, more: bool = True) -> int:
    """Width of the ``info`` table for ``max_nodes`` nodes: ``INFO``, shares and node rates, then
    (``more``: the energy objective, channel "rician") ``MORE`` and the expected node rates."""
    return len(INFO) + 2 * max_nodes + (len(MORE) + max_nodes if more else 0)


def info_arrays(
    table: np.ndarray, max_nodes: int, keys: tuple[str, ...] = MULTI_INFO_KEYS
) -> dict[str, np.ndarray]:
    """``info`` (``keys``, of :func:`info_keys`) as views of the rows of the info ``table``:
    ``position`` (B, 2), ``shares``, ``node_rates`` and ``expected_node_rates`` (B, K_max),
    ``slot`` int64, ``feasible`` bool."""
    columns, end = table.T, len(INFO)
    node_rates = end + max_nodes
    more = node_rates + max_nodes
    out = {}
    for key in keys:  # (only the keys asked for: the table holds every objective's columns)
        if key == "position":
            out[key] = table[:, MINFO_POSITION]
        elif key == "shares":
            out[key] = table[:, end:node_rates]
        elif key == "node_rates":
            out[key] = table[:, node_rates:more]
        elif key == "expected_node_rates":
            out[key] = table[:, more + len(MORE) :]
        elif key == "slot":
            out[key] = columns[MINFO_SLOT].astype(np.int64)
        elif key == "feasible":
            out[key] = columns[MINFO_FEASIBLE] != 0.0
        else:
            out[key] = columns[more + MORE.index(key)] if key in MORE else columns[INFO.index(key)]
    return out


@functools.lru_cache(maxsize=256)
def node_peaks(config: ScenarioConfig) -> tuple[tuple[float, float, float], ...]:
    """Each node's reachable rate peak (x, y, rate): ``rate_peak`` of ``config.node_config(k)``
    (on the compiled kernel when numba is installed: ``compiled=HAVE_NUMBA``), the ``peak_hint``
    features; cached, so a fixed scenario and the rows of a batch sharing one compute them once."""
    return tuple(tuple(rate_peak(config.node_config(k), compiled=HAVE_NUMBA)) for k in range(config.K))


def episode_row(config: ScenarioConfig, length_scale: float, sharpness: float, softmin_beta: float = 0.0,
                peak_hint: bool = False, reference: float = 0.0,
                served_clip: float = math.inf) -> np.ndarray:  # fmt: skip
    """The ``episode`` row of ``config`` (see :data:`EPISODE`): the core's columns
    (``core.kernel.core_episode_values``: the propulsion constants, the energy budget, the
    minimum-power move V_mp dt / D, B dt), the energy reward's constants of lambda_ref =
    ``reference`` (bits/J; :func:`set_reference`), then the view's, with where the observation
    clips the served rates (``served_clip``, bps/Hz: finite for faded rates only)."""
    cx, cy = config.ios_center[:2]
    elements = config.M / M_SCALE if config.surface != "none" else 0.0
    kind = float(config.surface == "ios"), float(config.surface == "ris")
    row = core_episode_values(config, length_scale)
    row += [config.N, cx, cy, config.K, sharpness, elements, *kind, config.T / T_SCALE, softmin_beta,
            float(peak_hint), served_clip]  # fmt: skip
    out = np.array(row, dtype=np.float64)
    set_reference(out, config, reference)
    return out


def set_reference(
    row: np.ndarray, config: ScenarioConfig, reference: float, observed: float | None = None
) -> None:
    """Write lambda_ref = ``reference`` (bits/J) into the ``episode`` ``row`` of ``config``: the
    reward's energy cost lambda_ref / B (bps/Hz per W) and the observation's energy weight
    ``observed`` P(0) / B (bps/Hz; ``observed`` defaults to ``reference``: it differs for moving
    nodes, whose reward takes the truth's lambda_ref and whose observation the configured one)."""
    seen = reference if observed is None else observed
    row[MEP_ENERGY_COST] = reference / config.bandwidth_hz
    row[MEP_ENERGY_WEIGHT] = seen / config.bandwidth_hz * config.propulsion.hover_power


def node_points(
    config: ScenarioConfig, peaks: Sequence[tuple[float, float, float]] | None = None
) -> np.ndarray:
    """The (K, 6) ``points`` of ``config`` (:data:`POINT`): each node's x, y, side of the IOS
    (+1 at x > x_c) and its rate peak (``peaks``, the single env's ``peak_hint``; 0 without)."""
    cx = config.ios_center[0]
    peaks = peaks or [(0.0, 0.0, 0.0)] * config.K
    rows = [
        (wx, wy, 1.0 if wx > cx else -1.0, *peak) for (wx, wy), peak in zip(config.nodes, peaks, strict=True)
    ]
    return np.array(rows, dtype=np.float64)
