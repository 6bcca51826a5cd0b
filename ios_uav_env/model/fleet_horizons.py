r"""Per-UAV horizons: which UAV of a fleet flies in which slot, and how its flight sits in the
fleet's arrays.

UAV u has its own horizon T_u (s, a multiple of the slot length dt, at most the scenario's T),
hence its own slot count N_u = T_u / dt: it flies the slots 0 .. N_u - 1 of the scenario's N and
must be at its final point in slot N_u - 1 (its own arrival guard). After its horizon it is gone:
it serves no node, takes no share of the surface, causes no interference in a shared band and is
no longer part of the separation guard. The nodes' rates are still averaged over the scenario's
N slots, so a UAV that leaves early simply contributes less.

**The representation** (this module is its one place). A fleet's flights are one (U, N, 2) array
with each UAV's slot count N_u beside it (``slots``, (U,) integers): row u holds UAV u's way-points
in its slots 0 .. N_u - 1 and its final point, held, in the slots after (:func:`hold_flights`);
the held points are masked inactive (:func:`active_slots`) and nothing reads them as a flight
(the scorer, the separation check, the feasibility check of its own N_u slots). With every
horizon T (the default), every slot is active and the arrays are the flights themselves.

A UAV's own scenario is the fleet's with its start, final point, speed limit and ``T = T_u``
(``model.fleet.fleet_setup``), so its N_u is that scenario's N (:func:`horizon_slots`) and every
single-UAV tool (the env's row, the arrival guard, the DP bound, the tour) runs on it unchanged.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import Any

import numpy as np

from ios_uav_env.model.config import ScenarioConfig

__all__ = [
    "active_slots", "check_horizons", "check_slots", "flights_feasibility", "hold_flights", "horizon_slots",
]  # fmt: skip


def check_horizons(config: ScenarioConfig, uavs: int, horizons: Any) -> np.ndarray:
    """(U,) int: each UAV's slot count N_u from ``horizons`` (s, one per UAV, or one for every UAV;
    None: every UAV the scenario's T). ``ValueError`` naming ``horizons``, the UAV and the allowed
    values unless each is a finite multiple of ``config.dt`` within [2 dt, T] (N_u >= 2 slots: a
    flight has a start slot and a final slot, as every scenario's). numpy numbers are accepted."""
    n, dt = config.N, config.dt
    if horizons is None:
        return np.full(uavs, n, dtype=np.int64)
    allowed = f"a multiple of dt = {dt:g} s within [{2 * dt:g}, {config.T:g}] s (2 to N = {n} slots)"
    try:
        h = np.broadcast_to(np.asarray(horizons, dtype=float), (uavs,))
    except (TypeError, ValueError):
        raise ValueError(
            f"horizons must be None or {uavs} horizons in s (one per UAV), each {allowed}, got {horizons!r}"
        ) from None
    out = np.empty(uavs, dtype=np.int64)
    for u, value in enumerate(h):
        ratio = float(value) / dt
        whole = math.isfinite(ratio) and abs(ratio - round(ratio)) <= 1e-9 * max(1.0, abs(ratio))
        if not (whole and 2 <= round(ratio) <= n):
            raise ValueError(f"horizons[{u}] must be {allowed}, got {float(value)!r} s")
        out[u] = round(ratio)
    return out


def horizon_slots(configs: Sequence[ScenarioConfig]) -> np.ndarray:
    """(U,) int: each UAV's slot count N_u, its own scenario's N (``fleet_setup``'s ``configs``)."""
    return np.array([c.N for c in configs], dtype=np.int64)


def check_slots(slots: Any, uavs: int, n: int) -> np.ndarray:
    """(U,) int: the UAVs' slot counts ``slots`` (None: every UAV all ``n`` slots), each an integer
    in [1, n]; ``ValueError`` naming ``slots`` otherwise."""
    if slots is None:
        return np.full(uavs, n, dtype=np.int64)
    try:
        values = list(np.asarray(slots, dtype=object)) if np.ndim(slots) == 1 else []
    except ValueError:  # (a ragged nesting)
        values = []
    whole = [isinstance(s, numbers.Integral) and not isinstance(s, bool) and 1 <= s <= n for s in values]
    if len(values) != uavs or not all(whole):
        raise ValueError(
            f"slots must be None or {uavs} integers in [1, {n}] (each UAV's slot count N_u), got {slots!r}"
        )
    return np.array([int(s) for s in values], dtype=np.int64)


def active_slots(slots: Any, n: int) -> np.ndarray:
    """(U, n) bool: whether UAV u flies slot i, i < N_u, for the slot counts ``slots`` (U,)."""
    return np.arange(n)[None, :] < np.asarray(slots, dtype=np.int64)[:, None]


def hold_flights(flights: Sequence[np.ndarray], n: int) -> np.ndarray:
    """(U, n, 2) m: the UAVs' ``flights`` (each (n_u, 2) m, 1 <= n_u <= n) in one array, each
    held at its last way-point (its final point) after its own n_u slots (module docstring)."""
    out = np.empty((len(flights), n, 2))
    for u, flight in enumerate(flights):
        f = np.asarray(flight, dtype=float)
        if f.ndim != 2 or f.shape[1] != 2 or not 1 <= len(f) <= n:
            raise ValueError(
                f"flights[{u}] must be an (n_u, 2) array with 1 <= n_u <= {n}, got shape {f.shape}"
            )
        out[u, : len(f)] = f
        out[u, len(f) :] = f[-1]
    return out


def flights_feasibility(configs: Sequence[ScenarioConfig], flights: np.ndarray) -> tuple[bool, float]:
    """(whether every UAV's flight meets eq. (10) over its own slots, each on its own scenario
    ``configs[u]``, and is held at its final point after them; the worst breach of eq. (10) in m).
    Separation is the other half of a fleet's feasibility (``separation.flights_separated``)."""
    from ios_uav_env.model.trajectory import check_trajectory

    feasible, worst = True, 0.0
    for c, f in zip(configs, np.asarray(flights, dtype=float), strict=True):
        report = check_trajectory(c, f[: c.N])
        worst = max(worst, float(report.worst_violation))
        feasible = feasible and report.feasible and bool(np.all(f[c.N :] == f[c.N - 1]))
    return feasible, worst
