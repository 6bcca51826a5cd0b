"""The linear programs of the schedules and the planners, solved by HiGHS.

HiGHS is the solver behind ``scipy.optimize.linprog(method="highs")``. :func:`solve_lp` calls
it through ``highspy`` when that is installed (the ``planners`` extra brings it), and through
``linprog`` otherwise. The LPs here are small and solved tens of thousands of times in a
plan or a dataset; ``linprog``'s input checks and conversions cost more than such a solve.

Both routes run HiGHS's simplex on the same model, but their HiGHS versions may differ (scipy
bundles its own). On a degenerate LP two versions may return different optimal vertices: the
same value to the solver's tolerances, other shares. Scores do not depend on it, since every
max-min score is certified by its dual (``ios_uav_env.model.schedule``).
"""

from __future__ import annotations

import functools
import os
import sys
import threading
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class LPSolution:
    """``optimal``: HiGHS proved an optimum; then ``x`` (n,) the solution, ``value`` = c x and
    ``ub_duals`` the duals of the ``a_ub`` rows (d value / d b_ub, <= 0). ``message``: the
    solver's status."""

    optimal: bool
    x: np.ndarray
    value: float
    ub_duals: np.ndarray
    message: str


@functools.cache
def _highspy() -> Any:
    """The ``highspy`` module, or None when it is not installed."""
    try:
        import highspy
    except ImportError:
        return None
    return highspy


_LOCAL = threading.local()  # each thread's HiGHS instance: one instance solves one LP at a time
_BANNER = threading.Lock()  # held while fd 1 points at /dev/null
_announced = False  # True once this process has made its first instance (the one with a banner)


def _highs() -> Any:
    """This thread's HiGHS instance, silent. The first construction in a process prints a banner
    on the C stdout, where CLIs print their results, so it is made with fd 1 on /dev/null."""
    h = getattr(_LOCAL, "highs", None)
    if h is None:
        h = _LOCAL.highs = _new_highs()
    return h


def _new_highs() -> Any:
    global _announced
    highspy = _highspy()
    with _BANNER:
        if _announced:
            h = highspy.Highs()
        else:
            sys.stdout.flush()
            try:
                saved = os.dup(1)
            except OSError:  # no fd 1: no output to keep clean
                h = highspy.Highs()
            else:
                null = os.open(os.devnull, os.O_WRONLY)
                try:
                    os.dup2(null, 1)
                    h = highspy.Highs()
                finally:
                    os.dup2(saved, 1)
                    os.close(saved)
                    os.close(null)
            _announced = True
    h.setOptionValue("output_flag", False)
    return h


def solve_lp(
    c: np.ndarray,
    a_ub: Any,
    b_ub: np.ndarray,
    upper: np.ndarray,
    *,
    a_eq: Any = None,
    b_eq: np.ndarray | None = None,
    dual_simplex: bool = False,
    feasibility_tol: float | None = None,
) -> LPSolution:
    """min c x  s.t.  a_ub x <= b_ub,  a_eq x = b_eq,  0 <= x <= upper (``np.inf``: no bound).

    ``a_ub`` and ``a_eq``: scipy sparse or dense matrices. ``dual_simplex``: HiGHS's dual simplex
    (``linprog``'s ``"highs-ds"``) instead of its own choice (``"highs"``);
    ``feasibility_tol``: its primal and dual feasibility tolerances (default: HiGHS's)."""
    from scipy.sparse import csc_array, vstack

    c, b_ub, upper = (np.asarray(v, dtype=float) for v in (c, b_ub, upper))
    highspy = _highspy()
    if highspy is None:
        return _by_linprog(c, a_ub, b_ub, upper, a_eq, b_eq, dual_simplex, feasibility_tol)
    n_ub = len(b_ub)
    if isinstance(a_ub, np.ndarray) and (a_eq is None or isinstance(a_eq, np.ndarray)):
        n_rows, (indptr, indices, data) = n_ub + (0 if a_eq is None else len(a_eq)), dense_columns(a_ub, a_eq)
    else:
        rows = csc_array(a_ub) if a_eq is None else csc_array(vstack([csc_array(a_ub), csc_array(a_eq)]))
        n_rows, (indptr, indices, data) = rows.shape[0], (rows.indptr, rows.indices, rows.data)
    b_eq = np.zeros(0) if b_eq is None else np.asarray(b_eq, dtype=float)
    inf = highspy.kHighsInf
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = len(c), n_rows
    lp.col_cost_ = c
    lp.col_lower_ = np.zeros(len(c))
    lp.col_upper_ = np.where(np.isinf(upper), inf, upper)
    lp.row_lower_ = np.concatenate([np.full(n_ub, -inf), b_eq])
    lp.row_upper_ = np.concatenate([b_ub, b_eq])
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    lp.a_matrix_.start_, lp.a_matrix_.index_, lp.a_matrix_.value_ = indptr, indices, data
    h = _highs()
    h.setOptionValue("solver", "simplex" if dual_simplex else "choose")
    tol = 1e-7 if feasibility_tol is None else float(feasibility_tol)  # HiGHS's defaults
    h.setOptionValue("primal_feasibility_tolerance", tol)
    h.setOptionValue("dual_feasibility_tolerance", tol)
    h.clearModel()  # a fresh model and solver: no basis carried over from the last LP
    h.passModel(lp)
    h.run()
    status = h.getModelStatus()
    if status != highspy.HighsModelStatus.kOptimal:
        return LPSolution(False, np.zeros(0), float("nan"), np.zeros(0), h.modelStatusToString(status))
    sol = h.getSolution()
    x, duals = np.asarray(sol.col_value, dtype=float), np.asarray(sol.row_dual, dtype=float)[:n_ub]
    return LPSolution(True, x, float(h.getInfo().objective_function_value), duals, "optimal")


def dense_columns(
    a_ub: np.ndarray, a_eq: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(indptr, indices, data) of ``a_ub`` stacked over ``a_eq`` in compressed columns: the arrays
    ``scipy.sparse.csc_array(vstack([csc_array(a_ub), csc_array(a_eq)]))`` holds (its nonzeros,
    column after column, rows ascending; int32 indices), without scipy's sparse constructors,
    whose checks cost more than a small LP's solve."""
    full = np.asarray(a_ub if a_eq is None else np.vstack([a_ub, a_eq]), dtype=float)
    cols, rows = np.nonzero(full.T)
    indptr = np.zeros(full.shape[1] + 1, dtype=np.int32)
    np.cumsum(np.bincount(cols, minlength=full.shape[1]), out=indptr[1:])
    return indptr, rows.astype(np.int32), full.T[cols, rows]


def _by_linprog(
    c: np.ndarray,
    a_ub: Any,
    b_ub: np.ndarray,
    upper: np.ndarray,
    a_eq: Any,
    b_eq: np.ndarray | None,
    dual_simplex: bool,
    feasibility_tol: float | None,
) -> LPSolution:
    """:func:`solve_lp` through ``scipy.optimize.linprog`` (no ``highspy``)."""
    from scipy.optimize import linprog

    options = {}
    if feasibility_tol is not None:
        options = {f"{kind}_feasibility_tolerance": feasibility_tol for kind in ("primal", "dual")}
    bounds = np.column_stack([np.zeros(len(c)), upper])
    res = linprog(c, A_ub=a_ub, b_ub=b_ub, A_eq=a_eq, b_eq=b_eq, bounds=bounds,
                  method="highs-ds" if dual_simplex else "highs", options=options)  # fmt: skip
    if res.status != 0 or res.x is None:
        return LPSolution(False, np.zeros(0), float("nan"), np.zeros(0), str(res.message))
    return LPSolution(True, np.asarray(res.x), float(res.fun), np.asarray(res.ineqlin.marginals, dtype=float),
                      str(res.message))  # fmt: skip
