r"""The certified best TDMA schedule of a rate matrix: the linear programme (P), its dual (D) and
their agreement, with HiGHS (``ios_uav_env.model.lp``).

For a (K, N) matrix of rates r_k[n] >= 0 (node k's rate in slot n) the best schedule is

    V = max_alpha min_k R_k,   R_k = (1/N) sum_n alpha_k[n] r_k[n]                    (P)

over shares alpha_k[n] >= 0, sum_k alpha_k[n] <= 1: a linear programme in (alpha, t): max t s.t.
(1/N) sum_n alpha_k[n] r_k[n] >= t for all k, sum_k alpha_k[n] <= 1, alpha >= 0. Its dual is

    V = min_{w in simplex} g(w),   g(w) = (1/N) sum_n max_k w_k r_k[n]                (D)

(weak duality is one line: for feasible alpha, min_k R_k <= sum_k w_k R_k
= (1/N) sum_n sum_k alpha_k[n] w_k r_k[n] <= g(w)). What the rates are (the nodes along a
flight) and which solver scores a flight is :mod:`ios_uav_env.model.schedule`'s; its
``certified_schedule`` falls back to :func:`maxmin_schedule` here. Every name here is
importable from :mod:`ios_uav_env.model.schedule` too.

**Certified value.** :func:`maxmin_schedule` solves (P) with HiGHS, cleans the shares
(clipped to [0, 1], each slot's column scaled down to sum <= 1) and computes the primal
value min_k R_k of those shares exactly; it takes the dual weights w of the K rate rows
(projected on the simplex) and computes g(w). By weak duality primal <= V <= g(w); the two
are independent computations and must agree to ``CERTIFY_TOL`` (else ``RuntimeError``).
The value returned is the primal one (achieved by the returned shares).

**Any scale.** HiGHS's tolerances are absolute and it drops matrix entries below 1e-9, so
far nodes (rates of 1e-10 bps/Hz and less) need care; every step below is relative to
B = min_k B_k, B_k = R_k with every free slot given to node k (V <= B <= K V):

- B = 0: some node can never be served, V = 0 (certified by w on that node, g(w) = 0).
- B < ``SCALE_BELOW``: the LP is solved on the rates divided by the power of two that brings
  B into [1/2, 1) (an exact scaling), and certified in those units: the tolerance is
  ``CERTIFY_TOL`` x max(scale, value) (scale 1 above ``SCALE_BELOW``: the rates as given).
- A node with B < ``FREE_RATIO`` x B_k is served outside the LP: the same share of every free
  slot, just enough for R_k >= B >= V (at most ``FREE_RATIO`` of the slot; the LP shares the
  rest), which costs the others at most a fraction ``FREE_RATIO`` per such node.
- A node left with less than ``SMALL_SHARE`` of the free time, whose LP shares are at the
  level of the solver's tolerances, is topped up to the smallest R_k of the other nodes
  (its shares scaled, the slots' columns scaled back to sum <= 1) when that raises the value.

**Continuation.** ``maxmin_schedule(rates, fixed)`` keeps the shares ``fixed`` (K, n0) of the
first n0 slots (already served) and chooses the rest: the same LP with the fixed slots' rates
P_k = (1/N) sum_{n < n0} alpha_k[n] r_k[n] on the right-hand side, certified by
g(w) = sum_k w_k P_k + (1/N) sum_{n >= n0} max_k w_k r_k[n] (``dual_value(rates, w, fixed)``).
The imitation expert labels shares with it (``agents.expert.hindsight_shares``).

For K = 1 nothing is solved: the shares are all ones. scipy (for HiGHS) is imported only by
:func:`maxmin_schedule` for K > 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ios_uav_env.model.lp import solve_lp

#: Largest |primal - dual| a certified score may have, in units of max(scale, value) (bps/Hz;
#: scale: 1, or the power of two of a rate matrix scaled below ``SCALE_BELOW``).
CERTIFY_TOL = 1e-9
#: Below this bound B (bps/Hz) the LP is solved on the rates scaled by a power of two.
SCALE_BELOW = 2.0**-16
#: A node whose bound B_k is above B / ``FREE_RATIO`` is served outside the LP.
FREE_RATIO = 1e-12
#: A node with less than this fraction of the free time has its LP shares topped up.
SMALL_SHARE = 1e-6
#: Column sums of given shares may exceed 1 by this much (rounding).
SHARE_TOL = 1e-9


@dataclass(frozen=True)
class Schedule:
    """The best TDMA schedule of a rate matrix, with its duality certificate."""

    shares: np.ndarray  # (K, N) alpha_k[n], >= 0, column sums <= 1
    weights: np.ndarray  # (K,) dual weights w on the simplex
    value: float  # min_k R_k of ``shares`` (the primal value; bps/Hz)
    dual_value: float  # g(weights) >= V >= value
    node_rates: np.ndarray  # (K,) R_k of ``shares``

    @property
    def gap(self) -> float:
        """dual_value - value (>= 0 up to rounding)."""
        return self.dual_value - self.value


def dual_value(rates: np.ndarray, weights: np.ndarray, fixed: np.ndarray | None = None) -> float:
    """g(w) = (1/N) sum_n max_k w_k r_k[n] for a (K, N) rate matrix: >= V for every w in the
    simplex (weak duality; see the module docstring). ``weights`` must be >= 0 and sum to 1.
    With ``fixed`` shares (K, n0) of the first n0 slots those slots add (1/N) sum_k w_k alpha_k[n]
    r_k[n] instead of the max: the bound of :func:`maxmin_schedule` with ``fixed``."""
    r = np.asarray(rates, dtype=float)
    w = np.asarray(weights, dtype=float)
    if r.ndim != 2 or w.shape != (r.shape[0],):
        raise ValueError(f"weights must have shape (K,) = ({r.shape[0]},), got {w.shape}")
    if not (np.all(np.isfinite(w)) and np.all(w >= 0) and abs(w.sum() - 1.0) <= 1e-12):
        raise ValueError(f"weights must be >= 0 and sum to 1 (the simplex), got {w!r}")
    a = _check_fixed(r, fixed)
    n0 = a.shape[1]
    past = np.sum(w[:, None] * a * r[:, :n0])
    return float((past + np.sum(np.max(w[:, None] * r[:, n0:], axis=0))) / r.shape[1])


def _check_fixed(r: np.ndarray, fixed: np.ndarray | None) -> np.ndarray:
    """``fixed`` shares as a (K, n0) array, n0 < N (``ValueError`` naming what is wrong)."""
    if fixed is None:
        return np.zeros((r.shape[0], 0))
    a = np.asarray(fixed, dtype=float)
    if a.ndim != 2 or a.shape[0] != r.shape[0] or a.shape[1] >= r.shape[1]:
        raise ValueError(
            f"fixed must be the shares (K, n0) of the first n0 < N slots (K = {r.shape[0]}, "
            f"N = {r.shape[1]}), got shape {a.shape}"
        )
    if not (np.all(np.isfinite(a)) and np.all(a >= 0) and np.all(a.sum(axis=0) <= 1.0 + SHARE_TOL)):
        raise ValueError("fixed shares must be finite, >= 0, with column sums <= 1")
    return a


def check_rates(rates: np.ndarray) -> np.ndarray:
    """``rates`` as a float (K, N) array, K, N >= 1, finite and >= 0 (``ValueError`` otherwise)."""
    r = np.asarray(rates, dtype=float)
    if r.ndim != 2 or r.shape[0] < 1 or r.shape[1] < 1:
        raise ValueError(f"rates must be a (K, N) array with K, N >= 1, got shape {r.shape}")
    if not (np.all(np.isfinite(r)) and np.all(r >= 0)):
        raise ValueError("rates must be finite and >= 0")
    return r


def maxmin_schedule(rates: np.ndarray, fixed: np.ndarray | None = None) -> Schedule:
    """The best schedule (P) of a (K, N) rate matrix, certified by its dual (D).

    With ``fixed`` (K, n0) the first n0 slots keep those shares (already served) and only the
    later ones are chosen: the best continuation, max min_k R_k over the whole horizon, with
    the bound :func:`dual_value` (``fixed``) as its certificate; ``shares`` holds both parts.

    Raises ``RuntimeError`` when the LP fails or its primal and dual values differ by more
    than ``CERTIFY_TOL`` (times max(scale, value): the module docstring, "Any scale").
    """
    r = check_rates(rates)
    a = _check_fixed(r, fixed)
    k_nodes, n = r.shape
    n0 = a.shape[1]
    if k_nodes == 1:
        shares = np.ones_like(r)
        shares[:, :n0] = a
        value = float(np.mean(shares[0] * r[0]))
        return Schedule(shares, np.ones(1), value, value, np.array([value]))
    from scipy.sparse import csc_array

    free, m = r[:, n0:], n - n0
    past = np.sum(a * r[:, :n0], axis=1) / n  # (K,) served in the fixed slots
    later = np.sum(free, axis=1) / n  # (K,) R_k - past_k with every free slot given to node k
    reach = past + later  # (K,) B_k >= R_k of any schedule
    low = int(np.argmin(reach))
    bound = float(reach[low])  # B: V <= B <= K V
    if bound == 0.0:  # node `low` can never be served: V = 0, and g(e_low) = B = 0
        shares = np.concatenate([a, np.full((k_nodes, m), 1.0 / k_nodes)], axis=1)
        w = np.zeros(k_nodes)
        w[low] = 1.0
        per_node = np.mean(shares * r, axis=1)
        return Schedule(shares, w, float(per_node.min()), dual_value(r, w, fixed), per_node)
    # nodes served outside the LP: theta_k of every free slot gives R_k >= B
    cheap = bound < FREE_RATIO * reach
    theta = np.zeros(k_nodes)
    need = cheap & (past < bound)
    theta[need] = (bound - past[need]) / later[need]
    cap = 1.0 - float(theta.sum())  # what the LP may share of each free slot
    lp = np.flatnonzero(~cheap)
    k_lp = lp.size
    scale = 2.0 ** math.frexp(bound)[1] if bound < SCALE_BELOW else 1.0  # exact: a power of two

    # variables: alpha of the LP's nodes in the free slots (k-major, k_lp * m) then t / scale;
    # minimise -t / scale
    # rows: the k_lp rate rows, then the m slot rows; built column by column (CSC, as HiGHS
    # takes it): column (k, j) holds -r_k[j] / (n scale) in row k and 1 in slot row j, then t's
    # column holds 1 in every rate row
    n_lp = k_lp * m
    scaled = (free[lp] / scale).ravel() / n
    col_rows = np.stack([np.repeat(np.arange(k_lp), m), k_lp + np.tile(np.arange(m), k_lp)], axis=1)
    col_vals = np.stack([-scaled, np.ones(n_lp)], axis=1)
    keep = col_vals.ravel() != 0.0  # as a sparse constructor drops them
    per_col = np.concatenate([keep.reshape(n_lp, 2).sum(axis=1), [k_lp]])
    a_ub = csc_array(
        (
            np.concatenate([col_vals.ravel()[keep], np.ones(k_lp)]),
            np.concatenate([col_rows.ravel()[keep], np.arange(k_lp)]),
            np.concatenate([[0], np.cumsum(per_col)]),
        ),
        shape=(k_lp + m, n_lp + 1),
    )
    b_ub = np.concatenate([past[lp] / scale, np.full(m, cap)])
    c = np.zeros(n_lp + 1)
    c[-1] = -1.0
    res = solve_lp(c, a_ub, b_ub, np.append(np.ones(n_lp), np.inf), dual_simplex=True, feasibility_tol=1e-10)
    if not res.optimal:
        raise RuntimeError(f"max-min schedule LP failed: {res.message}")
    chosen = np.clip(res.x[:-1].reshape(k_lp, m), 0.0, 1.0)
    shares = np.zeros((k_nodes, n))
    shares[:, :n0] = a
    shares[lp, n0:] = chosen / np.maximum(chosen.sum(axis=0) / cap, 1.0)
    shares[cheap, n0:] = theta[cheap, None]
    per_node = np.mean(shares * r, axis=1)
    shares, per_node = _top_up(shares, per_node, r, n0, past, later)
    value = float(per_node.min())
    w = np.zeros(k_nodes)
    w[lp] = np.maximum(-res.ub_duals[:k_lp], 0.0)
    if not w.sum() > 0:
        raise RuntimeError(f"max-min schedule LP returned no dual weights ({res.ub_duals[:k_lp]})")
    w /= w.sum()
    dual = dual_value(r, w, fixed)
    if abs(dual - value) > CERTIFY_TOL * max(scale, abs(value)):
        raise RuntimeError(
            f"max-min schedule not certified: primal {value!r} vs dual {dual!r} (gap {dual - value:.3g})"
        )
    return Schedule(shares, w, value, dual, per_node)


def _top_up(
    shares: np.ndarray, per_node: np.ndarray, r: np.ndarray, n0: int, past: np.ndarray, later: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The shares (and R_k) with every node of less than ``SMALL_SHARE`` of the free time raised
    to the smallest R_k of the other nodes (its free shares scaled, or a uniform share if the LP
    gave it none; then each free slot's column scaled back to sum <= 1), if that raises min_k
    R_k; else ``shares`` and ``per_node`` as given."""
    small = shares[:, n0:].mean(axis=1) < SMALL_SHARE
    if small.all() or not small.any():
        return shares, per_node
    target = float(per_node[~small].min())
    short = np.flatnonzero(small & (per_node < target))
    if not short.size:
        return shares, per_node
    out = shares.copy()
    for k in short:
        got = per_node[k] - past[k]
        if got > 0:
            out[k, n0:] = np.minimum(out[k, n0:] * ((target - past[k]) / got), 1.0)
        elif later[k] > 0:
            out[k, n0:] = min((target - past[k]) / later[k], 1.0)
    out[:, n0:] /= np.maximum(out[:, n0:].sum(axis=0), 1.0)
    raised = np.mean(out * r, axis=1)
    return (out, raised) if raised.min() > per_node.min() else (shares, per_node)
