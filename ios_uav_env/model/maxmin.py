r"""The max-min TDMA schedule of a few nodes without a general LP solver: an exact column
generation on the dual, compiled with :func:`ios_uav_env.jit.jit`.

The problem is (P) of :mod:`ios_uav_env.model.schedule`: V = max_alpha min_k R_k over the
shares alpha_k[n] >= 0, sum_k alpha_k[n] <= 1, R_k = (1/N) sum_n alpha_k[n] r_k[n], with its
dual V = min_{w in simplex} g(w), g(w) = (1/N) sum_n max_k w_k r_k[n].

**Method** (Dantzig-Wolfe decomposition; on the dual, Kelley's cutting planes). The vector
R = (R_k) ranges over a polytope S whose support function is g: for weights w >= 0 the best
point of S is a vertex, every slot given whole to a node of largest w_k r_k[n] (the *pricing*
of w). The master problem keeps a few such vertices R^j and solves max t s.t.
sum_j lambda_j R^j >= t, sum_j lambda_j = 1, lambda >= 0 (K + 1 rows) by a dense primal
simplex; its duals on the K rate rows are weights w, and t <= V <= g(w) (the master's point is
a schedule, the mix of its vertices' assignments; g(w) is the dual bound). The vertex priced
at w is added while g(w) - t > ``STOP`` x B (B = min_k B_k, B_k the rate of node k given
every slot, V <= B <= K V); S has finitely many vertices and each added one is new, so the
method ends, exactly in exact arithmetic. The rate rows are divided by B_k and t by B, so the
master's numbers are O(1) whatever the rates' scale (far nodes of 1e-10 bps/Hz included).

**Certificate.** The result is recomputed from scratch: the shares are the mix of the basic
vertices' assignments (>= 0, every column sum the master's sum_j lambda_j, scaled down to <= 1),
the primal value is min_k R_k of those shares, w is the master's duals clipped to >= 0 and
normalised, and the dual value is g(w). :func:`fast_schedule` accepts the answer only when
``0 <= dual - primal <= FAST_TOL x dual``; otherwise (or when the simplex hits its caps) it
returns None and the caller solves the LP by HiGHS (``schedule.maxmin_schedule``).

The kernel is one source for both paths: numba's compilation, or plain Python
(``IOS_UAV_ENV_NO_NUMBA=1`` or numba absent; much slower, same answers). :func:`maxmin_row`
gives the value alone, for compiled callers (the multi-node envs' episode ends).
"""

from __future__ import annotations

import numpy as np

from ios_uav_env.jit import jit

#: Largest K the fast path takes (the master has K + 1 rows; more nodes: HiGHS).
MAX_NODES = 8
#: Largest certified gap, dual - primal, in units of the dual value (relative).
FAST_TOL = 1e-12
#: The column generation stops when the priced vertex improves t by at most this, in units of B.
STOP = 1e-13
#: A reduced cost (units of B) above this lets a column enter the master's basis.
ENTER = 1e-14
#: Weight of the best dual point so far where the next vertex is priced (Wentges' smoothing).
SMOOTH = 0.5
#: Most vertices the master keeps (then the method gives up: status ``CAPPED``).
MAX_COLUMNS = 400
#: Most simplex pivots of one solve.
MAX_PIVOTS = 4000
#: Entries of a pivot column below this fraction of its largest are rounding noise.
NOISE = 1e-14
#: Steps of iterative refinement of the final basic solution and duals.
REFINE = 2
#: Statuses of :func:`maxmin_kernel`.
CERTIFIED, UNCERTIFIED, CAPPED, SINGULAR = 0, 1, 2, 3

__all__ = [
    "CAPPED",
    "CERTIFIED",
    "FAST_TOL",
    "MAX_NODES",
    "SINGULAR",
    "UNCERTIFIED",
    "fast_schedule",
    "maxmin_kernel",
    "maxmin_row",
]


@jit
def _price(r: np.ndarray, w: np.ndarray, assign: np.ndarray, bounds: np.ndarray, out: np.ndarray) -> float:
    """Give every slot to a node of largest w_k r_k[n] (the first on a tie): ``assign`` (N,)
    receives the nodes, ``out`` (K,) the vertex's R_k / B_k (``bounds``: B_k); returns g(w)."""
    k_n, n_n = r.shape
    for k in range(k_n):
        out[k] = 0.0
    total = 0.0
    for n in range(n_n):
        best, top = 0, w[0] * r[0, n]
        for k in range(1, k_n):
            v = w[k] * r[k, n]
            if v > top:
                best, top = k, v
        assign[n] = best
        out[best] += r[best, n]
        total += top
    for k in range(k_n):
        out[k] /= n_n * bounds[k]
    return total / n_n


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
def _invert(basis: np.ndarray, k_n: int, cols: np.ndarray, coef: np.ndarray, inv: np.ndarray) -> bool:
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
def _reduced(v: int, k_n: int, y: np.ndarray, cols: np.ndarray, coef: np.ndarray) -> float:
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
def _master(
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
                d = _reduced(v, k_n, y, cols, coef)
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
            if not _invert(basis, k_n, cols, coef, inv):
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
def maxmin_kernel(r: np.ndarray, shares: np.ndarray, weights: np.ndarray) -> tuple[float, float, int, int]:
    """Solve (P) for the (K, N) rates ``r`` (finite, >= 0, 2 <= K <= ``MAX_NODES``, every B_k > 0):
    ``shares`` (K, N) and ``weights`` (K,) receive the schedule and the dual weights. Returns
    (primal value, dual value g(w), status, vertices generated); the status is ``CERTIFIED``
    when 0 <= dual - primal <= ``FAST_TOL`` x dual (module docstring)."""
    k_n, n_n = r.shape
    bounds = np.zeros(k_n)
    for k in range(k_n):
        s = 0.0
        for n in range(n_n):
            s += r[k, n]
        bounds[k] = s / n_n
    low = bounds.min()
    coef = np.empty(k_n)  # t's entries: B / B_k
    w = np.empty(k_n)
    total = 0.0
    for k in range(k_n):
        coef[k] = low / bounds[k]
        total += coef[k]
    for k in range(k_n):
        w[k] = coef[k] / total  # start at w_k ~ 1 / B_k: every node's full time valued alike
    cols = np.zeros((MAX_COLUMNS, k_n))
    assign = np.empty((MAX_COLUMNS, n_n), dtype=np.int8)
    best_g = _price(r, w, assign[0], bounds, cols[0])
    w_best, w_s = w.copy(), np.empty(k_n)
    n_cols = 1
    m = k_n + 1
    basis = np.empty(m, dtype=np.int64)
    in_basis = np.zeros(k_n + 1 + MAX_COLUMNS, dtype=np.bool_)
    for k in range(k_n):
        basis[k] = k  # the slacks, and the first vertex in the convexity row
        in_basis[k] = True
    basis[k_n] = k_n + 1
    in_basis[k_n + 1] = True
    inv = np.zeros((m, m))
    y = np.zeros(m)
    status, pivots = CERTIFIED, 0
    if not _invert(basis, k_n, cols, coef, inv):
        status = SINGULAR
    while status == CERTIFIED:
        pivots = _master(basis, in_basis, k_n, n_cols, cols, coef, inv, y, pivots)
        if pivots < 0:
            status = SINGULAR if pivots == -1 else CAPPED
            break
        total = 0.0
        for k in range(k_n):
            w[k] = max(-y[k], 0.0) * coef[k]  # w_k = -y_k B / B_k (rows scaled by 1 / B_k)
            total += w[k]
        if not total > 0.0:
            status = SINGULAR
            break
        for k in range(k_n):
            w[k] /= total
        if n_cols == MAX_COLUMNS:
            status = CAPPED
            break
        new = k_n + 1 + n_cols
        if best_g < np.inf:  # price first between the best w so far and the master's (smoothing)
            for k in range(k_n):
                w_s[k] = SMOOTH * w_best[k] + (1.0 - SMOOTH) * w[k]
            g = _price(r, w_s, assign[n_cols], bounds, cols[n_cols])
            if g < best_g:
                best_g = g
                w_best[:] = w_s
            if _reduced(new, k_n, y, cols, coef) > STOP:
                n_cols += 1
                continue
        g = _price(r, w, assign[n_cols], bounds, cols[n_cols])
        if g < best_g:
            best_g = g
            w_best[:] = w
        if _reduced(new, k_n, y, cols, coef) <= STOP:
            break
        n_cols += 1
    if status != CERTIFIED:
        return np.nan, np.nan, status, n_cols
    if not _invert(basis, k_n, cols, coef, inv):  # a fresh B^-1 for the final x_B and duals
        return np.nan, np.nan, SINGULAR, n_cols
    x = np.empty(m)
    _refine(basis, k_n, cols, coef, inv, x, y)
    return _certify(r, basis, k_n, x, y, coef, assign, shares, weights, n_cols)


@jit
def _refine(
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


@jit
def _certify(
    r: np.ndarray, basis: np.ndarray, k_n: int, x: np.ndarray, y: np.ndarray, coef: np.ndarray,
    assign: np.ndarray, shares: np.ndarray, weights: np.ndarray, n_cols: int,
) -> tuple[float, float, int, int]:  # fmt: skip
    """The shares (the basic vertices' mix) and weights of the final basis, their values from
    scratch, and the status of the gap (:func:`maxmin_kernel`)."""
    n_n = r.shape[1]
    shares[:, :] = 0.0
    mass = 0.0
    for p in range(k_n + 1):
        if basis[p] > k_n:
            mass += max(x[p], 0.0)
    if not mass > 0.0:
        return np.nan, np.nan, SINGULAR, n_cols
    scale = 1.0 / mass if mass > 1.0 else 1.0
    for p in range(k_n + 1):
        if basis[p] > k_n:
            lam = max(x[p], 0.0) * scale
            if lam > 0.0:
                row = assign[basis[p] - k_n - 1]
                for n in range(n_n):
                    shares[row[n], n] += lam
    primal = np.inf
    for k in range(k_n):
        s = 0.0
        for n in range(n_n):
            s += shares[k, n] * r[k, n]
        primal = min(primal, s / n_n)
    total = 0.0
    for k in range(k_n):
        weights[k] = max(-y[k], 0.0) * coef[k]
        total += weights[k]
    if not total > 0.0:
        return np.nan, np.nan, SINGULAR, n_cols
    for k in range(k_n):
        weights[k] /= total
    dual = 0.0
    for n in range(n_n):
        top = 0.0
        for k in range(k_n):
            top = max(top, weights[k] * r[k, n])
        dual += top
    dual /= n_n
    gap = dual - primal
    ok = primal > 0.0 and gap >= -FAST_TOL * dual and gap <= FAST_TOL * dual
    return primal, dual, CERTIFIED if ok else UNCERTIFIED, n_cols


@jit
def maxmin_row(r: np.ndarray) -> tuple[float, float, int]:
    """(primal value, dual value, status) of the (K, N) rates ``r`` (finite, >= 0): K = 1 its
    mean rate; a node of B_k = 0 value 0 (certified by w on that node); 2 <= K <=
    ``MAX_NODES`` :func:`maxmin_kernel`; more nodes NaN with status ``CAPPED``. For callers that
    need the value only (the multi-node envs' episode ends, compiled, row by row)."""
    k_n, n_n = r.shape
    low = np.inf
    for k in range(k_n):
        s = 0.0
        for n in range(n_n):
            s += r[k, n]
        low = min(low, s / n_n)
    if k_n == 1 or low == 0.0:
        return low, low, CERTIFIED
    if k_n > MAX_NODES:
        return np.nan, np.nan, CAPPED
    value, dual, status, _ = maxmin_kernel(r, np.empty((k_n, n_n)), np.empty(k_n))
    return value, dual, status


def fast_schedule(rates: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float] | None:
    """(shares, weights, primal value, dual value) of the (K, N) ``rates`` (finite, >= 0,
    2 <= K <= ``MAX_NODES``, every node's mean rate > 0) by :func:`maxmin_kernel`, or None when
    the answer is not certified (the caller then solves the LP by HiGHS)."""
    r = np.ascontiguousarray(rates, dtype=np.float64)
    if r.ndim != 2 or not 2 <= r.shape[0] <= MAX_NODES or r.shape[1] < 1:
        raise ValueError(f"rates must be a (K, N) array with 2 <= K <= {MAX_NODES}, N >= 1; got {r.shape}")
    shares, weights = np.empty(r.shape), np.empty(r.shape[0])
    value, dual, status, _ = maxmin_kernel(r, shares, weights)
    if status != CERTIFIED:
        return None
    return shares, weights, float(value), float(dual)
