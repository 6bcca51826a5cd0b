r"""Energy efficiency (bits per joule) of one ground node: SCA with the propulsion energy,
inside Dinkelbach's method.

**The problem.** With E(q) = dt sum_{n=1}^{N-1} P(|q[n+1] - q[n]| / dt) the propulsion energy
of the rotary-wing model (``ios_uav_env.propulsion_power``) and R[n] the slot rates of eq. (9),

    max_q  EE(q) = B dt sum_n R[n] / E(q)   s.t. eq. (10),

a ratio of a rate sum and an energy, both non-concave in q.

**Dinkelbach (outside).** For lambda >= 0 let F(lambda) = max_q G_lambda(q) with
G_lambda(q) = B dt sum_n R_n(q) - lambda E(q). E > 0, so F(lambda) > 0 iff some plan has
EE > lambda. From a plan q_k with lambda_k = EE(q_k), G_{lambda_k}(q_k) = 0; any q with
G_{lambda_k}(q) > 0 has EE(q) > lambda_k, since G_{lambda_k}(q) = E(q) (EE(q) - lambda_k).
So each outer step raises G_{lambda_k} by SCA from q_k (below), then sets
lambda_{k+1} = EE(q_{k+1}) >= lambda_k. It stops when the relative residual
(EE(q_{k+1}) - lambda_k) / lambda_k = G_{lambda_k}(q_{k+1}) / (lambda_k E(q_{k+1})) is below
``tol`` (the Dinkelbach stopping rule, on the exact model), or after ``max_iters`` convex
solves. ``inner_iters`` caps the SCA steps per value of lambda (1: lambda follows every
accepted iterate).

**SCA (inside), one convex problem per step.** G_lambda / (B dt N) = mean rate - w sum_n
P_n / P_ref with w = lambda P_ref / (B N) and P_ref = P0 + P_i (the hover power, a scale). The
mean rate is replaced by the concave lower bound of the paper's SCA
(:class:`baselines.sca_problem.Surrogate`: (16) under the inner approximations (17)-(19),
exact at the current iterate q^l; ``docs/planners.md``, "How SCA works"). The power of move
n, at V_n = |q[n+1] - q[n]| / dt (Zeng, Xu, Zhang 2019, eq. (12)),

    P(V) = P0 (1 + 3 V^2 / U_tip^2) + P_i (sqrt(1 + V^4 / (4 v0^4)) - V^2 / (2 v0^2))^(1/2)
           + c V^3,   c = d0 rho s A / 2,

has two terms convex in the move vector: P0 (1 + 3 V^2 / U_tip^2) (a convex quadratic) and
c V^3 (the cube of a norm, convex as a non-decreasing convex function of a convex non-negative
one). They are kept exact. The induced term P_i y(V) is not convex; with the slack y_n,

    y(V)^2 = sqrt(1 + V^4 / (4 v0^4)) - V^2 / (2 v0^2)   gives   1 / y(V)^2 = y(V)^2 + V^2 / v0^2

(multiply y^2 by its conjugate sqrt(1 + V^4 / (4 v0^4)) + V^2 / (2 v0^2): the product is 1,
so 1/y^2 - y^2 = V^2 / v0^2). The map y -> 1/y^2 - y^2 is decreasing on y > 0, so

    y_n >= y(V_n)   <=>   y_n^(-2) <= y_n^2 + V_n^2 / v0^2,   y_n > 0,

and replacing P_i y(V_n) by P_i y_n under that constraint is exact at the optimum (the
objective pushes y_n down). The left side is convex; the right side is convex in (y_n, move)
and is replaced by its first-order expansion at (y_n^l, move^l), which lies below it:

    y_n^(-2) <= y_n^l (2 y_n - y_n^l) + (2 m^l . m - |m^l|^2) / (dt^2 v0^2),

m = q[n+1] - q[n]. That is a convex constraint (convex <= affine), and any (y_n, m) meeting it
meets the original one, so y_n >= y(V_n): the surrogate's energy bounds E(q) from above.
The convex problem of the step is

    max  rate lower bound (problem (20))
         - w sum_n [P0 (1 + 3 V_n^2 / U_tip^2) + c V_n^3 + P_i y_n] / P_ref
    s.t. (17)-(19), (10b)-(10c), the constraint above for every move n.

Its objective is a lower bound of G_lambda / (B dt N) at every feasible point, equal to it at
q^l with y^l = y(V^l) (the expansions are exact there). So its optimum q^(l+1) has
G_lambda(q^(l+1)) >= G_lambda(q^l): every step is monotone, up to the solver's accuracy and
the rate surrogate's tiling anchor (``docs/planners.md``). Lengths are in
``baselines.sca_problem.LENGTH_SCALE`` and powers in P_ref, so the coefficients are O(1).

**The contract** (as ``baselines.sca``): every iterate is scored by the one scorer
(``ios_uav_env.score_plan``: its EE, energy and eq. (10) report); an infeasible iterate or
one that lowers G_lambda is not accepted, so the EE of the accepted iterates never decreases
and the plan returned is feasible and at least as efficient as its start. SCA is local and a
hover is a stationary point of E (P is smooth in V^2 at V = 0, so moving from rest lowers the
power only at second order): it starts from plans that already move, by default the loiter
heuristic (``baselines.loiter``) and the energy DP on a coarse grid (``baselines.dp_energy``);
the best plan by the exact EE wins. A solver error or an infeasible iterate stops that start
and keeps its last accepted iterate (``info["status"]``, a ``RuntimeWarning`` when the winner
was affected). One ground node, no energy budget. The convex problem of a step is
``baselines.sca_energy_problem.EnergySurrogate``.
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
from baselines.sca import SCHEME_NAMES, _as_starts, _validate, start_status
from baselines.sca_energy_problem import EnergySurrogate
from ios_uav_env import ScenarioConfig

#: Default cap on convex solves per start.
DEFAULT_MAX_ITERS = 100
#: Default Dinkelbach stopping tolerance: relative EE gain of an outer step.
DEFAULT_TOL = 1e-6
#: Default cap on SCA steps per value of lambda (1: lambda = EE of every accepted iterate).
DEFAULT_INNER_ITERS = 1
#: A drop of G_lambda beyond this (relative to the mean rate) is flagged ``"decrease"``.
DECREASE_TOL = 1e-9
#: DP resolution (m) of the energy DP start.
DP_START_RESOLUTION = 5.0

__all__ = [
    "DEFAULT_INNER_ITERS", "DEFAULT_MAX_ITERS", "DEFAULT_TOL", "EnergySurrogate", "default_starts", "solve",
]  # fmt: skip


def _objective(config: ScenarioConfig, q: np.ndarray, lam: float) -> tuple[float, float, float, float, Any]:
    """(G_lam / (B dt N), mean rate, energy J, EE bits/J, eq. (10) report) of ``q``, by the one
    scorer (``ios_uav_env.score_plan``)."""
    scored = ie.score_plan(config, q)
    g = scored.rate - lam * scored.energy / (config.bandwidth_hz * config.dt * config.N)
    return g, scored.rate, scored.energy, scored.energy_efficiency, scored.report


def default_starts(config: ScenarioConfig) -> list[tuple[str, np.ndarray]]:
    """The loiter heuristic's plan and the energy DP's plan at ``DP_START_RESOLUTION`` m (each
    when it exists), without duplicates."""
    starts: list[tuple[str, np.ndarray]] = []
    from baselines import loiter

    starts.append(("loiter", loiter.solve(config).trajectory))
    from baselines import dp_energy

    try:
        plan = dp_energy.solve_ee(config, resolution=DP_START_RESOLUTION)
    except ValueError:  # no grid path in time: the loiter start remains
        pass
    else:
        starts.append((f"dp{DP_START_RESOLUTION:g}", plan.trajectory))
    unique: list[tuple[str, np.ndarray]] = []
    for name, q in starts:
        if not any(np.allclose(q, u, atol=1e-9) for _, u in unique):
            unique.append((name, np.asarray(q, dtype=float)))
    return unique


def _run(
    surrogate: EnergySurrogate,
    q_init: np.ndarray,
    start: str,
    max_iters: int,
    inner_iters: int,
    tol: float,
    history: list[dict[str, Any]],
    verbose: bool,
    record_iterates: bool,
) -> tuple[np.ndarray, float, int, str]:
    """Dinkelbach + SCA from one start: (best accepted trajectory, its EE, solves, stop reason)."""
    config = surrogate.config
    q = q_init
    lam = float(ie.score_plan(config, q).energy_efficiency)
    g, rate, energy, ee, report = _objective(config, q, lam)
    history.append(
        {"start": start, "outer": 0, "iteration": 0, "lambda": lam, "energy_efficiency": ee, "energy": energy,
         "mean_rate": rate, "objective": g, "surrogate": None, "status": "init", "seconds": 0.0,
         "solver_seconds": 0.0, "accepted": True, "rel_improvement": None, "residual": None,
         "worst_violation": report.worst_violation}
    )  # fmt: skip
    if record_iterates:
        history[-1]["trajectory"] = q.tolist()
    stop, outer, inner, solves = "max_iters", 1, 0, 0
    while solves < max_iters:
        lin = surrogate.linearise_energy(q, lam)
        t0 = time.perf_counter()
        solves += 1
        try:
            q_new, value, status, solver_seconds = surrogate.solve(lin, verbose=verbose)
        except Exception as exc:  # any solver failure falls back to the last accepted iterate
            q_new, value, status, solver_seconds = (
                None,
                math.nan,
                f"solver_error: {type(exc).__name__}: {exc}",
                0.0,
            )
        record = {"start": start, "outer": outer, "iteration": solves, "lambda": lam,
                  "energy_efficiency": None, "energy": None, "mean_rate": None, "objective": None,
                  "surrogate": None, "status": status,
                  "seconds": time.perf_counter() - t0, "solver_seconds": solver_seconds, "accepted": False,
                  "rel_improvement": None, "residual": None, "worst_violation": None}  # fmt: skip
        history.append(record)
        if q_new is not None and not np.all(np.isfinite(q_new)):
            q_new, record["status"] = None, f"solver_error: non-finite trajectory (status {status})"
        if q_new is None:
            if not record["status"].startswith("solver_error"):
                record["status"] = f"solver_error: status {status}"
            stop = "solver_error"
            break
        g_new, rate_new, energy_new, ee_new, report = _objective(config, q_new, lam)
        rel = (g_new - g) / max(abs(rate), 1e-300)
        record.update(energy_efficiency=ee_new, energy=energy_new, mean_rate=rate_new, objective=g_new,
                      surrogate=value, rel_improvement=rel,
                      worst_violation=report.worst_violation)  # fmt: skip
        if record_iterates:
            record["trajectory"] = q_new.tolist()
        if not report.feasible:
            record["status"] = f"infeasible_iterate ({status}): {report}"
            stop = "infeasible_iterate"
            break
        if rel <= 0:  # no gain for this lambda
            if inner == 0:  # at a fresh lambda: no step improves EE
                stop = "decrease" if rel < -DECREASE_TOL else "converged"
                break
            # the inner SCA has stalled: update lambda at the last accepted iterate
            residual = (ee - lam) / lam
        else:
            record["accepted"] = True
            q, g, rate, energy, ee = q_new, g_new, rate_new, energy_new, ee_new
            inner += 1
            residual = (ee - lam) / lam
            if inner < inner_iters and rel >= tol:
                continue
        record["residual"] = residual  # Dinkelbach's F(lambda) / (lambda E): relative EE gain
        if residual < tol:
            stop = "converged"
            break
        lam = ee  # Dinkelbach's update: G_lam(q) = 0 at the new lambda
        g = _objective(config, q, lam)[0]
        outer, inner = outer + 1, 0
    return q, ee, solves, stop


def solve(
    config: ScenarioConfig,
    *,
    init: Any = None,
    tiles: int = 2,
    max_iters: int = DEFAULT_MAX_ITERS,
    inner_iters: int = DEFAULT_INNER_ITERS,
    tol: float = DEFAULT_TOL,
    solver: str = "CLARABEL",
    dpp: bool = True,
    solver_options: dict[str, Any] | None = None,
    record_iterates: bool = False,
    progress: bool = False,
    verbose: bool = False,
) -> Plan:
    """The most energy-efficient trajectory found by Dinkelbach + SCA (module docstring).

    Parameters
    ----------
    config : ScenarioConfig
        One ground node; its ``propulsion`` and ``bandwidth_hz`` define the EE.
    init : trajectory (N, 2), Plan, or a list of them, optional
        Feasible starts; None = :func:`default_starts` (loiter, coarse energy DP).
    tiles : int
        Surface nodes per axis of the rate surrogate (as ``baselines.sca.solve``), >= 1.
    max_iters : int
        Cap on convex solves per start, >= 1.
    inner_iters : int
        Cap on SCA steps per value of lambda, >= 1.
    tol : float
        Dinkelbach stopping tolerance (relative EE gain of an outer step), > 0.
    solver, dpp, solver_options, record_iterates, progress, verbose
        As in ``baselines.sca.solve``.

    Returns
    -------
    Plan
        Scheme ``"ia-ee"`` / ``"ra-ee"`` / ``"cuc-ee"``, scored by the one model (its
        ``energy_efficiency``, bits/J, and ``energy``, J); ``history`` has one record per start
        and solve (``lambda``, exact ``energy_efficiency``, ``energy``, ``mean_rate``,
        ``objective`` = G_lambda / (B dt N), ``surrogate``, ``accepted``, ``residual`` at each
        lambda update, ...); ``info`` has the winning ``start``, per-start summaries,
        ``n_iters`` and ``status``.

    Raises
    ------
    ValueError
        K > 1 ground nodes, an energy budget, or a bad ``tiles``, ``max_iters``,
        ``inner_iters``, ``tol``, ``solver`` or ``init``.
    """
    t_start = time.perf_counter()
    check_planner("sca-ee", config)
    _validate(config, tiles, max_iters, tol, solver)
    if isinstance(inner_iters, bool) or not isinstance(inner_iters, (int, np.integer)) or inner_iters < 1:
        raise ValueError(f"inner_iters must be an integer >= 1 (SCA steps per lambda), got {inner_iters!r}")
    solver = solver.upper()
    starts = default_starts(config) if init is None else _as_starts(config, init)
    surrogate = EnergySurrogate(config, int(tiles), solver, dpp=dpp, solver_options=solver_options)
    history: list[dict[str, Any]] = []
    summaries: list[dict[str, Any]] = []
    best: tuple[float, np.ndarray, str] | None = None
    for name, q0 in starts:
        t0 = time.perf_counter()
        init_ee = float(ie.energy_efficiency(config, q0))
        q, ee, n, stop = _run(
            surrogate,
            q0,
            name,
            int(max_iters),
            int(inner_iters),
            float(tol),
            history,
            verbose,
            record_iterates,
        )
        summaries.append({"start": name, "init_energy_efficiency": init_ee, "energy_efficiency": ee,
                          "iters": n, "stop": stop, "seconds": time.perf_counter() - t0})  # fmt: skip
        if progress:
            print(f"[sca-ee] {name:<12} {init_ee:.2f} -> {ee:.2f} bits/J  {n:3d} it  {stop}", flush=True)
        if best is None or ee > best[0]:
            best = (ee, q, name)
    assert best is not None
    _, status = start_status(summaries)
    stops = {s["start"]: s["stop"] for s in summaries}
    if stops[best[2]] in ("solver_error", "infeasible_iterate"):
        warnings.warn(
            f"SCA-EE: the winning start {best[2]!r} stopped early ({stops[best[2]]}); its last "
            "accepted iterate was kept (see plan.history)",
            RuntimeWarning,
            stacklevel=2,
        )
    ee, q, winner = best
    info = {
        "tiles": int(tiles),
        "start": winner,
        "starts": summaries,
        "n_iters": sum(s["iters"] for s in summaries),
        "status": status,
        "solver": solver,
        "tol": float(tol),
        "inner_iters": int(inner_iters),
    }
    scheme = f"{SCHEME_NAMES[config.surface]}-ee"
    return Plan.from_trajectory(scheme, config, q, time.perf_counter() - t_start, history=history, info=info)
