r"""A trust-region ascent of a flight's score on a first-order model of a weighted slot value.

The planners that polish a feasible flight off the grid (``ao-star``, ``ao-miso-sdma``) share it:
they differ in the score (the scorer's max-min of their scenario) and in the slot value f_w whose
gradients model it; the step and the acceptance rule are this module's.

**The step** (:class:`TrustStep`). From a feasible flight q^l with way-point gradients g_n of the
model (1/N) sum_n f_w(q[n]), the convex program (cvxpy, lengths in ``sca_problem.LENGTH_SCALE``
about the surface's centre, the gradients scaled to O(1))

    max  sum_n g_n . (q_n - q_n^l)
    s.t. |q[n] - q[n-1]| <= max(D - STEP_MARGIN, |q^l[n] - q^l[n-1]|)   (the speed limit),
         q[0] = q0, q[N-1] = qF                                      (fixed, as eq. (10)),
         |q_n - q_n^l| <= r                                          (the trust region),

maximises the first-order model on the disc of radius r about each way-point; its optimum is the
candidate flight. The speed limit is ``sca_problem``'s (an inward margin, loosened to the current
step where that is longer, so q^l is feasible for the program). The solver meets it to its accuracy
only (~1e-6 m in these units, the feasibility check's own tolerance); with ``repair`` a candidate
whose largest step exceeds D by delta is mixed with the straight line from q0 to qF (each step
D - s, s > 0 when the horizon is not tight): q_t = (1 - t) q + t q_line has every step at most
(1 - t)(D + delta) + t (D - s) <= D for t = delta / (delta + s) (a relative 1e-9 D more for the
rounding), a move of order delta, and the same ends.

**The ascent** (:func:`ascend`). Each round builds the model at the current flight (weights and
gradients; rebuilt only after an accepted step, since a rejected one leaves the flight as it
was), solves the step and scores the candidate with the caller's ``evaluate`` (feasibility by the
project's ``check_trajectory`` and the one scorer): accepted if feasible and strictly higher (then
r grows by ``GROW``, up to the cap), else r shrinks by ``SHRINK``. It stops when r falls below its
floor, after ``patience`` rejections in a row, after ``max_rounds`` rounds or once ``max_seconds``
have passed. Only feasible flights that score higher are accepted: the flight returned is never
below the start.
"""

from __future__ import annotations

import math
import numbers
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import cvxpy as cp
import numpy as np

from baselines.sca_problem import LENGTH_SCALE, OK_STATUSES, STEP_MARGIN
from ios_uav_env import ScenarioConfig

__all__ = [
    "GROW", "SHRINK", "Ascent", "TrustStep", "ascend", "checked_region", "count", "positive", "trust_step",
]  # fmt: skip

#: Trust radius factors after an accepted and a rejected step.
GROW = 2.0
SHRINK = 0.5


def positive(name: str, value: Any, low: float = 0.0, high: float = math.inf) -> float:
    """``value`` as a float in (low, high); ``ValueError`` naming ``name`` and the range otherwise."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not (low < value < high):
        upper = "" if high == math.inf else f" and < {high:g}"
        raise ValueError(f"{name} must be a finite number > {low:g}{upper}, got {value!r}")
    return float(value)


def count(name: str, value: Any, low: int) -> int:
    """``value`` as an int >= low; ``ValueError`` naming ``name`` and the range otherwise."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < low:
        raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    return int(value)


def checked_region(
    config: ScenarioConfig,
    *,
    max_rounds: Any,
    patience: Any,
    radius: Any,
    min_radius: Any,
    max_radius: Any,
    fd_step: Any,
) -> dict[str, Any]:
    """The ascent's arguments checked (``ValueError`` naming the one out of its range), as the
    keywords of :func:`ascend` (``max_radius`` None: D) plus ``fd_step`` (m, > 0)."""
    rounds, patience = count("max_rounds", max_rounds, 1), count("patience", patience, 1)
    cap = positive("max_radius", config.D if max_radius is None else max_radius)
    radius = positive("radius", radius)
    min_radius = positive("min_radius", min_radius, high=radius)
    if radius > cap:
        raise ValueError(f"radius must be <= max_radius ({cap:g} m), got {radius!r}")
    return {"max_rounds": rounds, "patience": patience, "radius": radius, "min_radius": min_radius,
            "max_radius": cap, "fd_step": positive("fd_step", fd_step)}  # fmt: skip


class TrustStep:
    """The step's convex program (module docstring), built once per scenario (cvxpy DPP
    parameters: gradients, iterate, speed limits, radius) and re-solved by calling it."""

    def __init__(self, config: ScenarioConfig, solver: str = "CLARABEL", repair: bool = False):
        m, scale = config.N - 2, LENGTH_SCALE
        if m < 1:
            raise ValueError(f"config: N must be >= 3 slots for a way-point to move, got N = {config.N}")
        self.config, self.solver, self.centre = config, solver, np.asarray(config.ios_center[:2], dtype=float)
        self.repair = repair
        self.line = np.linspace(
            np.asarray(config.q0, dtype=float), np.asarray(config.qF, dtype=float), config.N
        )
        self.slack = config.D - float(np.linalg.norm(self.line[1] - self.line[0]))
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
        """(the candidate flight (N, 2) m or None, the solver's status) from the feasible flight
        ``q`` with way-point gradients ``grad`` (N, 2) and trust radius ``radius`` m."""
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
        cand = np.vstack([q[:1], interior, q[-1:]])
        excess = float(np.linalg.norm(np.diff(cand, axis=0), axis=1).max()) - cfg.D
        if self.repair and excess > 0 and self.slack > 0:
            delta = excess + 1e-9 * cfg.D
            t = min(1.0, delta / (delta + self.slack))
            cand[1:-1] = (1 - t) * cand[1:-1] + t * self.line[1:-1]
            status += " (repaired)"
        return cand, status


def trust_step(
    config: ScenarioConfig, q: np.ndarray, grad: np.ndarray, radius: float, solver: str = "CLARABEL"
) -> tuple[np.ndarray | None, str]:
    """One step (module docstring) from the feasible flight ``q`` (N, 2) m with the way-points'
    gradients ``grad`` (N, 2) and trust radius ``radius`` m: (flight or None, status); a flight of
    two slots has no way-point to move and is returned as it is."""
    if config.N <= 2:
        return np.asarray(q, dtype=float).copy(), "optimal"
    return TrustStep(config, solver)(np.asarray(q, dtype=float), np.asarray(grad, dtype=float), radius)


@dataclass
class Ascent:
    """What :func:`ascend` returns: the best flight met, its score, one record per round (weights,
    radius, status, candidate score, predicted first-order gain, accepted), the accepted steps'
    count and why it stopped."""

    trajectory: np.ndarray
    score: float
    history: list[dict[str, Any]] = field(default_factory=list)
    accepted: int = 0
    stop: str = "max_rounds"


def ascend(
    config: ScenarioConfig,
    q: np.ndarray,
    score: float,
    model: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    evaluate: Callable[[np.ndarray], tuple[bool, float]],
    *,
    radius: float,
    min_radius: float,
    max_radius: float,
    max_rounds: int,
    patience: int,
    max_seconds: float = math.inf,
    solver: str = "CLARABEL",
    repair: bool = False,
    name: str = "ascent",
    progress: bool = False,
) -> Ascent:
    """The trust-region ascent (module docstring) from the feasible flight ``q`` of score
    ``score``: ``model(q) -> (weights, gradients (N, 2))`` the first-order model at a flight,
    ``evaluate(candidate) -> (feasible, score)`` the scorer. The arguments are the caller's,
    already checked; ``repair``: :class:`TrustStep`'s; ``name`` prefixes the ``progress`` lines."""
    t0 = time.perf_counter()
    out = Ascent(np.asarray(q, dtype=float), float(score))
    if config.N <= 2:
        out.stop = "no interior way-point"
        return out
    step, rejections = TrustStep(config, solver, repair), 0
    w, grad = model(out.trajectory)
    for it in range(max_rounds):
        if time.perf_counter() - t0 >= max_seconds:
            out.stop = "max_seconds"
            break
        if it > 0 and out.history[-1]["accepted"]:  # a rejected step leaves q, so w and g as they were
            w, grad = model(out.trajectory)
        cand, status = step(out.trajectory, grad, radius)
        record: dict[str, Any] = {"round": it, "weights": np.asarray(w).tolist(), "radius": radius,
                                  "status": status}  # fmt: skip
        ok = False
        if cand is not None:
            feasible, value = evaluate(cand)
            record["predicted"] = float(np.sum(grad[1:-1] * (cand - out.trajectory)[1:-1]) / config.N)
            record["score"] = value
            ok = feasible and value > out.score
        record["accepted"] = ok
        out.history.append(record)
        if progress:
            print(f"[{name}] round {it:2d}: r {radius:7.3f} m  score {record.get('score', math.nan):.6f}  "
                  f"{'accepted' if ok else 'rejected'}")  # fmt: skip
        if ok:
            out.trajectory, out.score, out.accepted, rejections = cand, record["score"], out.accepted + 1, 0
            radius = min(max_radius, radius * GROW)
        else:
            rejections += 1
            radius *= SHRINK
            if radius < min_radius:
                out.stop = "min_radius"
                break
            if rejections >= patience:
                out.stop = "patience"
                break
    return out
