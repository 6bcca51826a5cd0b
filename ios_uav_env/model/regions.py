r"""The max-min rate of a flight whose every slot offers a region of rate vectors, with time sharing.

TDMA (``ios_uav_env.model.schedule``) is one case: in slot n the UAV can give node k the rate
r_k[n] alone, and time sharing makes the slot's region the simplex hull of those points. A link
that serves several nodes at once (a superposition power split, several beams, a surface
configured for a pair of users on its two sides) offers more: any rate vector R in a set
C_n (K components, bps/Hz). With time sharing inside the slot, the slot's region is conv(C_n) and
the flight's problem is

    V = max { min_k R_k :  R = (1/N) sum_n R[n],  R[n] in conv(C_n) }.

**Dual.** R ranges over the Minkowski average S = (1/N) sum_n conv(C_n), a compact convex set whose
support function is g(w) = max_{R in S} w . R = (1/N) sum_n max_{R in C_n} w . R. For w in the
simplex, min_k R_k <= w . R <= g(w), so V <= g(w) for every w (and V = min_w g(w) by LP duality
on the convex set S). The per-slot maximisation, max_{R in C_n} w . R, is the link's *weighted-sum
problem*: the per-slot optimum any reference of such a link solves anyway.

**Method** (Dantzig-Wolfe, the column generation of ``ios_uav_env.model.maxmin`` with a general
pricing). A *pricer* maps weights w to a point of S, the average of per-slot maximisers (a
schedule: each slot's choice at w), and an upper bound of g(w) (the maximum itself when the
per-slot problem is solved exactly; a certified bound when it is not). The master keeps the
points R^j found so far and solves max t s.t. sum_j lambda_j R^j >= t, sum_j lambda_j = 1,
lambda >= 0 (an LP of K + 1 rows); its duals on the rate rows are the next w. Every master
solution is a schedule (slot n time-shares the choices of the points it mixes, lambda_j each),
so t <= V <= min over the visited w of the pricer's bound; the method stops when the two are
within ``tol`` (relative) or after ``max_columns`` points.

**Certificate.** ``value`` is min_k of the mixed point, recomputed from the points; ``upper`` is the
least bound the pricer returned; both are returned, and ``value <= V <= upper`` holds whatever the
master's rounding (weak duality; an inexact pricer only loosens ``upper``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from ios_uav_env.model.lp import solve_lp

#: A pricer: weights w (K,) on the simplex -> (a point of S (K,), an upper bound of g(w)).
Pricer = Callable[[np.ndarray], tuple[np.ndarray, float]]

__all__ = [
    "Pricer",
    "RegionSchedule",
    "broadcast_pricer",
    "maxmin_regions",
    "tdma_pricer",
    "weighted_noma",
    "weighted_noma_array",
]


@dataclasses.dataclass(frozen=True)
class RegionSchedule:
    """The answer of :func:`maxmin_regions`: ``value`` (bps/Hz, min_k of ``rates``, a schedule's)
    <= V <= ``upper``; ``rates`` (K,) the flight's average rates of the schedule; ``mix`` (J,)
    the time shares lambda_j of the ``points`` (J, K) priced, in the order priced, and
    ``weights`` (J, K) the w each was priced at (a caller that keeps the per-slot choices of
    each w rebuilds the schedule from these); ``dual_weights`` the w of ``upper``."""

    value: float
    upper: float
    rates: np.ndarray
    mix: np.ndarray
    points: np.ndarray
    weights: np.ndarray
    dual_weights: np.ndarray

    @property
    def gap(self) -> float:
        """upper / value - 1 (0 when both are 0)."""
        return 0.0 if self.upper == self.value else self.upper / self.value - 1.0


def _check_point(point: np.ndarray, bound: float, w: np.ndarray, k: int) -> tuple[np.ndarray, float]:
    p = np.asarray(point, dtype=float)
    if p.shape != (k,) or not np.all(np.isfinite(p)) or np.any(p < 0):
        raise ValueError(f"the pricer must return a point of K = {k} finite rates >= 0, got {point!r}")
    b = float(bound)
    if not np.isfinite(b) or b < float(w @ p) - 1e-12 * max(1.0, abs(b)):
        raise ValueError(
            f"the pricer's bound {bound!r} is below w . point = {float(w @ p)!r}: not a bound of g(w)"
        )
    return p, b


def _master(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lambda (J,), w (K,)) of max t s.t. sum_j lambda_j R^j >= t, sum lambda = 1 (module docstring)."""
    j, k = points.shape
    c = np.zeros(j + 1)
    c[-1] = -1.0  # min -t (t >= 0: the rates are)
    a_ub = np.hstack([-points.T, np.ones((k, 1))])  # t - sum_j lambda_j R^j_k <= 0
    a_eq = np.hstack([np.ones((1, j)), np.zeros((1, 1))])
    sol = solve_lp(
        c, a_ub, np.zeros(k), np.full(j + 1, np.inf), a_eq=a_eq, b_eq=np.ones(1), feasibility_tol=1e-10
    )
    if not sol.optimal:
        raise RuntimeError(f"the master LP of maxmin_regions failed: {sol.message}")
    lam = np.maximum(sol.x[:j], 0.0)
    w = np.maximum(-sol.ub_duals, 0.0)
    total = w.sum()
    w = w / total if total > 0 else np.full(k, 1.0 / k)
    return lam / lam.sum(), w


def maxmin_regions(
    price: Pricer, k: int, *, tol: float = 1e-9, max_columns: int = 200, start: np.ndarray | None = None
) -> RegionSchedule:
    """V for K = ``k`` nodes, priced by ``price`` (module docstring): the best schedule found and a
    certified upper bound. ``start``: the first w (default: each node alone, then uniform)."""
    if not (isinstance(k, int) and k >= 1):
        raise ValueError(f"k must be an integer >= 1 (the number of nodes), got {k!r}")
    if not (isinstance(tol, (int, float)) and 0 < tol < 1):
        raise ValueError(f"tol must be a number in (0, 1), got {tol!r}")
    if not (isinstance(max_columns, int) and max_columns > k):
        raise ValueError(f"max_columns must be an integer > k = {k}, got {max_columns!r}")
    firsts = list(np.eye(k)) + [np.full(k, 1.0 / k)] if start is None else [np.asarray(start, dtype=float)]
    points, weights, upper, best_w = [], [], np.inf, firsts[-1]
    for w in firsts:
        if w.shape != (k,) or np.any(w < 0) or abs(w.sum() - 1.0) > 1e-9:
            raise ValueError(f"start must be K = {k} weights >= 0 summing to 1, got {w!r}")
        p, b = _check_point(*price(w), w, k)
        points.append(p)
        weights.append(w)
        if b < upper:
            upper, best_w = b, w
    while True:
        lam, w = _master(np.array(points))
        rates = lam @ np.array(points)
        value = float(rates.min())
        if upper - value <= tol * upper or len(points) >= max_columns:
            break
        p, b = _check_point(*price(w), w, k)
        if b < upper:
            upper, best_w = b, w
        # the master's t is max_j w . R^j at its own w: a point no better there cannot enter (with
        # an exact pricer then g(w) = t and the bound has closed; an inexact one stalls here)
        if upper - value <= tol * upper or float(w @ p) <= value * (1 + 1e-12):
            break
        points.append(p)
        weights.append(w)
    if value > upper * (1 + 1e-9):
        raise RuntimeError(f"maxmin_regions: the schedule's {value!r} exceeds the dual bound {upper!r}")
    upper = max(upper, value)  # (they differ by rounding at the most: checked above)
    return RegionSchedule(
        value=value, upper=upper, rates=rates, mix=lam, points=np.array(points),
        weights=np.array(weights), dual_weights=best_w,
    )  # fmt: skip


def tdma_pricer(rates: np.ndarray) -> Pricer:
    """The pricer of TDMA on the (K, N) slot rates ``rates``: at w every slot goes whole to a node
    of largest w_k r_k[n]; exact, so its bound is g(w) itself."""
    r = np.asarray(rates, dtype=float)

    def price(w: np.ndarray) -> tuple[np.ndarray, float]:
        weighted = w[:, None] * r
        best = np.argmax(weighted, axis=0)
        point = np.zeros(r.shape[0])
        np.add.at(point, best, r[best, np.arange(r.shape[1])])
        return point / r.shape[1], float(weighted.max(axis=0).mean())

    return price


def weighted_noma(g_r: float, g_t: float, w: float) -> tuple[float, float, float, float]:
    """max over the power split of w R_r + (1 - w) R_t for two users' SNRs (g_r, g_t) served by
    superposition (:func:`broadcast_pricer`; in a STAR slot r and t are the two sides' users):
    (value, R_r, R_t, split), split the power share of user r.
    The strong user's power fraction x enters as c_s log(1 + x g_s) - c_w log(1 + x g_w) + const,
    whose derivative vanishes once, at x = (c_w g_w - c_s g_s) / (g_s g_w (c_s - c_w)): the
    maximum is at x = 0, 1 or there."""
    r_strong = g_r >= g_t
    g_s, g_w = (g_r, g_t) if r_strong else (g_t, g_r)
    c_s, c_w = (w, 1 - w) if r_strong else (1 - w, w)
    xs = [0.0, 1.0]
    if c_s != c_w and g_s > 0 and g_w > 0:
        x = (c_w * g_w - c_s * g_s) / (g_s * g_w * (c_s - c_w))
        if 0 < x < 1:
            xs.append(x)
    best = None
    for x in xs:
        r_s, r_w = math.log2(1 + x * g_s), math.log2((1 + g_w) / (1 + x * g_w))
        value = c_s * r_s + c_w * r_w
        if best is None or value > best[0]:
            best = (value, r_s, r_w, x) if r_strong else (value, r_w, r_s, 1 - x)
    return best


def weighted_noma_array(
    g_r: np.ndarray, g_t: np.ndarray, w: np.ndarray | float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`weighted_noma` elementwise over broadcast arrays of SNRs and weights: (value, R_r, R_t)
    of max over the power split of w R_r + (1 - w) R_t, with the same candidates (x = 0, 1 and the
    stationary point), formulas and order, so its values equal the scalar function's (tested; the
    scalar one is the fast path of a branch and bound's single evaluations)."""
    g_r, g_t, w = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (g_r, g_t, w)))
    r_strong = g_r >= g_t
    g_s, g_w = np.where(r_strong, g_r, g_t), np.where(r_strong, g_t, g_r)
    c_s, c_w = np.where(r_strong, w, 1 - w), np.where(r_strong, 1 - w, w)
    with np.errstate(divide="ignore", invalid="ignore"):
        stationary = (c_w * g_w - c_s * g_s) / (g_s * g_w * (c_s - c_w))
    inside = (c_s != c_w) & (g_s > 0) & (g_w > 0) & (stationary > 0) & (stationary < 1)
    best = np.full(g_r.shape, -np.inf)
    rate_s, rate_w = np.zeros(g_r.shape), np.zeros(g_r.shape)
    for x, allowed in ((0.0, True), (1.0, True), (np.where(inside, stationary, 0.0), inside)):
        r_s, r_w = np.log2(1 + x * g_s), np.log2((1 + g_w) / (1 + x * g_w))
        value = np.where(allowed, c_s * r_s + c_w * r_w, -np.inf)
        take = value > best
        best = np.where(take, value, best)
        rate_s, rate_w = np.where(take, r_s, rate_s), np.where(take, r_w, rate_w)
    return best, np.where(r_strong, rate_s, rate_w), np.where(r_strong, rate_w, rate_s)


def broadcast_pricer(snr: np.ndarray) -> Pricer:
    r"""The pricer of two users served at once by superposition coding (power-domain NOMA) with
    successive interference cancellation at the stronger user, on ``snr`` (2, N): each user's
    SNR per unit transmit power in slot n (eta |h_k|^2, linear). With power share p to the
    stronger user s (SNR a) and 1 - p to the weaker w (SNR b <= a), the rates are
    R_s = log2(1 + p a) and R_w = log2(1 + (1 - p) b / (p b + 1)) = log2((1 + b) / (1 + p b)):
    the boundary of the capacity region of the degraded Gaussian broadcast channel (Cover and
    Thomas, "Elements of Information Theory", 2nd ed., section 15.6.3), which contains the TDMA
    region (p = 1 or 0 gives each user alone). The weighted-sum maximum over p is exact
    (:func:`weighted_noma`), so the bound is g(w)."""
    g = np.asarray(snr, dtype=float)
    if g.ndim != 2 or g.shape[0] != 2 or not np.all(np.isfinite(g)) or np.any(g < 0):
        raise ValueError(f"snr must be a (2, N) array of finite SNRs >= 0, got shape {g.shape}")

    def price(w: np.ndarray) -> tuple[np.ndarray, float]:
        point, total = np.zeros(2), 0.0
        for n in range(g.shape[1]):
            value, r_0, r_1, _ = weighted_noma(float(g[0, n]), float(g[1, n]), float(w[0]))
            point += (r_0, r_1)
            total += value
        return point / g.shape[1], total / g.shape[1]

    return price
