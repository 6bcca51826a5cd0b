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
method ends, exactly in exact arithmetic. A vertex is priced first between the best w so far
and the master's (Wentges' smoothing, ``SMOOTH``: fewer vertices), then at the master's own w
when that one does not improve t. The master (:mod:`ios_uav_env.model.maxmin_master`) divides
the rate rows by B_k and t by B, so its numbers are O(1) whatever the rates' scale, and refines
its final solution iteratively, so that the tiny shares of a node whose B_k is far above B
(the others' partner of a far node of 1e-10 bps/Hz) are exact to rounding too.

**Certificate.** :func:`certificate` recomputes the answer from scratch: the shares are the mix
of the basic vertices' assignments (>= 0, every column sum the master's sum_j lambda_j <= 1),
the primal value is min_k R_k of those shares, w is the master's duals clipped to >= 0 and
normalised, and the dual value is g(w). The answer counts only when the shares are a schedule,
w is on the simplex and ``|dual - primal| <= FAST_TOL x dual`` (a negative gap is rounding);
otherwise (or when the simplex hits its caps) :func:`fast_schedule` returns None and the caller
solves the LP by HiGHS (``schedule.certified_schedule``).

The kernel is one source for both paths: numba's compilation, or plain Python
(``IOS_UAV_ENV_NO_NUMBA=1`` or numba absent; slower, the same answers to rounding). :func:`maxmin_row`
gives the value alone, for compiled callers (the multi-node envs' episode ends).
"""

from __future__ import annotations

import numpy as np

from ios_uav_env.jit import copy_into, jit
from ios_uav_env.model.maxmin_master import invert, master, reduced, refine

#: Largest K the fast path takes (the master has K + 1 rows; more nodes: HiGHS).
MAX_NODES = 8
#: Largest certified gap, dual - primal, in units of the dual value (relative).
FAST_TOL = 1e-12
#: The column generation stops when the priced vertex improves t by at most this, in units of B.
STOP = 1e-13
#: Weight of the best dual point so far where the next vertex is priced (Wentges' smoothing).
SMOOTH = 0.5
#: Most vertices the master keeps (then the method gives up: status ``CAPPED``).
MAX_COLUMNS = 400
#: Statuses of :func:`maxmin_kernel`.
CERTIFIED, UNCERTIFIED, CAPPED, SINGULAR = 0, 1, 2, 3

__all__ = [
    "CAPPED",
    "CERTIFIED",
    "FAST_TOL",
    "MAX_NODES",
    "SINGULAR",
    "UNCERTIFIED",
    "certificate",
    "fast_schedule",
    "maxmin_kernel",
    "maxmin_row",
]


@jit
def _price(
    r: np.ndarray, w: np.ndarray, assign: np.ndarray, bounds: np.ndarray, out: np.ndarray, top: np.ndarray
) -> float:
    """Give every slot to a node of largest w_k r_k[n] (the first on a tie): ``assign`` (N,)
    receives the nodes, ``out`` (K,) the vertex's R_k / B_k (``bounds``: B_k); returns g(w).
    ``top`` (N,) is scratch (each slot's largest w_k r_k[n]). Every loop runs over the slots
    with the node fixed, without a branch, so that it vectorises (the sums are reassociated:
    equal to the slot-by-slot sums to rounding)."""
    k_n, n_n = r.shape
    w0 = w[0]
    for n in range(n_n):
        top[n] = w0 * r[0, n]
        assign[n] = 0
    for k in range(1, k_n):
        wk = w[k]
        for n in range(n_n):
            v = wk * r[k, n]
            up = v > top[n]
            top[n] = v if up else top[n]
            assign[n] = k if up else assign[n]
    total = 0.0
    for n in range(n_n):
        total += top[n]
    for k in range(k_n):
        s = 0.0
        for n in range(n_n):
            s += r[k, n] if assign[n] == k else 0.0
        out[k] = s / (n_n * bounds[k])
    return total / n_n


@jit
def maxmin_kernel(r: np.ndarray, shares: np.ndarray, weights: np.ndarray) -> tuple[float, float, int, int]:
    """Solve (P) for the (K, N) rates ``r`` (finite, >= 0, 2 <= K <= ``MAX_NODES``, every B_k > 0):
    ``shares`` (K, N) and ``weights`` (K,) receive the schedule and the dual weights. Returns
    (primal value, dual value g(w), status, vertices generated); the status is ``CERTIFIED``
    when |dual - primal| <= ``FAST_TOL`` x dual (module docstring)."""
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
    top = np.empty(n_n)  # (_price's scratch)
    best_g = _price(r, w, assign[0], bounds, cols[0], top)
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
    if not invert(basis, k_n, cols, coef, inv):
        status = SINGULAR
    while status == CERTIFIED:
        pivots = master(basis, in_basis, k_n, n_cols, cols, coef, inv, y, pivots)
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
        for k in range(k_n):  # price first between the best w so far and the master's (smoothing)
            w_s[k] = SMOOTH * w_best[k] + (1.0 - SMOOTH) * w[k]
        g = _price(r, w_s, assign[n_cols], bounds, cols[n_cols], top)
        if g < best_g:
            best_g = g
            copy_into(w_best, w_s)
        if reduced(new, k_n, y, cols, coef) > STOP:  # it improves the master's t: keep it
            n_cols += 1
            continue
        g = _price(r, w, assign[n_cols], bounds, cols[n_cols], top)  # else the master's own w
        if g < best_g:
            best_g = g
            copy_into(w_best, w)
        if reduced(new, k_n, y, cols, coef) <= STOP:
            break
        n_cols += 1
    if status != CERTIFIED:
        return np.nan, np.nan, status, n_cols
    if not invert(basis, k_n, cols, coef, inv):  # a fresh B^-1 for the final x_B and duals
        return np.nan, np.nan, SINGULAR, n_cols
    x = np.empty(m)
    refine(basis, k_n, cols, coef, inv, x, y)
    return _certify(r, basis, k_n, x, y, coef, assign, shares, weights, n_cols)


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
    total = 0.0
    for k in range(k_n):
        weights[k] = max(-y[k], 0.0) * coef[k]
        total += weights[k]
    if not total > 0.0:
        return np.nan, np.nan, SINGULAR, n_cols
    for k in range(k_n):
        weights[k] /= total
    primal, dual, status = certificate(r, shares, weights)
    return primal, dual, status, n_cols


@jit
def certificate(r: np.ndarray, shares: np.ndarray, weights: np.ndarray) -> tuple[float, float, int]:
    """(primal, dual, status) of a proposed answer for the (K, N) rates ``r``: primal = min_k
    (1/N) sum_n shares_k[n] r_k[n], dual = g(weights); ``CERTIFIED`` when the shares are a
    schedule (>= 0, column sums <= 1 + 1e-12: rounding), the weights lie on the simplex (to 1e-12) and
    |dual - primal| <= ``FAST_TOL`` x dual (a negative gap is rounding), else ``UNCERTIFIED``.
    Independent of how the answer was found: by weak duality primal <= V <= dual."""
    k_n, n_n = r.shape
    feasible = True
    for n in range(n_n):
        column = 0.0
        for k in range(k_n):
            feasible = feasible and shares[k, n] >= 0.0
            column += shares[k, n]
        feasible = feasible and column <= 1.0 + 1e-12
    total = 0.0
    for k in range(k_n):
        feasible = feasible and weights[k] >= 0.0
        total += weights[k]
    feasible = feasible and abs(total - 1.0) <= 1e-12
    primal = np.inf
    for k in range(k_n):
        s = 0.0
        for n in range(n_n):
            s += shares[k, n] * r[k, n]
        primal = min(primal, s / n_n)
    dual = 0.0
    for n in range(n_n):
        top = 0.0
        for k in range(k_n):
            top = max(top, weights[k] * r[k, n])
        dual += top
    dual /= n_n
    gap = dual - primal
    ok = feasible and primal > 0.0 and -FAST_TOL * dual <= gap <= FAST_TOL * dual
    return primal, dual, CERTIFIED if ok else UNCERTIFIED


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
