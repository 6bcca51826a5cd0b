"""The fleet planner's candidate flights (``baselines.fleet``): the repair of a plan whose UAVs
meet, the tours' routes and their polish, the nodes' nearest lanes.

Every function takes the UAVs' own scenarios (``model.fleet.fleet_setup``'s ``configs``: each its
start, final point, speed limit and horizon as its T), so every UAV is planned over its own N_u
slots; a fleet's flights are one (U, N, 2) array, a UAV held at its final point after its horizon
(``model.fleet_horizons.hold_flights``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ios_uav_env import ScenarioConfig
from ios_uav_env.model.fleet_horizons import hold_flights, horizon_slots
from ios_uav_env.model.separation import guard_distance, guarded_moves

__all__ = ["DIRECTIONS", "guarded_flights", "nearest_lanes", "polish_routes", "route_flight"]


def guarded_flights(
    configs: list[ScenarioConfig], flights: np.ndarray, finals: np.ndarray, min_separation: float
) -> np.ndarray | None:
    """The U ``flights`` (U, N, 2) m of the UAVs' scenarios ``configs`` flown through the fleet
    env's guards (``model.separation.guarded_moves``: each UAV heads for its next way-point at its
    own speed limit, then its arrival guard to its own horizon and the separation guard at
    ``min_separation`` between the UAVs still flying), or None if a UAV then misses its final
    point: a separated flight near a plan whose UAVs come too close."""
    guard, d, n = guard_distance(min_separation), np.array([c.D for c in configs]), flights.shape[1]
    slots = horizon_slots(configs)
    out = np.empty_like(flights)
    out[:, 0] = flights[:, 0]
    for t in range(1, n):
        flying = slots > t  # the UAVs flying the move into slot t
        out[:, t] = out[:, t - 1]
        wanted = (flights[flying, t] - out[flying, t - 1]) / d[flying, None]
        moves, _ = guarded_moves(
            out[flying, t - 1], wanted, finals[flying], d[flying], slots[flying] - t - 1, guard
        )
        out[flying, t] = out[flying, t - 1] + d[flying, None] * moves
    reached = out[np.arange(len(configs)), slots - 1]
    if np.max(np.hypot(*(reached - finals).T)) > 1e-6:
        return None
    flown = [np.vstack([out[u, : last - 1], finals[u]]) for u, last in enumerate(slots)]
    return hold_flights(flown, n)


def route_flight(config: ScenarioConfig, points: np.ndarray, slots: np.ndarray) -> np.ndarray | None:
    """The flight through hover ``points`` with hover slots in the proportions of ``slots``
    (``baselines.tour.route_trajectory``), or None if the route needs more than N - 1 moves."""
    from baselines import tour

    legs = tour.route_legs(config, points)
    if legs is None:
        return None
    hover = tour.round_slots(np.maximum(slots, 0.0) + 1e-9, config.N - len(legs[0]))
    return tour.route_trajectory(config, points, hover)


#: Directions of the hover points' pattern search (:func:`polish_routes`): the axes and the diagonals.
DIRECTIONS = np.array([(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, 1), (1, -1), (-1, -1)], dtype=float)
DIRECTIONS /= np.hypot(*DIRECTIONS.T)[:, None]


def polish_routes(
    flights: np.ndarray,
    routes: list[Any],
    configs: list[ScenarioConfig],
    steps: tuple[float, ...],
    score: Any,
    budget: int | None = None,
) -> tuple[float, np.ndarray]:
    """Pattern search on the tours' hover points: move one point of one UAV by a step along one
    of :data:`DIRECTIONS`, keep the move if the fleet's value (``score(flights)``, -inf when not
    feasible and separated) rises, halve the step when none does; at most ``budget`` moved
    flights scored (None: until no step helps). Returns (value, flights)."""
    best = score(flights)
    routes = list(routes)
    left = math.inf if budget is None else int(budget)
    for step in steps:
        improved = True
        while improved and left > 0:
            improved = False
            for u, route in enumerate(routes):
                if route is None:
                    continue
                points, slots = route
                for i in range(len(points)):
                    for direction in DIRECTIONS:
                        moved = points.copy()
                        moved[i] += step * direction
                        flight = route_flight(configs[u], moved, slots)
                        if flight is None:
                            continue
                        if left <= 0:
                            return best, flights
                        left -= 1
                        trial = flights.copy()
                        trial[u] = hold_flights([flight], flights.shape[1])[0]
                        value = score(trial)
                        if value > best:
                            best, flights, points, improved = value, trial, moved, True
                            routes[u] = (points, slots)
    return best, flights


def nearest_lanes(configs: list[ScenarioConfig]) -> tuple[int, ...]:
    """Each node's UAV: the one whose straight flight passes nearest to it."""
    out = []
    for g in np.asarray(configs[0].nodes, dtype=float):
        dists = []
        for c in configs:
            a, b = np.asarray(c.q0), np.asarray(c.qF)
            s = np.clip(np.dot(g - a, b - a) / max(np.dot(b - a, b - a), 1e-12), 0.0, 1.0)
            dists.append(float(np.hypot(*(a + s * (b - a) - g))))
        out.append(int(np.argmin(dists)))
    return tuple(out)
