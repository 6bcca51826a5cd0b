"""Fixed trajectories: the paper's IA-FT benchmark (fly-hover-fly) and the straight line.

Both are feasible for every valid :class:`~ios_uav_env.ScenarioConfig` (eq. (10) holds
to rounding) and are scored by the one model through :meth:`Plan.from_trajectory`.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from baselines.plan import Plan
from baselines.registry import check as check_planner
from ios_uav_env import ScenarioConfig, moves_needed


def _leg(start: np.ndarray, end: np.ndarray, step: float, moves: int) -> np.ndarray:
    """Way-points after each of ``moves`` full steps from ``start`` towards ``end``, stopping at it.

    Step k is at start + min(k * step, |end - start|) * u; the last way-point is ``end`` exactly
    when ``moves`` reaches it. Shape (moves, 2); the start itself is not included.
    """
    dist = float(np.linalg.norm(end - start))
    if moves == 0:
        return np.empty((0, 2))
    if dist == 0:
        return np.repeat(end[None, :], moves, axis=0)
    along = np.minimum(np.arange(1, moves + 1) * step, dist)
    pts = start + along[:, None] * ((end - start) / dist)
    pts[along >= dist] = end
    return pts


def fly_hover_fly_path(
    config: ScenarioConfig, hover: Sequence[float] | None = None
) -> tuple[np.ndarray, np.ndarray, int]:
    """Fly-hover-fly trajectory (N, 2), its turning point Z and the slots spent at Z.

    See :func:`fly_hover_fly` for the rule.
    """
    n_moves, d_max = config.N - 1, config.D
    q0, q_f = np.asarray(config.q0, float), np.asarray(config.qF, float)
    target = np.asarray(config.ground_node if hover is None else hover, dtype=float)
    if target.shape != (2,) or not np.all(np.isfinite(target)):
        raise ValueError(f"hover must be a finite (x, y) point in m, got {hover!r}")
    d_out = float(np.linalg.norm(target - q0))
    k_out = moves_needed(d_out, config.D)
    unit = (target - q0) / d_out if d_out > 0 else np.zeros(2)

    def turn_point(m: int) -> np.ndarray:
        return target if m >= k_out else q0 + m * d_max * unit

    # the largest number m of outbound moves after which qF is still reachable at slot N
    m = k_out
    while m > 0 and m + moves_needed(float(np.linalg.norm(q_f - turn_point(m))), config.D) > n_moves:
        m -= 1
    turn = turn_point(m)
    k_back = moves_needed(float(np.linalg.norm(q_f - turn)), config.D)
    hover_moves = n_moves - m - k_back
    out = _leg(q0, turn, d_max, m)
    stay = np.repeat(turn[None, :], hover_moves, axis=0)
    back = _leg(turn, q_f, d_max, k_back)
    traj = np.vstack([q0[None, :], out, stay, back])
    traj[-1] = q_f  # k_back = 0 only when turn == qF: the end is qF either way
    return traj, turn, hover_moves + 1


def fly_hover_fly(config: ScenarioConfig, hover: Sequence[float] | None = None) -> Plan:
    """IA-FT: fly from q0 towards the hover point at v_max, hover, fly to qF arriving at slot N.

    Rule (m = number of outbound moves):

    1. Outbound, move k (k = 1..m) reaches q0 + min(k D, |P - q0|) (P - q0)/|P - q0|: full
       steps of D, the last one into P shorter.
    2. m is the largest value in [0, k_P], k_P = ceil(|P - q0| / D), such that the UAV can
       still reach qF by slot N from its turning point Z_m (Z_m = P when m = k_P):
       m + ceil(|qF - Z_m| / D) <= N - 1. When time allows, m = k_P and Z = P.
    3. Hover at Z for the N - 1 - m - ceil(|qF - Z| / D) moves left (at most one when Z != P).
    4. Fly from Z to qF at v_max, the last step into qF shorter, arriving at slot N.

    m = 0 always qualifies (ScenarioConfig checks that qF is reachable from q0), so the
    trajectory is feasible for every valid config.

    Parameters
    ----------
    config : ScenarioConfig
        The scenario (its surface decides the rate; the paper's IA-FT uses the IOS).
    hover : sequence of 2 floats, optional
        Hover point P (m); default: above the ground node, ``config.ground_node``.

    Returns
    -------
    Plan
        Scheme ``"ia-ft"``; ``info`` holds the hover point, the turning point and the number
        of slots spent there.
    """
    t0 = time.perf_counter()
    check_planner("fixed", config)
    traj, turn, slots = fly_hover_fly_path(config, hover)
    target = [float(v) for v in (config.ground_node if hover is None else hover)]
    info = {
        "hover": target,
        "turning_point": turn.tolist(),
        "slots_at_turning_point": slots,  # the arrival slot plus the hover moves
        "reached_hover": bool(np.array_equal(turn, target)),
    }
    return Plan.from_trajectory("ia-ft", config, traj, time.perf_counter() - t0, info=info)


def straight_line_path(config: ScenarioConfig) -> np.ndarray:
    """(N, 2) constant-speed straight line from q0 (slot 1) to qF (slot N)."""
    q0, q_f = np.asarray(config.q0, float), np.asarray(config.qF, float)
    frac = np.arange(config.N) / (config.N - 1)
    traj = q0 + frac[:, None] * (q_f - q0)
    traj[-1] = q_f
    return traj


def straight_line(config: ScenarioConfig) -> Plan:
    """Constant-speed straight line q0 -> qF reaching qF at slot N (e.g. an SCA initialisation).

    Parameters
    ----------
    config : ScenarioConfig
        The scenario.

    Returns
    -------
    Plan
        Scheme ``"line"``; each step is |qF - q0| / (N - 1) <= D.
    """
    t0 = time.perf_counter()
    check_planner("fixed", config)
    traj = straight_line_path(config)
    return Plan.from_trajectory("line", config, traj, time.perf_counter() - t0)
