"""The paper's algorithm (Section III): alternating optimisation with SCA for the trajectory.

:func:`solve` maximises the expected-gain average rate (eq. (9)) over the trajectories that
meet eq. (10), for one ground node or several (then through :mod:`baselines.sca_multi`). The
phases are closed form (eq. (13)), so each outer iteration is one convex step on the
trajectory around the current iterate: problem (20), built by :mod:`baselines.sca_problem`
(tiled and anchored surrogate, DPP parameters) and solved by Clarabel through cvxpy. The
derivation (problems (15)-(20), the bound (16), the inner approximations (17)-(19), why every
iterate improves, the side of the plane, the tiles, the solver's box) is in
``docs/planners.md``, section "How SCA works".

The contract:

- Every iterate is scored by the exact model (``ios_uav_env.average_rate``) and checked by
  ``ios_uav_env.check_trajectory``; the history records the exact rate of every solve. An
  iterate that lowers the exact rate is not accepted: the start stops there, flagged
  ``"decrease"`` beyond ``DECREASE_TOL`` relative.
- SCA is local, so :func:`solve` runs a multi-start (:func:`default_starts`): the straight
  line, fly-hover-fly above G, fly-hover-fly to the reachable rate peak on each side of the
  surface plane (each skipped within D of an earlier hover point), and a coarse DP plan at
  ``DP_START_RESOLUTION`` m polished by SCA. The best plan by the exact objective wins.
- On the IOS a slot keeps its side of the plane (the start sets the crossing slot); slots
  within ``PLANE_TOL`` of it, or without a surface term, may cross.
- A solver exception, a status other than optimal / optimal_inaccurate, or an iterate that
  fails ``check_trajectory`` stops that start (``"solver_error: ..."``,
  ``"infeasible_iterate ..."`` in the history) and keeps its last feasible iterate;
  ``info["status"]`` is then ``"partial_failure"`` or ``"failed"`` (a stop on an exact
  decrease counts too), with a ``RuntimeWarning`` when the winning start was affected. A
  solver name cvxpy does not know raises ``ValueError``; a known one that is not installed or
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
from baselines.registry import check as check_planner
from baselines.sca_problem import PLANE_TOL, SCHEME_NAMES, STEP_MARGIN, Surrogate, tiled_config
from ios_uav_env import ScenarioConfig
from ios_uav_env.model import channel as ch
from ios_uav_env.model.peak import rate_peak

#: Default tiles per axis (2 x 2 = 4 nodes; docs/planners.md, "How SCA works").
DEFAULT_TILES = 2
#: Default cap on SCA iterations per start.
DEFAULT_MAX_ITERS = 50
#: An exact-objective decrease beyond this (relative) is flagged ``"decrease"``.
DECREASE_TOL = 1e-9
#: DP resolution (m) of the "DP + SCA polish" start.
DP_START_RESOLUTION = 5.0

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
    """The default multi-start set: ``[(name, trajectory), ...]`` (the module docstring lists them)."""
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


#: The stops of a start that count as a failure in a plan's ``info["status"]``.
FAILED_STOPS = ("solver_error", "infeasible_iterate", "decrease")


def start_status(summaries: list[dict[str, Any]]) -> tuple[list[str], str]:
    """The starts of a multi-start run that stopped on a :data:`FAILED_STOPS` stop, and the run's
    status: ``"ok"`` (none), ``"partial_failure"`` (some) or ``"failed"`` (all)."""
    failed = [s["start"] for s in summaries if s["stop"] in FAILED_STOPS]
    return failed, "ok" if not failed else "partial_failure" if len(failed) < len(summaries) else "failed"


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
    check_planner("sca", config)
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
    failed, status = start_status(summaries)
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
        "status": status,
        "solver": solver,
        "dpp": bool(dpp),
        "compile_seconds": 0.0 if was_compiled else surrogate.compile_seconds,  # 0: cached
        "tol": float(tol),
    }
    scheme = SCHEME_NAMES[config.surface]
    return Plan.from_trajectory(scheme, config, q, time.perf_counter() - t_start, history=history, info=info)
