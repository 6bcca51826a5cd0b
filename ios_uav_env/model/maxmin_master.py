"""The master problem of :mod:`ios_uav_env.model.maxmin`'s column generation: a dense primal
simplex on max t s.t. sum_j lambda_j R^j / B_k - t B / B_k - s_k = 0 (k < K), sum_j lambda_j = 1,
lambda, t, s >= 0 (K + 1 rows), compiled with :func:`ios_uav_env.jit.jit`.

Variables: v < K the slack s_v, v = K the value t (in units of B), v = K + 1 + j vertex j
(``cols[j]``: R^j_k / B_k; ``coef``: B / B_k). ``basis`` (K + 1,) lists the basic variables by
row position and ``inv`` holds B^-1, updated by each pivot and refactorised every 32 and at the
end; the duals y = c_B B^-1 give the weights w_k = -y_k B / B_k.
"""

from __future__ import annotations

import numpy as np

from ios_uav_env.jit import jit

#: A reduced cost (units of B) above this lets a column enter the basis.
ENTER = 1e-14
#: Most simplex pivots of one solve.
MAX_PIVOTS = 4000
#: Entries of a pivot column below this fraction of its largest are rounding noise.
NOISE = 1e-14
#: Steps of iterative refinement of the final basic solution and duals.
REFINE = 2

__all__ = ["ENTER", "MAX_PIVOTS", "NOISE", "REFINE", "invert", "master", "reduced", "refine"]


@jit
def _column(v: int, k_n: int, cols: np.ndarray, coef: np.ndarray, out: np.ndarray) -> None:
    """The master's column of variable ``v`` into ``out`` (K + 1,): slack k < K (-e_k), t (K:
    -B / B_k in rate row k) or vertex j = v - K - 1 (R^j_k / B_k, then 1 in the convexity row)."""
    for i in range(k_n + 1):
        out[i] = 0.0
    if v < k_n:
        out[v] = -1.0
    elif v == k_n:
        for i in range(k_n):
            out[i] = -coef[i]
    else:
        for i in range(k_n):
            out[i] = cols[v - k_n - 1, i]
        out[k_n] = 1.0


@jit
def invert(basis: np.ndarray, k_n: int, cols: np.ndarray, coef: np.ndarray, inv: np.ndarray) -> bool:
    """``inv`` = the inverse of the basis matrix (Gauss-Jordan, partial pivoting); False if singular."""
    m = k_n + 1
    a = np.zeros((m, 2 * m))
    col = np.empty(m)
    for j in range(m):
        _column(basis[j], k_n, cols, coef, col)
        for i in range(m):
            a[i, j] = col[i]
        a[j, m + j] = 1.0
    for j in range(m):
        p = j
        for i in range(j + 1, m):
            if abs(a[i, j]) > abs(a[p, j]):
                p = i
        if abs(a[p, j]) < 1e-13:
            return False
        if p != j:
            for c in range(2 * m):
                a[j, c], a[p, c] = a[p, c], a[j, c]
        piv = a[j, j]
        for c in range(2 * m):
            a[j, c] /= piv
        for i in range(m):
            if i != j and a[i, j] != 0.0:
                f = a[i, j]
                for c in range(2 * m):
                    a[i, c] -= f * a[j, c]
    for i in range(m):
        for c in range(m):
            inv[i, c] = a[i, m + c]
    return True


@jit
def _duals(basis: np.ndarray, k_n: int, inv: np.ndarray, y: np.ndarray) -> None:
    """y = c_B B^-1: the row of B^-1 at t's basis position (t is the only cost), or 0."""
    for i in range(k_n + 1):
        y[i] = 0.0
    for p in range(k_n + 1):
        if basis[p] == k_n:
            for i in range(k_n + 1):
                y[i] = inv[p, i]


@jit
def reduced(v: int, k_n: int, y: np.ndarray, cols: np.ndarray, coef: np.ndarray) -> float:
    """Reduced cost c_v - y A_v of variable ``v`` (maximising t)."""
    if v < k_n:
        return y[v]
    if v == k_n:
        d = 1.0
        for i in range(k_n):
            d += y[i] * coef[i]
        return d
    d = -y[k_n]
    for i in range(k_n):
        d -= y[i] * cols[v - k_n - 1, i]
    return d


@jit
def master(
    basis: np.ndarray, in_basis: np.ndarray, k_n: int, n_cols: int, cols: np.ndarray, coef: np.ndarray,
    inv: np.ndarray, y: np.ndarray, pivots: int,
) -> int:  # fmt: skip
    """Primal simplex on the master's ``n_cols`` vertices (Dantzig's rule; Bland's after
    degenerate pivots) until no reduced cost exceeds ``ENTER``; leaves its duals in ``y``.
    Returns the pivot count so far, or -1 (singular basis) / -2 (``MAX_PIVOTS``)."""
    m = k_n + 1
    u = np.empty(m)
    col = np.empty(m)
    stall = 0
    while True:
        _duals(basis, k_n, inv, y)
        enter, best = -1, ENTER
        for v in range(k_n + 1 + n_cols):
            if not in_basis[v]:
                d = reduced(v, k_n, y, cols, coef)
                if d > best:
                    enter, best = v, d
                    if stall > 2 * m:  # Bland: the first improving variable
                        break
        if enter < 0:
            return pivots
        if pivots >= MAX_PIVOTS:
            return -2
        _column(enter, k_n, cols, coef, col)
        for i in range(m):
            s = 0.0
            for c in range(m):
                s += inv[i, c] * col[c]
            u[i] = s
        top = 0.0
        for i in range(m):
            top = max(top, abs(u[i]))
        leave, ratio = -1, np.inf
        for i in range(m):
            if u[i] > NOISE * top:
                q = max(inv[i, k_n], 0.0) / u[i]  # x_B = B^-1 e_K
                if q < ratio or (q == ratio and u[i] > u[leave]):
                    leave, ratio = i, q
        if leave < 0:
            return -1  # unbounded: cannot happen (t <= min_k B_k); treat as a failure
        stall = stall + 1 if ratio == 0.0 else 0
        in_basis[basis[leave]] = False
        basis[leave] = enter
        in_basis[enter] = True
        pivots += 1
        if pivots % 32 == 0:
            if not invert(basis, k_n, cols, coef, inv):
                return -1
        else:
            p = u[leave]
            for c in range(m):
                inv[leave, c] /= p
            for i in range(m):
                if i != leave and u[i] != 0.0:
                    f = u[i]
                    for c in range(m):
                        inv[i, c] -= f * inv[leave, c]


@jit
def refine(
    basis: np.ndarray, k_n: int, cols: np.ndarray, coef: np.ndarray, inv: np.ndarray, x: np.ndarray,
    y: np.ndarray,
) -> None:  # fmt: skip
    """The basic solution x (B x = e_K) and the duals y (y B = c_B) from ``inv`` = B^-1, each
    with ``REFINE`` steps of iterative refinement: the residual of every row is computed in that
    row's own scale, so the small shares of nodes whose full-time rates B_k are far above B
    (rows whose numbers are all small) are exact to rounding too, not only to eps x the
    largest row's scale."""
    m = k_n + 1
    col = np.empty(m)
    res = np.empty(m)
    for i in range(m):
        x[i] = inv[i, k_n]
    _duals(basis, k_n, inv, y)
    for _ in range(REFINE):
        for i in range(m):
            res[i] = 1.0 if i == k_n else 0.0
        for j in range(m):
            _column(basis[j], k_n, cols, coef, col)
            for i in range(m):
                res[i] -= col[i] * x[j]
        for i in range(m):
            s = 0.0
            for c in range(m):
                s += inv[i, c] * res[c]
            x[i] += s
        for j in range(m):  # y's residual: c_B[j] - y B_j
            _column(basis[j], k_n, cols, coef, col)
            s = 1.0 if basis[j] == k_n else 0.0
            for i in range(m):
                s -= y[i] * col[i]
            res[j] = s
        for i in range(m):
            s = 0.0
            for c in range(m):
                s += res[c] * inv[c, i]
            y[i] += s
