r"""The paper's algorithm (Section III): alternating optimisation with SCA for the trajectory.

**Alternation.** Given a trajectory, the optimal phases are closed form, eq. (13)
(``ios_uav_env.model.channel.phase_shifts``); they align every path, so the expected gain of slot n is
zeta(q[n])^2 with the phase-aligned amplitude of the model (``ios_uav_env.model.channel.zeta``). The phase
step is therefore implicit in zeta, and each outer iteration is one SCA step on the
trajectory, problem (25):

    max_Q (1/N) sum_n log2(1 + eta zeta(q[n])^2)   s.t. (10b)-(10c),
    zeta(q) = sum_k c_k(q) |x - x_c|^3 / d_k(q)^4 + K d_UG(q)^(-alpha/2),

with c_k = J s(q) w_k, s(q) the side factor (1 reflection, epsilon / 0 transmission),
(y_k, z_k, w_k) the weighted nodes ("tiles") of ``ios_uav_env.model.surface.surface_nodes`` and
d_k^2 = (x - x_c)^2 + (y - y_k)^2 + (z_U - z_k)^2, K = sqrt(G_tx G_rx). With
the default compression the nodes reproduce the element sum to ``config.quadrature_tol``; SCA
uses ``tiles`` x ``tiles`` nodes (default 2, 4 tiles) and the exact model scores every iterate.

**Problem (15)** (per slot; one u_k per tile, not per element):

    max (1/N) sum_n f(s, u, v),  f = log2(1 + eta (sum_k c_k e^{s - u_k} + K e^v)^2)
    s.t. e^s <= |x - x_c|^3,  e^{u_k} >= d_k^4,  e^v <= d_UG^(-alpha/2),  (10b)-(10c).

At the optimum every slack constraint is tight (f increases in s and v, decreases in u_k),
so (15) is (25). f is convex in (s, u, v): log zeta is a log-sum-exp, and
f = softplus(2 log zeta + ln eta) / ln 2 with softplus convex and increasing.

**Derivation of (16).** Write t_k = c_k e^{s - u_k} (tile k's amplitude), S = sum_k t_k,
zeta = S + K e^v, A = 1 + eta zeta^2. Then d zeta/ds = S, d zeta/du_k = -t_k,
d zeta/dv = K e^v and, with f = log2 A,

    B   = dA/ds   = 2 eta zeta S,
    C_k = dA/du_k = -2 eta zeta t_k,
    D   = dA/dv   = 2 eta zeta K e^v,

all at the linearisation point (s^l, u^l, v^l) = (3 ln|x^l - x_c|, 4 ln d_k(q^l),
-(alpha/2) ln d_UG(q^l)). Since f is convex its tangent is a global under-estimator:

    f >= log2 A^l + [B^l (s - s^l) + sum_k C_k^l (u_k - u_k^l) + D^l (v - v^l)] / (A^l ln 2).  (16)

Expanding zeta^2 = S^2 + 2 S K e^v + K^2 e^{2v} gives the paper's printed A, B, C_m, D
term by term, so those agree with this derivation once zeta is read as (15a)'s sum. The
paper's inconsistencies are elsewhere: (24) states E|h|^2 = zeta (it is zeta^2, as (25)
uses); (17) and (25) write |x|^3 for |x - x_m|^3 (x_m = 0 there); the proof of Prop. 2
says e^v replaces d_UG^4 (it replaces d_UG^(-alpha/2), as (15d) says); (20) applies 1/N to
the first term only and drops the constants of (16), which are needed for (16) to be a
bound; (14) keeps the random h_SS (and its phase lacks 2 pi) although the algorithm
optimises the expectation (25).

**Inner approximations (17)-(19)** (replace each non-convex constraint by a convex
restriction: the tangent of a convex function lies below it):

    (17) e^s <= |x^l|^3 + 3 x^l |x^l| (x - x^l)                 (|x|^3 convex on each side;
         here x is x - x_c and the right side is > 0 only for x / x^l > 2/3: x stays on
         its side of the plane within an iteration)
    (18) d_k^2 <= e^{u_k^l / 2} (1 + (u_k - u_k^l) / 2)           (e^{u/2} convex; d_k^2 is
         a convex quadratic of (x, y))
    (19) d_UG^2 <= e^{-4 v^l / alpha} (1 - (4 / alpha)(v - v^l))   (e^{-4v/alpha} convex)

Problem (20) maximises the right side of (16) over (Q, s, u, v) subject to (17)-(19) and
(10b)-(10c): one exponential cone per slot (17), second-order cones for (18), (19) and the
steps. In the solver the slacks are offsets from their linearisation values (s' = s - s^l,
...): (17) becomes s' <= log(3 (x - x_c)/(x^l - x_c) - 2), (18) d_k^2 <= d_k(q^l)^2 (1 +
u'_k/2), (19) d_UG^2 <= d_UG(q^l)^2 (1 - 4 v'/alpha); lengths are in 100 m and the objective
coefficients are B/(A ln 2)/N etc. (dimensionless, <= 2/ln 2 per slot). Every squared
distance is affine in (x, y, X2, Y2) with epigraph variables X2 >= (x - x_c)^2,
Y2 >= (y - y_c)^2 (exact, as distances only appear on the small side of <=), so there are
two second-order cones per slot whatever the number of tiles. See :mod:`baselines.sca_problem`.

**Why every iterate improves.** q^l with zero offsets is feasible for (20) and its value
there is the rate at q^l; the optimum q^(l+1) satisfies the original slack constraints, so
exact(q^(l+1)) >= (16) at the optimum >= (16) at q^l = exact(q^l). Two approximations are
controlled: (i) tiling: the tiled per-node terms are *anchored* per slot (multiplied by
exact / tiled surface amplitude at q^l), so the surrogate equals the exact rate at q^l and
only its curvature uses the tiles (the bound then holds to the change of exact / tiled
between q^l and q^(l+1)); (ii) the step constraint has an inward margin of 1e-6 m; (iii) a
slot within 0.1 m of the plane drops its surface term (below 1e-7 of zeta there).
Every iterate is scored by ``ios_uav_env.average_rate`` and checked by
``ios_uav_env.check_trajectory``; the history records the exact rate of every solve
(accepted or not), and an iterate that lowers the exact rate is not accepted (the run
stops there, flagged ``"decrease"`` when beyond 1e-9 relative).

**Reflection vs transmission.** A slot's side is fixed by the current iterate: (17) keeps
x - x_c on the sign of x^l - x_c (it may shrink by at most 1/3 of its distance to the
plane per iteration), so the surrogate's side factor stays right. Slots with
|x^l - x_c| < ``PLANE_TOL`` (0.1 m), and slots whose surface term is 0 (RIS on the
transmissive side, or no surface), drop the surface term in that iteration: their surrogate
is the tangent of the direct-link rate, a valid lower bound on either side (the surface
term is >= 0), so those slots may cross the plane. A consequence: on the IOS a slot never
crosses the plane, so the slot at which the UAV crosses is set by the initial trajectory;
the multi-start covers this. Hovering on the transmissive side is kept: from a fly-hover-fly
to a point behind the IOS (x > 0, G at x = -100) SCA keeps hovering there (this is the
IA optimum of the default scenario, at (100.0, -0.2) m; see the tests and the benchmark).

**Multi-start (SCA is local).** Default starts (:func:`default_starts`): the straight
line; fly-hover-fly (``baselines.fixed.fly_hover_fly``) above G; fly-hover-fly to the reachable
rate peak (``ios_uav_env.rate_peak``) on G's side of the plane ("front") and on the other
side ("behind"), each skipped when within D of an
earlier hover point; and "DP + SCA polish", a coarse ``baselines.dp.solve`` at 5 m (at 10 m
the grid's moves are slower than v_max and, the crossing slot being fixed, the polish ends
lower). The best plan by the exact objective wins.

**Tiles.** Default 2 x 2: thanks to the anchoring the tile count changes the curvature of
the surrogate only, not its value at q^l (measurements: ``benchmarks/README.md``).

**Solver.** Clarabel (interior point, native exponential and second-order cones). Each
solve builds a fresh Clarabel instance (``warm_start=False``): cvxpy's in-place data update of
the cached instance can fail spuriously. The slack offsets are boxed (s', v' >= -10,
u' <= 10; q^l stays feasible, so the guarantees hold; it acts as a loose trust region, d_k at
most 2.4x and d_UG at most 3x their values at q^l per iteration), which keeps the solver's
conditioning sane on long horizons.

**DPP.** Every linearisation point and coefficient is a ``cvxpy.Parameter``: the problem is
canonicalised once (cached across ``solve`` calls for the same config, tiles and solver) and
each iteration only rewrites the parameter values.

**Failures.** A solver exception or a status other than optimal / optimal_inaccurate stops
that start with ``"solver_error: ..."`` in the history and keeps its last feasible iterate;
so does an iterate that fails ``check_trajectory`` (``"infeasible_iterate ..."``).
``info["status"]`` is then ``"partial_failure"`` or ``"failed"`` (a stop on an exact decrease
counts too), and a ``RuntimeWarning`` says so when the winning start hit a solver error or an
infeasible iterate. A losing start's stop is only recorded: it did not produce the plan
(though it might have won had it run on).
A solver name cvxpy does not know raises ``ValueError``; a known one that is not installed or
cannot take exponential cones (e.g. "OSQP") fails at the first solve and falls back.
"""

from __future__ import annotations

import math
import time
import warnings
from typing import Any

import numpy as np

import ios_uav_env as ie
from baselines.plan import Plan
from baselines.sca_problem import PLANE_TOL, STEP_MARGIN, Surrogate, tiled_config
from ios_uav_env import ScenarioConfig
from ios_uav_env.model import channel as ch
from ios_uav_env.model.peak import rate_peak

#: Default tiles per axis (2 x 2 = 4 nodes; see the module docstring).
DEFAULT_TILES = 2
#: Default cap on SCA iterations per start.
DEFAULT_MAX_ITERS = 50
#: An exact-objective decrease beyond this (relative) is flagged ``"decrease"``.
DECREASE_TOL = 1e-9
#: DP resolution (m) of the "DP + SCA polish" start.
DP_START_RESOLUTION = 5.0
SCHEME_NAMES = {"ios": "ia", "ris": "ra", "none": "cuc"}

__all__ = ["DEFAULT_TILES", "PLANE_TOL", "STEP_MARGIN", "default_starts", "solve", "tiling_error"]


def _known_solvers() -> set[str]:
    """Every solver name cvxpy knows (installed or not; whether it can take this problem's
    exponential and second-order cones is found out, and recorded, when it is called)."""
    from cvxpy.reductions.solvers.defines import SOLVER_MAP_CONIC, SOLVER_MAP_QP

    return set(SOLVER_MAP_CONIC) | set(SOLVER_MAP_QP)


def _validate(config: Any, tiles: Any, max_iters: Any, tol: Any, solver: Any) -> None:
    if not isinstance(config, ScenarioConfig):
        raise TypeError(f"config must be a ScenarioConfig, got {type(config).__name__}")
    if isinstance(tiles, bool) or not isinstance(tiles, (int, np.integer)) or not 1 <= tiles <= 64:
        raise ValueError(f"tiles must be an integer in [1, 64] (nodes per axis), got {tiles!r}")
    if isinstance(max_iters, bool) or not isinstance(max_iters, (int, np.integer)) or max_iters < 1:
        raise ValueError(f"max_iters must be an integer >= 1, got {max_iters!r}")
    if not (isinstance(tol, (int, float)) and math.isfinite(tol) and tol > 0):
        raise ValueError(f"tol must be a finite number > 0 (relative improvement), got {tol!r}")
    if not isinstance(solver, str) or solver.upper() not in _known_solvers():
        raise ValueError(f"solver must be a cvxpy solver name, e.g. 'CLARABEL' or 'SCS', got {solver!r}")


# --- initial trajectories -----------------------------------------------------------------


def best_hover_points(config: ScenarioConfig) -> dict[str, tuple[float, float]]:
    """The reachable rate peak (``ios_uav_env.rate_peak``) on each side of the surface plane:
    keys ``"front"`` (G's side) and ``"behind"``, each present when a reachable point lies there."""
    out = {}
    for side in ("front", "behind"):
        peak = rate_peak(config, side=side)
        if peak is not None:
            out[side] = (peak.x, peak.y)
    return out


def default_starts(config: ScenarioConfig, dp_start: bool = True) -> list[tuple[str, np.ndarray]]:
    """The default multi-start set: ``[(name, trajectory), ...]`` (see the module docstring)."""
    from baselines.fixed import fly_hover_fly, straight_line

    starts = [("line", straight_line(config).trajectory)]
    hovers = [("G", tuple(config.ground_node))]
    hovers += [(f"{side}({p[0]:g},{p[1]:g})", p) for side, p in best_hover_points(config).items()]
    kept: list[tuple[float, float]] = []
    for name, point in hovers:  # hover points closer than D to a kept one add nothing new
        if all(math.dist(point, k) >= config.D for k in kept):
            kept.append(point)
            starts.append((f"fhf-{name}", fly_hover_fly(config, point).trajectory))
    if dp_start:
        from baselines.dp import solve as dp_solve

        try:
            plan = dp_solve(config, resolution=DP_START_RESOLUTION)
        except ValueError:  # no grid path reaches qF in time (tight horizon): the other starts remain
            pass
        else:
            starts.append((f"dp{DP_START_RESOLUTION:g}", plan.trajectory))
    unique: list[tuple[str, np.ndarray]] = []
    for name, q in starts:
        if not any(q.shape == u.shape and np.allclose(q, u, atol=1e-9) for _, u in unique):
            unique.append((name, np.asarray(q, dtype=float)))
    return unique


def _as_starts(config: ScenarioConfig, init: Any) -> list[tuple[str, np.ndarray]]:
    if init is None:
        return default_starts(config)
    items = [init] if (hasattr(init, "trajectory") or np.ndim(init) == 2) else list(init)
    if not items:
        raise ValueError("init must be a trajectory (N, 2), a Plan, or a non-empty list of them")
    out = []
    for i, item in enumerate(items):
        q = np.asarray(getattr(item, "trajectory", item), dtype=float)
        if q.shape != (config.N, 2) or not np.all(np.isfinite(q)):
            raise ValueError(f"init[{i}] must be a finite (N={config.N}, 2) trajectory, got shape {q.shape}")
        report = ie.check_trajectory(config, q)
        if not report.feasible:
            raise ValueError(f"init[{i}] must be feasible for eq. (10): {report}")
        out.append((f"init{i}", q.copy()))
    return out


# --- tiling error -------------------------------------------------------------------------


def tiling_error(config: ScenarioConfig, trajectory: np.ndarray, tiles: int) -> dict[str, float]:
    """Error of the tiled model (``tiles`` x ``tiles`` nodes, no anchoring) on ``trajectory``.

    Against the config's own model (the one that scores plans): ``zeta_max_rel`` =
    max_n |zeta_tiled - zeta| / zeta, ``rate_abs`` / ``rate_rel`` = error of the mean rate.
    """
    tiled = tiled_config(config, tiles)
    z_exact, z_tiled = ch.zeta(config, trajectory), ch.zeta(tiled, trajectory)
    r_exact, r_tiled = ie.average_rate(config, trajectory), ie.average_rate(tiled, trajectory)
    return {
        "zeta_max_rel": float(np.max(np.abs(z_tiled - z_exact) / z_exact)),
        "rate_abs": abs(r_tiled - r_exact),
        "rate_rel": abs(r_tiled - r_exact) / max(abs(r_exact), 1e-300),
    }


# --- the algorithm ------------------------------------------------------------------------

_CACHE: dict[tuple[Any, ...], Surrogate] = {}
_CACHE_SIZE = 8


def _surrogate(
    config: ScenarioConfig, tiles: int, solver: str, dpp: bool, options: dict[str, Any] | None
) -> Surrogate:
    """The compiled surrogate for (config, tiles, solver), reused across calls (DPP)."""
    if not dpp:
        return Surrogate(config, tiles, solver, dpp=False, solver_options=options)
    key = (config, tiles, solver)
    if key not in _CACHE:
        if len(_CACHE) >= _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))
        _CACHE[key] = Surrogate(config, tiles, solver, dpp=True)
    surrogate = _CACHE[key]
    surrogate.solver_options = dict(options or {})
    return surrogate


def _run(
    surrogate: Surrogate,
    q_init: np.ndarray,
    start: str,
    max_iters: int,
    tol: float,
    history: list[dict[str, Any]],
    verbose: bool,
    record_iterates: bool = False,
) -> tuple[np.ndarray, float, int, str]:
    """SCA from one start: (best feasible trajectory, its exact rate, solves, stop reason)."""
    config = surrogate.config
    q, rate = q_init, ie.average_rate(config, q_init)
    history.append(
        {"start": start, "iteration": 0, "mean_rate": rate, "surrogate": None, "status": "init",
         "seconds": 0.0, "solver_seconds": 0.0, "accepted": True, "rel_improvement": None,
         "worst_violation": ie.check_trajectory(config, q).worst_violation}
    )  # fmt: skip
    if record_iterates:
        history[-1]["trajectory"] = q.tolist()
    stop = "max_iters"
    for it in range(1, max_iters + 1):
        lin = surrogate.linearise(q)
        t0 = time.perf_counter()
        try:
            q_new, value, status, solver_seconds = surrogate.solve(lin, verbose=verbose)
        except Exception as exc:  # any solver failure falls back to the last iterate
            q_new, value, status, solver_seconds = (
                None,
                float("nan"),
                f"solver_error: {type(exc).__name__}: {exc}",
                0.0,
            )
        record = {"start": start, "iteration": it, "mean_rate": None, "surrogate": None, "status": status,
                  "seconds": time.perf_counter() - t0, "solver_seconds": solver_seconds, "accepted": False,
                  "rel_improvement": None, "worst_violation": None}  # fmt: skip
        history.append(record)
        if q_new is not None and not np.all(np.isfinite(q_new)):  # a broken solution: a failure
            q_new, status = None, f"solver_error: non-finite trajectory (status {status})"
            record["status"] = status
        if q_new is None:
            if not status.startswith("solver_error"):
                record["status"] = f"solver_error: status {status}"
            stop = "solver_error"
            break
        report = ie.check_trajectory(config, q_new)
        new_rate = ie.average_rate(config, q_new)
        rel = (new_rate - rate) / max(abs(rate), 1e-300)
        record.update(mean_rate=new_rate, surrogate=value, rel_improvement=rel,
                      worst_violation=report.worst_violation)  # fmt: skip
        if record_iterates:
            record["trajectory"] = q_new.tolist()
        if not report.feasible:
            record["status"] = f"infeasible_iterate ({status}): {report}"
            stop = "infeasible_iterate"
            break
        if rel < 0:
            stop = "decrease" if rel < -DECREASE_TOL else "converged"
            break
        record["accepted"] = True
        q, rate = q_new, new_rate
        if rel < tol:
            stop = "converged"
            break
    n_solves = sum(1 for h in history if h["start"] == start and h["iteration"] > 0)
    return q, rate, n_solves, stop


def solve(
    config: ScenarioConfig,
    *,
    tiles: int = DEFAULT_TILES,
    init: Any = None,
    max_iters: int = DEFAULT_MAX_ITERS,
    tol: float = 1e-4,
    solver: str = "CLARABEL",
    dpp: bool = True,
    solver_options: dict[str, Any] | None = None,
    record_iterates: bool = False,
    progress: bool = False,
    verbose: bool = False,
) -> Plan:
    """Trajectory of problem (10) by the paper's alternating optimisation / SCA, multi-start.

    Parameters
    ----------
    config : ScenarioConfig
        The scenario; ``surface`` "ios" (IA), "ris" (RA) or "none" (CUC).
    tiles : int
        Nodes per axis of the surface sum in the surrogate (``tiles`` x ``tiles`` slacks u_k
        per slot), >= 1. The exact model scores every iterate whatever ``tiles`` is.
    init : trajectory (N, 2), Plan, or a list of them, optional
        Feasible starting trajectories; None = :func:`default_starts`.
    max_iters : int
        Cap on SCA iterations (convex solves) per start, >= 1.
    tol : float
        Stop a start when the relative improvement of the exact mean rate is < ``tol``
        (the paper's mu = 1e-4), > 0.
    solver : str
        cvxpy conic solver, "CLARABEL" (default) or e.g. "SCS".
    dpp : bool
        Compile the surrogate once with parameters (default) instead of every iteration.
    solver_options : dict, optional
        Extra keyword arguments for the solver (e.g. Clarabel settings).
    record_iterates : bool
        Also store every iterate's trajectory (as a list) in its history record.
    progress : bool
        Print one line per start.
    verbose : bool
        Pass ``verbose`` to the solver.

    Returns
    -------
    Plan
        Scheme "ia" / "ra" / "cuc"; ``history`` has one record per start and iteration
        (``start``, ``iteration``, exact ``mean_rate``, ``surrogate`` value, solver
        ``status``, ``seconds``, ...); ``info`` has ``tiles``, ``tiling_error``, the
        winning ``start``, per-start summaries, ``n_iters`` and ``status``.

    Several ground nodes (K > 1): :func:`baselines.sca_multi.solve` (block-coordinate descent:
    TDMA shares by LP, the trajectory by this SCA for fixed shares, multi-start from the tour
    heuristic); ``dpp``, ``solver_options``, ``record_iterates`` and ``verbose`` do not apply.

    Raises
    ------
    ValueError
        Bad ``tiles``, ``max_iters``, ``tol``, ``solver`` or ``init``.
    """
    t_start = time.perf_counter()
    _validate(config, tiles, max_iters, tol, solver)
    if config.K > 1:  # several ground nodes: the same SCA inside BCD with the TDMA shares
        from baselines import sca_multi

        return sca_multi.solve(config, tiles=int(tiles), init=init, max_iters=int(max_iters), tol=float(tol),
                               solver=solver, progress=progress)  # fmt: skip
    solver = solver.upper()
    starts = _as_starts(config, init)
    surrogate = _surrogate(config, int(tiles), solver, dpp, solver_options)
    was_compiled = surrogate.compiled
    history: list[dict[str, Any]] = []
    summaries: list[dict[str, Any]] = []
    best: tuple[float, np.ndarray, str] | None = None
    for name, q0 in starts:
        t0 = time.perf_counter()
        init_rate = ie.average_rate(config, q0)
        q, rate, n, stop = _run(
            surrogate, q0, name, int(max_iters), float(tol), history, verbose, record_iterates
        )
        summaries.append({"start": name, "init_rate": init_rate, "mean_rate": rate, "iters": n, "stop": stop,
                          "seconds": time.perf_counter() - t0})  # fmt: skip
        if progress:
            print(f"[sca] {name:<28} {init_rate:.6f} -> {rate:.6f} bps/Hz  {n:3d} it  {stop}", flush=True)
        if best is None or rate > best[0]:
            best = (rate, q, name)
    assert best is not None
    failed = [
        s["start"] for s in summaries if s["stop"] in ("solver_error", "infeasible_iterate", "decrease")
    ]
    stops = {s["start"]: s["stop"] for s in summaries if s["start"] in failed}
    # warn when the winning start hit a solver error or an infeasible iterate. A losing
    # start's early stop did not produce the plan, and "decrease" (the exact objective fell,
    # the previous iterate is kept) is SCA's usual stop when the surrogate's error exceeds
    # the improvement left: both are only recorded in ``info``
    if stops.get(best[2], "decrease") != "decrease":
        warnings.warn(
            f"SCA: start(s) {failed} stopped early ({list(stops.values())}); "
            "their last feasible iterate was kept (see plan.history)",
            RuntimeWarning,
            stacklevel=2,
        )
    rate, q, winner = best
    info = {
        "tiles": int(tiles),
        "tiling_error": tiling_error(config, q, int(tiles)) if config.surface != "none" else None,
        "start": winner,
        "starts": summaries,
        "n_iters": sum(s["iters"] for s in summaries),
        "status": "ok" if not failed else "partial_failure" if len(failed) < len(summaries) else "failed",
        "solver": solver,
        "dpp": bool(dpp),
        "compile_seconds": 0.0 if was_compiled else surrogate.compile_seconds,  # 0: cached
        "tol": float(tol),
    }
    scheme = SCHEME_NAMES[config.surface]
    return Plan.from_trajectory(scheme, config, q, time.perf_counter() - t_start, history=history, info=info)
