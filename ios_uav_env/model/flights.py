"""The loiter flight: circle the rate peak at the minimum-power speed (an energy reference).

A rotary-wing UAV spends less power cruising slowly than hovering (``docs/model.md``, "Energy"),
so the EE-minded counterpart of "fly to the rate peak and hover" is to loiter around the peak.
:func:`loiter_path`

1. flies from q0 towards the reachable rate peak P onto a circle around P, in
   ceil(distance / (V_mr dt)) moves of one constant speed: the maximum-range speed V_mr (the
   least energy per metre), or just below it so that the last move is not a short one; when T
   is too short for both legs at V_mr, at the least faster speed that fits (:func:`cruise_speed`);
2. circles P at the minimum-power speed V_mp: the way-points are the ``sides`` corners of a
   regular polygon inscribed in the circle, one per slot, so each move is the chord V_mp dt and
   the radius follows from the speed and the slot, rho = V_mp dt / (2 sin(pi / sides))
   (``sides = 2``: back and forth across P);
3. leaves for qF at the last slot from which the cruise speed still arrives in time, flying the
   remaining distance at one constant speed over the moves left, so it reaches qF at slot N.

Every proposed way-point goes through the arrival guard (``guard.guarded_position``), so the
flight is feasible for every valid scenario. It is a fixed flight of the scenario, not a
planner: the energy env uses its EE as a reward reference (``energy_reference="loiter"``),
and ``baselines.loiter`` makes the loiter heuristic of it. Pure numpy, no Gymnasium.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ios_uav_env.model.config import ScenarioConfig, moves_needed
from ios_uav_env.model.guard import guarded_position
from ios_uav_env.model.peak import rate_peak
from ios_uav_env.model.propulsion import max_range_speed, min_power_speed

__all__ = ["best_loiter_path", "cruise_speed", "loiter_centre", "loiter_path"]


def loiter_centre(config: ScenarioConfig, peak: Sequence[float] | None = None) -> np.ndarray:
    """The centre (x, y) m of the loiter circle: ``peak`` checked (a finite (x, y) point, else
    ``ValueError``), or by default the reachable rate peak of the first node
    (``rate_peak(config.node_config(0))``)."""
    if peak is None:
        best = rate_peak(config.node_config(0))
        return np.array([best.x, best.y])
    point = np.asarray(peak, dtype=float)
    if point.shape != (2,) or not np.all(np.isfinite(point)):
        raise ValueError(f"peak must be a finite (x, y) point in m, got {peak!r}")
    return point


def _moves_needed(distance: float, step: float) -> int:
    """``config.moves_needed`` of one distance, on floats (the same arithmetic)."""
    return max(math.ceil(distance / step - 1e-9), 0)


def cruise_speed(config: ScenarioConfig, out: float, back: float) -> float:
    """The cruise speed (m/s) of the two legs of ``out`` and ``back`` m: the maximum-range speed
    V_mr, or, when the horizon is too short for the legs at V_mr, the least speed of a grid of
    256 speeds from V_mr to v_max whose legs fit in the N - 1 moves (v_max if none does)."""
    v_mr = min(max_range_speed(config.propulsion), config.v_max)
    for v in np.linspace(v_mr, config.v_max, 256):
        if moves_needed(out, v * config.dt) + moves_needed(back, v * config.dt) <= config.N - 1:
            return float(v)
    return config.v_max


def loiter_path(
    config: ScenarioConfig, sides: int = 3, peak: Sequence[float] | None = None, cruise: float | None = None
) -> tuple[np.ndarray, dict]:
    """The loiter trajectory (N, 2) and its description (module docstring); ``sides`` >= 2
    way-points per lap, ``peak`` (m) the centre (default: the reachable rate peak), ``cruise``
    (m/s) the legs' speed (default :func:`cruise_speed`; at least that, at most v_max)."""
    if isinstance(sides, bool) or not isinstance(sides, int) or sides < 2:
        raise ValueError(f"sides must be an integer >= 2 (way-points per lap), got {sides!r}")
    centre = loiter_centre(config, peak)
    d_max, dt = config.D, config.dt
    chord = min(min_power_speed(config.propulsion), config.v_max) * dt
    radius = chord / (2.0 * math.sin(math.pi / sides))
    q0, q_f = np.asarray(config.q0, float), np.asarray(config.qF, float)
    away = q0 - centre
    phi0 = math.atan2(away[1], away[0]) if np.any(away) else 0.0
    angles = phi0 + 2.0 * math.pi * np.arange(sides) / sides
    corners = centre + radius * np.column_stack([np.cos(angles), np.sin(angles)])
    least = cruise_speed(config, float(np.hypot(*(corners[0] - q0))), float(np.hypot(*(q_f - corners[0]))))
    out_step = min(max(least, least if cruise is None else float(cruise)), config.v_max) * dt

    # the loop on floats: the same operations as on the (2,) arrays, in the same order, at a
    # fraction of their per-call cost (the energy env computes this flight at every reset)
    hypot, step, n_slots = np.hypot, out_step, config.N
    fx, fy = float(q_f[0]), float(q_f[1])
    cx, cy = (float(v) for v in corners[0])
    traj = np.empty((n_slots, 2))
    traj[0] = q0
    px, py = float(q0[0]), float(q0[1])
    phase, corner, loiter_moves = "out", 0, 0
    for n in range(n_slots - 1):
        left = n_slots - 2 - n  # moves left after this one
        on_circle = phase == "loiter"
        if phase == "out":
            moves = max(_moves_needed(float(hypot(cx - px, cy - py)), step), 1)
            tx, ty = px + (cx - px) / moves, py + (cy - py) / moves  # one constant speed <= V_mr over the leg
            if moves == 1:
                phase = "loiter"
        elif on_circle:
            corner = (corner + 1) % sides
            tx, ty = float(corners[corner, 0]), float(corners[corner, 1])
        if phase != "back" and _moves_needed(float(hypot(fx - tx, fy - ty)), step) > left:
            phase = "back"
        if phase == "back":
            # one constant speed over the moves left
            tx, ty = px + (fx - px) / (left + 1), py + (fy - py) / (left + 1)
        else:
            loiter_moves += on_circle
        px, py = guarded_position((px, py), (tx, ty), (fx, fy), d_max, left)
        traj[n + 1] = px, py
    traj[-1] = q_f
    info = {
        "peak": centre.tolist(), "radius": radius, "sides": sides, "loiter_moves": int(loiter_moves),
        "cruise_speed": out_step / dt, "loiter_speed": chord / dt,
    }  # fmt: skip
    return traj, info


def best_loiter_path(
    config: ScenarioConfig, sides: int = 3, peak: Sequence[float] | None = None
) -> tuple[np.ndarray, dict, float]:
    """Of the loiter paths with the legs at :func:`cruise_speed` and at 4 faster speeds up to
    v_max, the one of the best energy efficiency (faster legs leave more slots near the peak,
    which pays when T is short): (trajectory, its description, its EE in bits/J)."""
    from ios_uav_env.model.score import score_plan

    centre = loiter_centre(config, peak)
    traj, info = loiter_path(config, sides, centre)
    best = score_plan(config, traj).energy_efficiency
    for v in np.linspace(info["cruise_speed"], config.v_max, 5)[1:]:
        q, more = loiter_path(config, sides, centre, float(v))
        ee = score_plan(config, q).energy_efficiency
        if ee > best:
            traj, info, best = q, more, ee
    return traj, info, float(best)
