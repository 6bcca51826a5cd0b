r"""The certified bound of a fleet's max-min rate (``baselines.fleet``'s problem: U UAVs in
bands of their own share one IOS and serve K static nodes, each UAV over its own N_u slots).

**The bound.** For any weights w in the simplex and any schedule of a slot, node k's rate from UAV
u is at most the rate of the link (u, k) with the surface aligned to it (the closed-form phases
maximise the link's amplitude, a triangle inequality), and slot n's rates are a time-shared mix
of the choices of the UAVs flying it (u with n < N_u), so with f_w^u(q) = max_k w_k r_{u,k}(q)

    sum_k w_k R_k  <=  (1/N) sum_{n < N} sum_{u: n < N_u} f_w^u(q_u[n])
                    =  sum_u (N_u / N) (1/N_u) sum_{n < N_u} f_w^u(q_u[n])
                   <=  sum_u (N_u / N) UB_u(w),

with UB_u(w) the single-UAV bound of ``baselines.dp_bound`` on UAV u's own scenario (its start,
final point, speed limit and T = its horizon: the relaxed DP over grid cells, certified for every
continuous trajectory of that scenario, and UAV u's flight over its slots 0 .. N_u - 1 is one).
Dropping the surface's coupling and the separation only relaxes the problem, and so does dropping
a shared band's interference (it only lowers rates), so by weak duality (V = min_k R_k <=
sum_k w_k R_k for every w) V <= min_w sum_u (N_u / N) UB_u(w) in either band. Each UB_u is convex
in w with the cut UB_u(w') >= G_u . w' of its relaxed path, and N_u / N > 0 keeps both, so the
sum is convex and sum_u (N_u / N) G_u is the fleet's cut: Kelley's cuts (``dp_bound.kelley_minimise``)
minimise a certified bound. With every horizon T the factors are 1: the bound is the plain sum.
"""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np

from baselines.dp_bound import kelley_minimise, weighted_dp_path
from baselines.dp_relaxed import RelaxedDP, check_relaxed_grid
from baselines.grid import DEFAULT_MARGIN
from ios_uav_env import ScenarioConfig
from ios_uav_env.model.fleet_horizons import hold_flights, horizon_slots

__all__ = ["dual_flights", "fleet_bound"]


def fleet_bound(
    configs: list[ScenarioConfig],
    *,
    resolution: float = 5.0,
    margin: float = DEFAULT_MARGIN,
    max_cuts: int = 15,
    tol: float = 1e-3,
    start_weights: np.ndarray | None = None,
    on_weights: Any = None,
    slots: int | None = None,
) -> tuple[float, np.ndarray, float, list[dict[str, Any]]]:
    """(upper bound, its w, Kelley's lower value, per-iteration records): min over w of
    sum_u (N_u / N) UB_u(w) for the UAVs' scenarios ``configs`` (each over its own N_u slots, its
    horizon; module docstring). ``slots``: the scenario's N, over which the nodes' rates are
    averaged (default the longest horizon's N_u). ``on_weights(w)`` is called at every w tried
    (the planner's dual plans)."""
    k = configs[0].K
    for c in configs:
        check_relaxed_grid(c, resolution, margin, False)
    longest = int(horizon_slots(configs).max())
    n_slots = longest if slots is None else slots
    if isinstance(n_slots, bool) or not isinstance(n_slots, numbers.Integral) or n_slots < longest:
        raise ValueError(f"slots must be an integer >= every UAV's N_u (>= {longest}), got {slots!r}")
    scale = [c.N / n_slots for c in configs]  # each UAV's share of the N slots (1: the whole flight)
    relaxed = [RelaxedDP(c, resolution, margin) for c in configs]
    w = np.full(k, 1.0 / k) if start_weights is None else np.asarray(start_weights, dtype=float)

    def value(w: np.ndarray) -> tuple[float, np.ndarray]:
        values = [r.value(w) for r in relaxed]
        ub = float(sum(s * v for s, (v, _) in zip(scale, values, strict=True)))
        return ub, np.sum([s * g for s, (_, g) in zip(scale, values, strict=True)], axis=0)

    return kelley_minimise(value, w, max_cuts=max_cuts, tol=tol, on_weights=on_weights)


def dual_flights(
    configs: list[ScenarioConfig], w: np.ndarray, resolution: float, margin: float, n_slots: int
) -> np.ndarray | None:
    """Every UAV's plain grid DP path on f_w over its own N_u slots (``dp_bound.weighted_dp_path``;
    None if one has no grid path in time), in one (U, ``n_slots``, 2) array (each held at its
    final point after its horizon)."""
    flights = [weighted_dp_path(c, w, resolution, margin) for c in configs]
    return None if any(f is None for f in flights) else hold_flights(flights, n_slots)
