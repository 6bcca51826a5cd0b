r"""A STAR surface serving a user on each side at once (NOMA): dp-star's plan polished off the grid by
alternating optimisation with a trust-region SCA step on a continuous trajectory.

The scenario and its score are ``baselines.dp_star``'s: ``ScenarioConfig(surface="star",
star_access="noma")``, two static users one on each side of the surface plane, and the flight's
max-min V(q) with the best surface setting, power split and time sharing in every slot
(``ios_uav_env.score_plan``, ``model.star_regions.scenario_maxmin``). :func:`solve` starts from
dp-star's plan (or a given feasible flight) and repeats:

1. **The schedule.** w* = the dual weights of the current flight's max-min (``scenario_maxmin``'s
   ``dual_weights``): the per-slot settings, splits and time sharing are the scorer's own
   optimum for the flight, and V(q) <= (1/N) sum_n f_{w*}(q[n]) with equality to the scorer's
   tolerance at the current flight (weak duality, ``dp_star``'s "The dual").
2. **The trajectory.** One SCA step on (1/N) sum_n f_{w*}(q[n]), f_w the slot's weighted-sum
   optimum (``model.star_maps``: ``frontier_maps`` + ``FrontierMaps.weighted_sum``'s ``value``).
   f_w is a maximum over the surface settings and splits of smooth functions of q, so (envelope
   theorem) differentiable almost everywhere; its gradient g_n at each interior way-point is
   taken by central finite differences of step ``fd_step`` m (default ``FD_STEP``) along x and y.
   The convex program (cvxpy, as ``baselines.sca_problem``, lengths in its ``LENGTH_SCALE``)

       max  sum_n g_n . (q_n - q_n^l)
       s.t. |q[n] - q[n-1]| <= max(D - STEP_MARGIN, |q^l[n] - q^l[n-1]|)   (the speed limit),
            q[0] = q0, q[N-1] = qF                                      (fixed, as eq. (10)),
            |q_n - q_n^l| <= r                                          (the trust region),

   is a first-order model of the objective on the disc of radius r around each way-point; its
   optimum is the candidate flight.
3. **The test.** The candidate is scored by ``score_plan`` (feasibility by the project's own
   ``check_trajectory``, inside it): accepted if feasible and higher (then r grows by ``GROW``, up
   to ``max_radius``), else r shrinks by ``SHRINK``. The run stops when r < ``min_radius``, after
   ``patience`` rejections in a row or after ``max_rounds`` rounds.

**Guarantees.** Only feasible flights that score higher are accepted, so the plan returned is
never below the start (dp-star's plan); being a feasible flight, it is never above dp-star's
certified bound (``info["upper_bound"]``, ``dp_star.noma_bound``). It is a local method: the
first-order model carries no curvature, the trust region does the globalisation, and the
way-points move continuously (off dp-star's grid and its refinement's lattices).
"""

from __future__ import annotations

import math
import numbers
import time
import warnings
from typing import Any

import cvxpy as cp
import numpy as np

from baselines.plan import Plan
from baselines.registry import check as check_planner
from baselines.sca_problem import LENGTH_SCALE, OK_STATUSES, STEP_MARGIN
from ios_uav_env import ScenarioConfig, check_trajectory, score_plan
from ios_uav_env.model.star_maps import FRONTIER_POINTS, frontier_maps
from ios_uav_env.model.star_regions import scenario_maxmin

#: m, the central finite difference's step of f_w's gradient.
FD_STEP = 0.25
#: m, the default initial trust radius, and its floor (below it the run stops).
RADIUS = 5.0
MIN_RADIUS = 0.05
#: Trust radius factors after an accepted and a rejected step.
GROW = 2.0
SHRINK = 0.5
#: Default cap on rounds and on rejections in a row.
MAX_ROUNDS = 30
PATIENCE = 6

__all__ = ["FD_STEP", "MAX_ROUNDS", "MIN_RADIUS", "PATIENCE", "RADIUS", "gradients", "solve", "trust_step"]


def _positive(name: str, value: Any, low: float = 0.0, high: float = math.inf) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not (low < value < high):
        upper = "" if high == math.inf else f" and < {high:g}"
        raise ValueError(f"{name} must be a finite number > {low:g}{upper}, got {value!r}")
    return float(value)


def _count(name: str, value: Any, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < low:
        raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    return int(value)


def gradients(
    config: ScenarioConfig, q: np.ndarray, w: np.ndarray, step: float = FD_STEP, points: int = FRONTIER_POINTS
) -> np.ndarray:
    """(N, 2): the central finite differences (step ``step`` m) of f_w at every way-point of ``q``
    (module docstring), from ``FrontierMaps.weighted_sum``'s value."""
    users = np.asarray(config.nodes, dtype=float)
    shifts = step * np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
    probes = (q[:, None, :] + shifts[None]).reshape(-1, 2)
    value = frontier_maps(config, probes, users, points).weighted_sum(w)[0].reshape(len(q), 4)
    return np.column_stack([value[:, 0] - value[:, 1], value[:, 2] - value[:, 3]]) / (2 * step)


class _Step:
    """The step's convex program, built once (cvxpy DPP parameters): gradients, iterate, radius."""

    def __init__(self, config: ScenarioConfig, solver: str):
        m, scale = config.N - 2, LENGTH_SCALE
        self.config, self.solver, self.centre = config, solver, np.asarray(config.ios_center[:2], dtype=float)
        self.x = cp.Variable((m, 2))
        self.grad = cp.Parameter((m, 2))
        self.anchor = cp.Parameter((m, 2))
        self.radius = cp.Parameter(nonneg=True)
        self.dmax = cp.Parameter(m + 1, nonneg=True)
        ends = (np.array([config.q0, config.qF], dtype=float) - self.centre) / scale
        path = cp.vstack([ends[:1], self.x, ends[1:]])  # q[0] = q0, q[N-1] = qF exactly
        cons = [
            cp.norm(path[1:] - path[:-1], 2, axis=1) <= self.dmax,
            cp.norm(self.x - self.anchor, 2, axis=1) <= self.radius,
        ]
        self.problem = cp.Problem(cp.Maximize(cp.sum(cp.multiply(self.grad, self.x))), cons)

    def __call__(self, q: np.ndarray, grad: np.ndarray, radius: float) -> tuple[np.ndarray | None, str]:
        cfg, scale = self.config, LENGTH_SCALE
        steps = np.minimum(np.linalg.norm(np.diff(q, axis=0), axis=1), cfg.D)
        self.dmax.value = np.maximum(cfg.D - STEP_MARGIN, steps) / scale  # as sca_problem's linearise
        self.anchor.value = (q[1:-1] - self.centre) / scale
        self.grad.value = grad[1:-1] * scale / max(float(np.abs(grad).max()), 1e-300)  # scaled: O(1)
        self.radius.value = radius / scale
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                self.problem.solve(solver=self.solver, warm_start=False)
        except cp.error.SolverError as err:
            return None, f"solver_error: {err}"
        status = str(self.problem.status)
        if status not in OK_STATUSES or self.x.value is None:
            return None, status
        interior = self.x.value * scale + self.centre
        return np.vstack([q[:1], interior, q[-1:]]), status


def trust_step(
    config: ScenarioConfig, q: np.ndarray, grad: np.ndarray, radius: float, solver: str = "CLARABEL"
) -> tuple[np.ndarray | None, str]:
    """The trajectory step (module docstring, 2.) from the feasible flight ``q`` (N, 2) m with the
    way-points' gradients ``grad`` (N, 2) and trust radius ``radius`` m: (flight or None, status)."""
    if config.N <= 2:
        return np.asarray(q, dtype=float).copy(), "optimal"
    return _Step(config, solver)(np.asarray(q, dtype=float), np.asarray(grad, dtype=float), radius)


def solve(
    config: ScenarioConfig,
    start: Plan | np.ndarray | None = None,
    *,
    resolution: float = 5.0,
    max_rounds: int = MAX_ROUNDS,
    radius: float = RADIUS,
    min_radius: float = MIN_RADIUS,
    max_radius: float | None = None,
    patience: int = PATIENCE,
    fd_step: float = FD_STEP,
    frontier_points: int = FRONTIER_POINTS,
    solver: str = "CLARABEL",
    dp_options: dict[str, Any] | None = None,
    progress: bool = False,
) -> Plan:
    """AO/SCA from dp-star's plan (module docstring): the best flight met and its history.

    ``start``: a ``Plan`` (e.g. dp-star's; its ``info["upper_bound"]`` is carried) or a feasible
    (N, 2) flight; None runs ``dp_star.solve(config, resolution, **dp_options)``. ``radius``,
    ``min_radius``, ``max_radius`` (default D): the trust region's initial radius, floor and cap
    (m); ``max_rounds``, ``patience``: rounds at most and rejections in a row at most; ``fd_step``:
    the gradient's finite-difference step (m); ``frontier_points``: the ES frontier's angles
    (``model.star_maps``); ``solver``: cvxpy's.

    ``history``: one record per round (weights, radius, status, candidate score, accepted,
    predicted first-order gain). ``info``: ``start_rate`` (the start's score), ``upper_bound``
    (dp-star's certified bound, or None if the start carried none), ``gap``, ``rounds``,
    ``accepted``, ``stop`` (why it stopped), ``start_seconds`` (dp-star's), ``fd_step``. ``seconds``:
    this call's wall time (dp-star's included when it runs it).
    """
    t0 = time.perf_counter()
    check_planner("ao-star", config)
    max_rounds = _count("max_rounds", max_rounds, 1)
    patience = _count("patience", patience, 1)
    cap = _positive("max_radius", config.D if max_radius is None else max_radius)
    radius = _positive("radius", radius)
    min_radius = _positive("min_radius", min_radius, high=radius)
    if radius > cap:
        raise ValueError(f"radius must be <= max_radius ({cap:g} m), got {radius!r}")
    fd_step = _positive("fd_step", fd_step)
    upper_bound, start_seconds = None, 0.0
    if start is None:
        from baselines.dp_star import solve as dp_star

        start = dp_star(config, resolution, **(dp_options or {}))
    if isinstance(start, Plan):
        upper_bound, start_seconds = start.info.get("upper_bound"), start.seconds
        start = start.trajectory
    q = np.asarray(start, dtype=float)
    if not check_trajectory(config, q).feasible:
        raise ValueError("start must be a feasible flight (check_trajectory), got an infeasible one")
    score = score_plan(config, q).rate
    start_rate, history, accepted, rejections, stop = score, [], 0, 0, "max_rounds"
    step = _Step(config, solver) if config.N > 2 else None
    for it in range(max_rounds):
        if step is None:
            stop = "no interior way-point"
            break
        if it == 0 or history[-1]["accepted"]:  # a rejected step leaves q, so w* and g as they were
            w = scenario_maxmin(config, q).dual_weights
            grad = gradients(config, q, w, fd_step, frontier_points)
        cand, status = step(q, grad, radius)
        record: dict[str, Any] = {"round": it, "weights": w.tolist(), "radius": radius, "status": status}
        ok = False
        if cand is not None:
            scored = score_plan(config, cand)
            record["predicted"] = float(np.sum(grad[1:-1] * (cand - q)[1:-1]) / config.N)
            record["score"] = scored.rate
            ok = scored.feasible and scored.rate > score
        record["accepted"] = ok
        history.append(record)
        if progress:
            print(f"[ao-star] round {it:2d}: r {radius:7.3f} m  score {record.get('score', math.nan):.6f}  "
                  f"{'accepted' if ok else 'rejected'}")  # fmt: skip
        if ok:
            q, score, accepted, rejections = cand, record["score"], accepted + 1, 0
            radius = min(cap, radius * GROW)
        else:
            rejections += 1
            radius *= SHRINK
            if radius < min_radius:
                stop = "min_radius"
                break
            if rejections >= patience:
                stop = "patience"
                break
    info = {
        "start_rate": start_rate,
        "upper_bound": upper_bound,
        "gap": upper_bound / score - 1.0 if upper_bound is not None and score > 0 else None,
        "rounds": len(history),
        "accepted": accepted,
        "stop": stop,
        "start_seconds": start_seconds,
        "fd_step": fd_step,
        "frontier_points": int(frontier_points),
    }
    return Plan.from_trajectory("ao-star", config, q, time.perf_counter() - t0, history=history, info=info)
