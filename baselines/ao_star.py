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
   The convex program (``baselines.trust_region``'s step, cvxpy, as ``baselines.sca_problem``)

       max  sum_n g_n . (q_n - q_n^l)
       s.t. |q[n] - q[n-1]| <= max(D - STEP_MARGIN, |q^l[n] - q^l[n-1]|)   (the speed limit),
            q[0] = q0, q[N-1] = qF                                      (fixed, as eq. (10)),
            |q_n - q_n^l| <= r                                          (the trust region),

   is a first-order model of the objective on the disc of radius r around each way-point; its
   optimum is the candidate flight.
3. **The test.** The candidate is scored by ``score_plan`` (feasibility by the project's own
   ``check_trajectory``, inside it): accepted if feasible and higher (then r grows by
   ``trust_region.GROW``, up to ``max_radius``), else r shrinks by ``trust_region.SHRINK``. The
   run stops when r < ``min_radius``, after ``patience`` rejections in a row or after
   ``max_rounds`` rounds (``trust_region.ascend``).

**Guarantees.** Only feasible flights that score higher are accepted, so the plan returned is
never below the start (dp-star's plan); being a feasible flight, it is never above dp-star's
certified bound (``info["upper_bound"]``, ``dp_star.noma_bound``). It is a local method: the
first-order model carries no curvature, the trust region does the globalisation, and the
way-points move continuously (off dp-star's grid and its refinement's lattices).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from baselines.plan import Plan
from baselines.registry import check as check_planner
from baselines.trust_region import ascend, checked_region, trust_step
from ios_uav_env import ScenarioConfig, check_trajectory, score_plan
from ios_uav_env.model.star_maps import FRONTIER_POINTS, frontier_maps
from ios_uav_env.model.star_regions import scenario_maxmin

#: m, the central finite difference's step of f_w's gradient.
FD_STEP = 0.25
#: m, the default initial trust radius, and its floor (below it the run stops).
RADIUS = 5.0
MIN_RADIUS = 0.05
#: Default cap on rounds and on rejections in a row.
MAX_ROUNDS = 30
PATIENCE = 6

__all__ = ["FD_STEP", "MAX_ROUNDS", "MIN_RADIUS", "PATIENCE", "RADIUS", "gradients", "solve", "trust_step"]


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
    region = checked_region(config, max_rounds=max_rounds, patience=patience, radius=radius,
                            min_radius=min_radius, max_radius=max_radius, fd_step=fd_step)  # fmt: skip
    fd_step = region.pop("fd_step")
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

    def model(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        w = scenario_maxmin(config, q).dual_weights
        return w, gradients(config, q, w, fd_step, frontier_points)

    def evaluate(cand: np.ndarray) -> tuple[bool, float]:
        scored = score_plan(config, cand)
        return scored.feasible, scored.rate

    run = ascend(
        config, q, score, model, evaluate, **region, solver=solver, name="ao-star", progress=progress
    )
    start_rate, q, score = score, run.trajectory, run.score
    info = {
        "start_rate": start_rate,
        "upper_bound": upper_bound,
        "gap": upper_bound / score - 1.0 if upper_bound is not None and score > 0 else None,
        "rounds": len(run.history),
        "accepted": run.accepted,
        "stop": run.stop,
        "start_seconds": start_seconds,
        "fd_step": fd_step,
        "frontier_points": int(frontier_points),
    }
    return Plan.from_trajectory(
        "ao-star", config, q, time.perf_counter() - t0, history=run.history, info=info
    )
