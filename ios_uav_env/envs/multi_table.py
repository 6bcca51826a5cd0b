"""The rows' layout of the multi-node kernels (``ios_uav_env.envs.multi_kernels``): the columns
of ``state``, ``episode``, ``points`` and the ``info`` table, the ``info`` keys of each setting
(more with the energy objective and with channel "rician") and their views of the table, and
each scenario's ``episode`` row and node ``points``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import numpy as np

from ios_uav_env.envs.observation import M_SCALE, T_SCALE, min_power_move
from ios_uav_env.envs.single_kernels import budget_of
from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.peak import rate_peak

__all__ = [
    "BEST", "ENERGY_INFO_KEYS", "EPISODE", "EP_BITS_SCALE", "EP_BUDGET", "EP_ENERGY_COST", "EP_ENERGY_WEIGHT",
    "EP_MIN_POWER_MOVE", "EP_SERVED_CLIP", "INFO", "MORE", "MULTI_INFO_KEYS", "POINT", "RICIAN_INFO_KEYS",
    "STATE", "ST_ENERGY", "ST_MOVE_X", "ST_MOVE_Y", "episode_row", "info_arrays", "info_columns", "info_keys",
    "node_peaks", "node_points", "set_reference",
]  # fmt: skip

#: Columns of a row of ``state`` (``moves_made`` at column 2, as in ``single_kernels.STATE``;
#: ``energy``: the propulsion energy so far, J; ``move_x``, ``move_y``: the last move / D).
STATE = ("x", "y", "moves_made", "excess", "min_rate", "potential", "energy", "move_x", "move_y")
#: Columns of a row of ``episode``.
EPISODE = (
    "D", "qfx", "qfy", "moves", "inv_l", "N", "cx", "cy", "K", "sharpness", "elements", "is_ios",
    "is_ris", "horizon", "softmin_beta", "peak_hint", "dt", "p_blade", "blade_k", "p_induced", "induced_k",
    "drag", "budget", "energy_cost", "energy_weight", "min_power_move", "bits_scale", "served_clip",
)  # fmt: skip
#: Columns of a row of ``points`` (per node).
POINT = ("x", "y", "side", "peak_x", "peak_y", "peak_rate")
#: The energy objective's and the Rician channel's columns, by name (the kernels index them so).
ST_ENERGY, ST_MOVE_X, ST_MOVE_Y = (STATE.index(c) for c in ("energy", "move_x", "move_y"))
EP_BUDGET, EP_ENERGY_COST, EP_ENERGY_WEIGHT, EP_MIN_POWER_MOVE, EP_BITS_SCALE, EP_SERVED_CLIP = (
    EPISODE.index(c)
    for c in ("budget", "energy_cost", "energy_weight", "min_power_move", "bits_scale", "served_clip")
)
#: The scalar columns of the ``info`` table; then ``shares`` (K_max), ``node_rates`` (K_max),
#: :data:`MORE` and ``expected_node_rates`` (K_max).
INFO = (
    "position_x", "position_y", "slot", "distance_to_final", "min_rate", "best_schedule_rate",
    "reward_rate", "reward_reach", "reward_terminal", "feasible", "worst_violation", "terminal_miss",
)  # fmt: skip
#: The scalar columns of the ``info`` table after ``node_rates``: the energy objective's and the
#: Rician channel's (written on every row; ``info`` shows them only where they mean something).
MORE = ("power", "energy", "energy_efficiency", "reward_energy", "expected_min_rate")
#: Column of ``best_schedule_rate`` (filled in by the caller: an LP, at episode end only).
BEST = INFO.index("best_schedule_rate")
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


def info_columns(max_nodes: int) -> int:
    """Width of the ``info`` table for ``max_nodes`` nodes."""
    return len(INFO) + len(MORE) + 3 * max_nodes


def info_arrays(
    table: np.ndarray, max_nodes: int, keys: tuple[str, ...] = MULTI_INFO_KEYS
) -> dict[str, np.ndarray]:
    """``info`` (``keys``, of :func:`info_keys`) as views of the rows of the info ``table``:
    ``position`` (B, 2), ``shares``, ``node_rates`` and ``expected_node_rates`` (B, K_max),
    ``slot`` int64, ``feasible`` bool."""
    columns, end = table.T, len(INFO)
    out = {key: columns[i] for i, key in enumerate(INFO) if not key.startswith("position")}
    out["position"] = table[:, 0:2]
    out["slot"] = out["slot"].astype(np.int64)
    out["feasible"] = out["feasible"] != 0.0
    out["shares"], out["node_rates"] = (
        table[:, end : end + max_nodes],
        table[:, end + max_nodes : end + 2 * max_nodes],
    )
    more = end + 2 * max_nodes
    out.update({key: columns[more + j] for j, key in enumerate(MORE)})
    out["expected_node_rates"] = table[:, more + len(MORE) :]
    return {key: out[key] for key in keys}


@functools.lru_cache(maxsize=256)
def node_peaks(config: ScenarioConfig) -> tuple[tuple[float, float, float], ...]:
    """Each node's reachable rate peak (x, y, rate): ``rate_peak`` of ``config.node_config(k)``
    (on the compiled kernel when numba is installed: ``compiled=HAVE_NUMBA``), the ``peak_hint``
    features; cached, so a fixed scenario and the rows of a batch sharing one compute them once."""
    return tuple(tuple(rate_peak(config.node_config(k), compiled=HAVE_NUMBA)) for k in range(config.K))


def episode_row(config: ScenarioConfig, length_scale: float, sharpness: float, softmin_beta: float = 0.0,
                peak_hint: bool = False, reference: float = 0.0,
                served_clip: float = math.inf) -> np.ndarray:  # fmt: skip
    """The ``episode`` row of ``config`` (see :data:`EPISODE`): the propulsion constants of
    ``single_kernels.slot_power``, the energy budget (``single_kernels.budget_of``), then the
    energy reward's constants of lambda_ref = ``reference`` (bits/J; :func:`set_reference`), the
    minimum-power move V_mp dt / D, B dt (bits per bps/Hz of a slot) and where the observation
    clips the served rates (``served_clip``, bps/Hz: finite for faded rates only)."""
    (fx, fy), (cx, cy) = config.qF, config.ios_center[:2]
    elements = config.M / M_SCALE if config.surface != "none" else 0.0
    kind = float(config.surface == "ios"), float(config.surface == "ris")
    m = config.propulsion
    row = [config.D, fx, fy, config.N - 1, 1.0 / length_scale, config.N, cx, cy, config.K, sharpness,
           elements, *kind, config.T / T_SCALE, softmin_beta, float(peak_hint), config.dt, m.P0,
           3.0 / m.U_tip**2, m.P_i, 1.0 / (2.0 * m.v0**2), m.drag_coefficient, budget_of(config), 0.0, 0.0,
           min_power_move(config), config.bandwidth_hz * config.dt, served_clip]  # fmt: skip
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
    row[EP_ENERGY_COST] = reference / config.bandwidth_hz
    row[EP_ENERGY_WEIGHT] = seen / config.bandwidth_hz * config.propulsion.hover_power


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
