"""Energy heuristics: loiter around the rate peak, and the fly-to-the-peak-and-hover baseline.

A rotary-wing UAV spends less power cruising slowly than hovering (``docs/model.md``, "Energy"),
so for the energy efficiency the heuristic of the rate objective, "fly to the reachable rate peak
and hover there", is no longer the answer. :func:`loiter` instead

1. flies from q0 towards the reachable rate peak P (``ios_uav_env.rate_peak``) onto a circle
   around P, in ceil(distance / (V_mr dt)) moves of one constant speed: the maximum-range
   speed V_mr (the least energy per metre), or just below it so that the last move is not
   a short one; when T is too short for both legs at V_mr, at the least faster speed that
   fits (:func:`cruise_speed`);
2. circles P at the minimum-power speed V_mp: the way-points are the ``sides`` corners of a
   regular polygon inscribed in the circle, one per slot, so each move is the chord
   V_mp dt and the radius follows from the speed and the slot,
   rho = V_mp dt / (2 sin(pi / sides)) (``sides = 2``: back and forth across P);
3. leaves for qF at the last slot from which the cruise speed still arrives in time, flying the remaining
   distance at one constant speed over the moves left, so it reaches qF exactly at slot N.

The flight is the model's (``ios_uav_env.model.flights``: ``loiter_path``, ``best_loiter_path``):
the energy env's ``energy_reference="loiter"`` flies the same one. Every proposed way-point goes
through the arrival guard
(``ios_uav_env.model.guard.guarded_position``: within D of the last one and within reach of qF),
so the plan is feasible for every valid scenario, even when T leaves no time to loiter or to
fly at V_mr (both speeds are capped at v_max). :func:`hover` is the existing baseline of the
rate objective, the fly-hover-fly of ``baselines.fixed`` through the same peak, scored alike.
Both return a :class:`~baselines.plan.Plan` scored by the one scorer (``ios_uav_env.score_plan``:
rate, energy, energy efficiency). One ground node, or the peak of the first node for K > 1 (the
plan is still scored by the max-min rate).
"""

from __future__ import annotations

import time
from collections.abc import Sequence

from baselines.fixed import fly_hover_fly
from baselines.plan import Plan
from baselines.registry import check as check_planner
from ios_uav_env import ScenarioConfig
from ios_uav_env.model.flights import best_loiter_path, cruise_speed, loiter_centre, loiter_path

__all__ = ["best_loiter_path", "cruise_speed", "hover", "loiter", "loiter_path", "solve"]


def loiter(config: ScenarioConfig, sides: int = 3, peak: Sequence[float] | None = None) -> Plan:
    """The loiter heuristic as a :class:`Plan`, scheme ``"loiter"`` (module docstring): of the
    loiter paths with the legs at :func:`cruise_speed` and at 4 faster speeds up to v_max, the
    one of the best energy efficiency (faster legs leave more slots near the peak, which pays
    when T is short). ``info`` holds the peak, the circle's radius (m) and sides, the moves
    along the circle (``loiter_moves``) and the speeds."""
    t0 = time.perf_counter()
    check_planner("loiter", config)
    traj, info, _ = best_loiter_path(config, sides, loiter_centre(config, peak))
    return Plan.from_trajectory("loiter", config, traj, time.perf_counter() - t0, info=info)


def hover(config: ScenarioConfig, peak: Sequence[float] | None = None) -> Plan:
    """Fly to the reachable rate peak at v_max, hover, fly to qF arriving at slot N
    (``baselines.fixed.fly_hover_fly`` through the peak), scheme ``"hover"``."""
    t0 = time.perf_counter()
    check_planner("hover", config)
    centre = loiter_centre(config, peak)
    plan = fly_hover_fly(config, hover=centre)
    plan.seconds = time.perf_counter() - t0
    plan.scheme = "hover"
    return plan


#: The planner entry point, as in the other planner modules (``solve(config) -> Plan``).
solve = loiter
