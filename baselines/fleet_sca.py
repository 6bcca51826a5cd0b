r"""Several UAVs: block-coordinate SCA of the fleet's flights (the last step of ``baselines.fleet``).

The problem is ``ios_uav_env.model.fleet``'s. :func:`refine` alternates two blocks from separated
flights (the planner's polished tours):

1. **The schedule**, exact: the pricer's LP of ``fleet_maxmin`` with every column j's choice in
   every slot kept (``baselines.fleet_schedule``): slot n time-shares the choices
   (l, a_1 .. a_U) of the columns, lambda_j each, l = (u*, k*) the link the surface lines up
   with, a_u the node UAV u serves (-1 silent: a shared band's choice).
2. **One SCA step on q_u** for each UAV u in turn, the others' flights and the schedule fixed:

       max  t + MU sum_k w_k R~_k   s.t.  R~_k >= t for every node k,

   u's speed limit (``STEP_MARGIN`` inward), start and final point, the separation (below) and
   a trust region (each way-point within ``trust`` m of its iterate, per axis); w the LP's dual
   weights, R~_k node k's flight rate with the schedule's shares: R_k(q^l) plus, for each slot n
   and column j in which u serves k, lambda_j / N times the increment of a concave lower bound of
   u's rate to k. With fixed shares the LP leaves every node at the value, so t cannot rise when
   u does not serve them all (a node served by the others only is a constant); t is then that
   constant and the step raises the dual-weighted rates with every node kept at t, which block
   1's next LP turns into max-min rate (the envelope theorem: the value's first-order change is
   w . dR).

**u's rate.** With the surface lined up with u's own link (l = (u, k)) the gain is zeta^2,
zeta = a_D + sum_m a_m (all paths in phase, whatever the Rician factor): the single-UAV model,
whose log2(1 + eta' zeta^2) is convex in the log-amplitudes, so its tangent in the slacks of
``sca_problem.Surrogate`` ((16)-(19): s for |x - x_c|^3, u_j for the tiles, v for the direct
path) is a lower bound, tight at q^l and anchored to the exact model. (17)'s log z (z = 1 at
q^l) is replaced on the trust region by its interpolation through five points, which lies below
it (linear rows, no exponential cone). With the surface lined up with another link, the surface
sum adds to the direct path with a phase that turns with q_u and can cancel it, so the direct link
alone bounds nothing; the step takes that rate at its exact value at q^l plus the tangent
increment of the direct link's log2(1 + eta' a_D^2) (the misaligned sum's change is not
modelled). eta' = eta in orthogonal bands; in a shared band the others are fixed in u's block,
so the interference I at u's node under column j's choice in slot n is a constant and
eta' = eta / (1 + eta I).

**Frozen terms and acceptance.** The others' service is a constant in u's block except where
the surface follows u's link (its phases move with q_u) and, in a shared band, through u's
interference at their nodes: both are taken at q^l, a local model, not a bound. The exact
rescoring guards it: a step is accepted only if u's flight is feasible (``check_trajectory``),
the fleet is separated all along (``flights_separated``) and block 1's value does not decrease;
a failed or rejected step is tried once more in half the trust region, then u keeps its flight
for the round. The refinement stops when a round accepts no step or gains less than ``tol``, or
after ``iterations`` rounds; the flights returned are rescored by ``fleet_maxmin``.

**Separation.** ||q_u(s) - q_v(s)|| >= d on slot n's segment (both at constant speed): with p*
the point of the iterate's relative segment [r^l[n], r^l[n+1]] nearest 0 and e = p* / |p*|,
e . r[n] >= d and e . r[n+1] >= d keep e . r(s) >= d all along it (a convex combination), so
||r(s)|| >= d: the first-order bound of ||r||^2 at p*, an inner approximation, which q^l meets
(p* is 0's projection on the segment: e . r >= |p*| there). d is raised by
``SEPARATION_MARGIN`` where q^l allows; half-planes the trust region keeps clear of are left out.

**Horizons** (``horizons``, s per UAV, as ``fleet_setup``'s; ``model.fleet_horizons``). UAV u
flies its slots 0 .. N_u - 1 and is held at its final point after them, so in u's block only its
way-points 1 .. N_u - 2 are variables (its start and its final point at slot N_u - 1 fixed, the
held points follow the final one). Block 1 prices with the slot counts (``fleet_schedule(...,
slots=)``): after its horizon a UAV serves nothing, is no alignment of the surface and causes no
interference, so it is no term of any slot's choice there. The rates are still averaged over the
scenario's N slots (the factor 1/N of R~_k), a pair has separation half-planes only on the
segments both UAVs fly, and the acceptance and the final rescoring use the slot counts
(``check_trajectory`` on u's own scenario, ``flights_separated(..., slots=)``,
``fleet_maxmin(..., slots=)``). With every horizon T (the default) every slot is flown and the
refinement is the plain one. The step's pieces (the tangent coefficients, the separation's
half-planes, the chords of (17)) are ``baselines.fleet_sca_terms``.
"""

from __future__ import annotations

import math
import numbers
import time
import warnings
from dataclasses import dataclass, field
from typing import Any

import cvxpy as cp
import numpy as np

import ios_uav_env as ie
from baselines.fleet_sca_terms import SEPARATION_MARGIN, Pieces, chords, coefficients, separation_rows
from baselines.fleet_schedule import FleetSchedule, fleet_schedule
from baselines.sca_problem import LENGTH_SCALE, OK_STATUSES, SLACK_BOUND, STEP_MARGIN, U_BOUND, Surrogate
from ios_uav_env import ScenarioConfig
from ios_uav_env.model.fleet import ACCESS, fleet_maxmin, fleet_setup
from ios_uav_env.model.fleet_horizons import horizon_slots
from ios_uav_env.model.separation import DEFAULT_SEPARATION, flights_separated

__all__ = ["MU", "NOTHING_TO_GAIN", "RETRIES", "SEPARATION_MARGIN", "TRUST", "Refinement", "refine"]

#: Weight of the dual-weighted rates in a UAV's step (module docstring).
MU = 0.1
#: m, the default half-side of a step's trust region (each way-point's box around its iterate).
TRUST = 50.0
#: Retries of a UAV's failed or rejected step, each in half the previous trust region.
RETRIES = 1
#: A step's status when u serves no node the dual weights value (no retry).
NOTHING_TO_GAIN = "serves no node the dual weights value"


@dataclass
class Refinement:
    """:func:`refine`'s answer: the flights (U, N, 2) m, their ``value`` (``fleet_maxmin``) and the
    start's, the rounds run, why it stopped and every step (``history``)."""

    trajectories: np.ndarray
    value: float
    start_value: float
    rounds: int
    stop: str
    seconds: float
    history: list[dict[str, Any]] = field(default_factory=list)


def _step(
    config: ScenarioConfig,
    uav: ScenarioConfig,
    sched: FleetSchedule,
    u: int,
    flights: np.ndarray,
    surrogates: list[Surrogate],
    d_min: float,
    access: str,
    solver: str,
    trust: float,
    slots: np.ndarray | None = None,
) -> tuple[np.ndarray | None, float, str]:
    """One SCA step on UAV u's flight over its own N_u = ``uav.N`` slots (module docstring; the
    others' slot counts ``slots`` (U,), default N each): (its (N_u, 2) flight or None, surrogate t,
    status)."""
    n_n, n_u, k_n, scale = config.N, uav.N, config.K, LENGTH_SCALE  # rates averaged over N slots
    q = flights[u, :n_u]
    m = n_u - 2
    if m <= 0:
        return None, math.nan, "no interior slot"
    pieces = [Pieces(s, flights[u], m) for s in surrogates]
    cd, cb, cc = (c * n_n for c in coefficients(config, sched, u, pieces, access))  # per-slot units
    xc, yc = config.ios_center[0], config.ios_center[1]
    xi, psi = cp.Variable(m), cp.Variable(m)
    ends = (q[[0, -1]] - (xc, yc)) / scale
    xs = cp.hstack([ends[:1, 0], xi, ends[1:, 0]])
    ys = cp.hstack([ends[:1, 1], psi, ends[1:, 1]])
    dmax = (uav.D - STEP_MARGIN) / scale  # inward, so the solver's rounding keeps every step <= D
    cons = [
        cp.norm(cp.vstack([cp.diff(xs), cp.diff(ys)]), 2, axis=0) <= dmax,
    ]
    # the slacks only where they count: the surface's in the slots whose aligned terms do, the
    # direct path's where u serves the node, the squares' epigraphs X2 >= xi^2, Y2 >= psi^2 in
    # those slots (an idle slack or epigraph is unbounded: a degenerate problem for the solver)
    surf = np.flatnonzero((cb > 0).any(axis=1)) if config.surface != "none" else np.zeros(0, dtype=int)
    x2, y2 = cp.Variable(m), cp.Variable(m)
    needed = np.union1d(surf, np.flatnonzero((cd > 0).any(axis=1)))
    cons += [cp.square(xi[needed]) <= x2[needed], cp.square(psi[needed]) <= y2[needed]]
    idle = np.setdiff1d(np.arange(m), needed)
    if len(idle):
        cons += [x2[idle] == 0, y2[idle] == 0]
    s = uu = None
    if len(surf):
        first = surrogates[0]
        x_l = (q[1:-1, 0][surf] - xc) / scale
        s, uu = cp.Variable(len(surf)), cp.Variable((len(surf), first.n_tiles))
        yk = (first.node_y - yc) / scale
        const = yk**2 + ((config.uav_altitude - first.node_z) / scale) ** 2
        r2 = x2[surf] + y2[surf]
        d_j2 = cp.reshape(r2, (len(surf), 1), order="C") @ np.ones((1, first.n_tiles))
        d_j2 = d_j2 - cp.reshape(psi[surf], (len(surf), 1), order="C") @ (2 * yk)[None, :]
        d_j2 = d_j2 + np.ones((len(surf), 1)) @ const[None, :]
        dl2 = pieces[0].values["dl2"][surf]
        cons += [
            *chords(s, cp.multiply(3.0 / x_l, xi[surf]) - 2.0, 3.0 * trust / scale / np.abs(x_l)),  # (17)
            d_j2 <= dl2 + 0.5 * cp.multiply(dl2, uu),  # (18)
            s >= -SLACK_BOUND,
            uu <= U_BOUND,
        ]
    zu = config.uav_altitude / scale
    rates = []
    for k, (gx, gy) in enumerate(config.nodes):
        rate: Any = n_n * float(sched.rates[k])
        used = np.flatnonzero(cd[:, k] > 0)
        if len(used):
            v = cp.Variable(len(used))
            xg, yg = (gx - xc) / scale, (gy - yc) / scale
            d_ug2 = x2[used] - 2 * xg * xi[used] + y2[used] - 2 * yg * psi[used] + (xg**2 + yg**2 + zu**2)
            gl2 = pieces[k].values["gl2"][used]
            cons += [d_ug2 <= gl2 - (4.0 / config.alpha) * cp.multiply(gl2, v), v >= -SLACK_BOUND]  # (19)
            rate = rate + cd[used, k] @ v
        if s is not None and np.any(cb[surf, k] > 0):
            rate = rate + cb[surf, k] @ s + cp.sum(cp.multiply(cc[surf, k], uu))
        rates.append(rate)
    # a node u does not serve keeps its rate: t is capped there and, if the others are at or
    # above that cap, t = cap is reached at q^l already; t is then that constant (a free t
    # pinned by a constant row leaves the interior-point solver a degenerate problem)
    served = [k for k in range(k_n) if not isinstance(rates[k], float)]
    if not np.any(sched.dual[served] > 0):  # u serves no node the dual weights value
        return None, math.nan, NOTHING_TO_GAIN
    fixed = [rates[k] for k in range(k_n) if k not in served]
    moving = [rates[k] for k in served]
    lowest = n_n * float(np.min(sched.rates[served], initial=np.inf))
    if fixed and min(fixed) <= lowest * (1 + 1e-6):
        t: Any = min(fixed + [lowest])
    else:
        t = cp.Variable()
        cons += [t <= r for r in fixed]
    cons += [r >= t for r in moving]
    # the trust region: each way-point within a box of half-side ``trust`` m of its iterate; a
    # separation half-plane that the box keeps clear of cannot bind and is left out
    interior_l = (q[1:-1] - (xc, yc)) / scale
    box = trust / scale
    cons += [xi >= interior_l[:, 0] - box, xi <= interior_l[:, 0] + box]
    cons += [psi >= interior_l[:, 1] - box, psi <= interior_l[:, 1] + box]
    others = None if slots is None else np.delete(slots, u)
    rows = [r for r in separation_rows(q, np.delete(flights, u, axis=0), d_min, others)
            if float(r[1] @ q[r[0]]) - r[2] <= math.sqrt(2.0) * trust + 1.0]  # fmt: skip
    if rows:
        slot = np.array([r[0] for r in rows]) - 1
        e = np.array([r[1] for r in rows])
        rhs = (np.array([r[2] for r in rows]) - e @ np.array([xc, yc])) / scale
        cons.append(cp.multiply(e[:, 0], xi[slot]) + cp.multiply(e[:, 1], psi[slot]) >= rhs)
    weighted = sum(float(sched.dual[k]) * rates[k] for k in served)
    objective = weighted if isinstance(t, float) else t + MU * weighted
    problem = cp.Problem(cp.Maximize(objective), cons)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            problem.solve(solver=solver, warm_start=False)
    except cp.error.SolverError as err:
        return None, math.nan, f"solver_error: {err}"
    status = str(problem.status)
    if status not in OK_STATUSES or xi.value is None or psi.value is None:
        return None, math.nan, status
    interior = np.column_stack([xi.value, psi.value]) * scale + (xc, yc)
    return np.vstack([q[:1], interior, q[-1:]]), float(getattr(t, "value", t)) / n_n, status


def _count(value: Any, name: str, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < low:
        raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    return int(value)


def refine(
    config: ScenarioConfig,
    trajectories: np.ndarray,
    *,
    access: str = "orthogonal",
    min_separation: float = DEFAULT_SEPARATION,
    speeds: Any = None,
    horizons: Any = None,
    iterations: int = 5,
    tol: float = 1e-4,
    trust: float = TRUST,
    tiles: int = 2,
    solver: str = "CLARABEL",
    progress: bool = False,
) -> Refinement:
    """Block-coordinate SCA of the U separated ``trajectories`` (U, N, 2) m (module docstring):
    at most ``iterations`` rounds (>= 0) of one step per UAV, stopped when a round gains less than
    ``tol`` (relative, > 0). Each UAV flies from its first way-point to its final point at its
    speed limit (``speeds``) within its horizon (``horizons``, s; both as ``fleet_setup``'s:
    UAV u flies slots 0 .. N_u - 1 and is held at its final point after, ``model.fleet_horizons``);
    ``tiles`` x ``tiles`` surface tiles model the surrogate's curvature (``sca_problem``);
    ``trust`` (m) is a step's trust region and ``solver`` cvxpy's solver. The flights must be
    feasible, held after each horizon and separated by ``min_separation`` m all along while both
    UAVs of a pair fly; the value (``fleet_maxmin`` with each UAV's slot count) never decreases."""
    t0 = time.perf_counter()
    if not isinstance(config, ScenarioConfig):
        raise TypeError(f"config must be a ScenarioConfig, got {type(config).__name__}")
    if access not in ACCESS:
        raise ValueError(f"access must be one of {ACCESS}, got {access!r}")
    rounds = _count(iterations, "iterations", 0)
    tiles = _count(tiles, "tiles", 1)
    if not (isinstance(trust, numbers.Real) and not isinstance(trust, bool) and 0 < trust < math.inf):
        raise ValueError(f"trust must be a finite number > 0 (m), got {trust!r}")
    if not (isinstance(tol, numbers.Real) and not isinstance(tol, bool) and 0 < tol < 1):
        raise ValueError(f"tol must be a number in (0, 1), got {tol!r}")
    flights = np.array(trajectories, dtype=float)
    if flights.ndim != 3 or flights.shape[1:] != (config.N, 2) or not np.all(np.isfinite(flights)):
        raise ValueError(
            f"trajectories must be a finite (U, N={config.N}, 2) array in m, got shape {flights.shape}"
        )
    u_n = flights.shape[0]
    _, _, configs = fleet_setup(
        config, u_n, flights[:, 0], flights[:, -1], min_separation, access, speeds, horizons
    )
    slots = horizon_slots(configs)  # each UAV's N_u
    for u, (c, f) in enumerate(zip(configs, flights, strict=True)):
        if not (ie.check_trajectory(c, f[: c.N]).feasible and np.all(f[c.N :] == f[c.N - 1])):
            raise ValueError(
                f"trajectories[{u}] is not a feasible flight of UAV {u} (speed limit, endpoints, "
                f"held at its final point after its N_u = {c.N} slots)"
            )
    if not flights_separated(flights, float(min_separation), slots):
        raise ValueError(
            f"trajectories are not separated by min_separation = {min_separation:g} m all along "
            "(each pair while both fly)"
        )
    start_value = fleet_maxmin(config, flights, access=access, slots=slots).value
    history: list[dict[str, Any]] = []
    stop, done = "iterations", 0
    if rounds:
        surrogates = [
            Surrogate(config.node_config(k), tiles, solver.upper(), dpp=False) for k in range(config.K)
        ]
        sched = fleet_schedule(config, flights, access, slots)
    for it in range(rounds):
        done, before, accepted = it + 1, sched.value, 0
        for u in range(u_n):
            rho = float(trust)
            for _ in range(1 + RETRIES):  # a failed or rejected step is tried again in half the box
                record: dict[str, Any] = {"round": it, "uav": u, "trust": rho, "value": None,
                                          "accepted": False}  # fmt: skip
                history.append(record)
                q_new, record["surrogate"], record["status"] = _step(
                    config, configs[u], sched, u, flights, surrogates, float(min_separation), access,
                    solver.upper(), rho, slots,
                )  # fmt: skip
                rho /= 2.0
                if q_new is None:
                    if record["status"] == NOTHING_TO_GAIN:
                        break
                    continue
                trial = flights.copy()
                trial[u, : len(q_new)], trial[u, len(q_new) :] = q_new, q_new[-1]  # held after N_u
                if not ie.check_trajectory(configs[u], q_new).feasible:
                    record["status"] += ", infeasible"
                    continue
                if not flights_separated(trial, float(min_separation), slots):
                    record["status"] += ", not separated"
                    continue
                new = fleet_schedule(config, trial, access, slots)
                record["value"] = new.value
                if progress:
                    print(f"[fleet-sca] round {it} UAV {u}: {sched.value:.6f} -> {new.value:.6f}", flush=True)
                if new.value >= sched.value:
                    flights, sched, record["accepted"] = trial, new, True
                    accepted += 1
                    break
        if not accepted:
            stop = "no step accepted"
            break
        if sched.value - before < tol * max(before, 1e-300):
            stop = "converged"
            break
    value = fleet_maxmin(config, flights, access=access, slots=slots).value if done else start_value
    if value < start_value:  # rounding between the two pricings' sums: keep the start
        flights, value, stop = np.array(trajectories, dtype=float), start_value, f"{stop}, start kept"
    return Refinement(flights, value, start_value, done, stop, time.perf_counter() - t0, history)
