r"""Several ground nodes: TDMA shares and the max-min average rate (the scorer for K >= 1).

Contract (model.md, "Several ground nodes"): node k's rate in slot n is the single-node
expected-gain rate r_k(q[n]) with G = w_k (``config.node_config(k)``: phases (13) and the
reflect/transmit side for node k); slot n is shared by TDMA, alpha_k[n] >= 0,
sum_k alpha_k[n] <= 1; node k's average rate is R_k = (1/N) sum_n alpha_k[n] r_k(q[n]) and
the score of a trajectory is its best schedule,

    V(q) = max_alpha min_k R_k                                                        (P)

a linear programme in (alpha, t): max t s.t. (1/N) sum_n alpha_k[n] r_k[n] >= t for all k,
sum_k alpha_k[n] <= 1, alpha >= 0. Its dual is

    V(q) = min_{w in simplex} g(w),   g(w) = (1/N) sum_n max_k w_k r_k[n]             (D)

(weak duality is one line: for feasible alpha, min_k R_k <= sum_k w_k R_k
= (1/N) sum_n sum_k alpha_k[n] w_k r_k[n] <= g(w)).

**Certified value.** :func:`maxmin_schedule` solves (P) with HiGHS, cleans the shares
(clipped to [0, 1], each slot's column scaled down to sum <= 1) and computes the primal
value min_k R_k of those shares exactly; it takes the dual weights w of the K rate rows
(projected on the simplex) and computes g(w). By weak duality primal <= V <= g(w); the two
are independent computations and must agree to ``CERTIFY_TOL`` (else ``RuntimeError``).
The value returned is the primal one (achieved by the returned shares).

**Continuation.** ``maxmin_schedule(rates, fixed)`` keeps the shares ``fixed`` (K, n0) of the
first n0 slots (already served) and chooses the rest: the same LP with the fixed slots' rates
P_k = (1/N) sum_{n < n0} alpha_k[n] r_k[n] on the right-hand side, certified by
g(w) = sum_k w_k P_k + (1/N) sum_{n >= n0} max_k w_k r_k[n] (``dual_value(rates, w, fixed)``).
The imitation expert labels shares with it (``agents.expert.hindsight_shares``).

For K = 1 nothing is solved: the shares are all ones and the score is
:func:`ios_uav_env.average_rate` (no scipy needed). scipy (``linprog``) is imported only
for K > 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ios_uav_env.model.channel import as_positions, slot_rates
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.trajectory import as_trajectory, average_rate

#: Largest |primal - dual| (absolute, bps/Hz, scaled by max(1, value)) a certified score may have.
CERTIFY_TOL = 1e-9
#: Column sums of given shares may exceed 1 by this much (rounding).
SHARE_TOL = 1e-9

__all__ = [
    "CERTIFY_TOL",
    "Schedule",
    "best_schedule",
    "dual_value",
    "maxmin_rate",
    "maxmin_schedule",
    "node_rates",
    "schedule",
    "scheduled_rates",
]


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


def node_rates(config: ScenarioConfig, positions: np.ndarray) -> np.ndarray:
    """r_k(q) (bps/Hz) of every node k at every position, shape (K, n) (``slot_rates`` per node)."""
    q = as_positions(positions)
    return np.stack([slot_rates(config.node_config(k), q) for k in range(config.K)])


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


def _check_rates(rates: np.ndarray) -> np.ndarray:
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
    than ``CERTIFY_TOL`` (times max(1, value)).
    """
    r = _check_rates(rates)
    a = _check_fixed(r, fixed)
    k_nodes, n = r.shape
    n0 = a.shape[1]
    if k_nodes == 1:
        shares = np.ones_like(r)
        shares[:, :n0] = a
        value = float(np.mean(shares[0] * r[0]))
        return Schedule(shares, np.ones(1), value, value, np.array([value]))
    from scipy.optimize import linprog
    from scipy.sparse import csr_matrix, hstack, vstack

    # variables: alpha of the free slots (k-major, K * m) then t; minimise -t
    free, m = r[:, n0:], n - n0
    past = np.sum(a * r[:, :n0], axis=1) / n  # (K,) served in the fixed slots
    rows = np.repeat(np.arange(k_nodes), m)
    rate_rows = csr_matrix((-free.ravel() / n, (rows, np.arange(k_nodes * m))), shape=(k_nodes, k_nodes * m))
    slot_rows = csr_matrix((np.ones(k_nodes * m), (np.tile(np.arange(m), k_nodes), np.arange(k_nodes * m))))
    a_ub = vstack(
        [hstack([rate_rows, csr_matrix(np.ones((k_nodes, 1)))]), hstack([slot_rows, csr_matrix((m, 1))])]
    ).tocsr()
    b_ub = np.concatenate([past, np.ones(m)])
    c = np.zeros(k_nodes * m + 1)
    c[-1] = -1.0
    bounds = [(0.0, 1.0)] * (k_nodes * m) + [(0.0, None)]
    tols = {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}
    res = linprog(c, A_ub=a_ub, b_ub=b_ub, bounds=bounds, method="highs-ds", options=tols)
    if res.status != 0 or res.x is None:
        raise RuntimeError(f"max-min schedule LP failed: {res.message}")
    chosen = np.clip(res.x[:-1].reshape(k_nodes, m), 0.0, 1.0)
    shares = np.concatenate([a, chosen / np.maximum(chosen.sum(axis=0), 1.0)], axis=1)
    per_node = np.mean(shares * r, axis=1)
    value = float(per_node.min())
    w = np.maximum(-np.asarray(res.ineqlin.marginals[:k_nodes], dtype=float), 0.0)
    if not w.sum() > 0:
        raise RuntimeError(
            f"max-min schedule LP returned no dual weights ({res.ineqlin.marginals[:k_nodes]})"
        )
    w /= w.sum()
    dual = dual_value(r, w, fixed)
    if abs(dual - value) > CERTIFY_TOL * max(1.0, abs(value)):
        raise RuntimeError(
            f"max-min schedule not certified: primal {value!r} vs dual {dual!r} (gap {dual - value:.3g})"
        )
    return Schedule(shares, w, value, dual, per_node)


def schedule(config: ScenarioConfig, trajectory: np.ndarray) -> Schedule:
    """The certified best schedule of ``trajectory`` (see :func:`maxmin_schedule`)."""
    q = as_trajectory(config, trajectory)
    if config.K == 1:  # the single-node score, exactly: average_rate
        value = average_rate(config, q)
        return Schedule(np.ones((1, len(q))), np.ones(1), value, value, np.array([value]))
    return maxmin_schedule(node_rates(config, q))


def best_schedule(config: ScenarioConfig, trajectory: np.ndarray) -> np.ndarray:
    """The shares alpha (K, N) of the best schedule of ``trajectory`` (all ones for K = 1)."""
    return schedule(config, trajectory).shares


def maxmin_rate(config: ScenarioConfig, trajectory: np.ndarray) -> float:
    """Score V(q) = max_alpha min_k R_k (bps/Hz) of a trajectory with its best schedule.

    For K = 1 this is :func:`ios_uav_env.average_rate` exactly. For K > 1 the value is
    certified by the LP's dual to ``CERTIFY_TOL`` (module docstring).
    """
    return schedule(config, trajectory).value


def scheduled_rates(config: ScenarioConfig, trajectory: np.ndarray, shares: np.ndarray) -> np.ndarray:
    """R_k = (1/N) sum_n alpha_k[n] r_k(q[n]) for given shares, shape (K,); ``min`` of it is
    the score of an agent that schedules itself (never above :func:`maxmin_rate`).

    ``shares`` must be a finite (K, N) array, >= 0, with column sums <= 1 (+ ``SHARE_TOL``).
    """
    q = as_trajectory(config, trajectory)
    a = np.asarray(shares, dtype=float)
    if a.shape != (config.K, config.N):
        raise ValueError(f"shares must have shape (K, N) = ({config.K}, {config.N}), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError("shares must be finite (no NaN or inf)")
    if np.any(a < 0):
        raise ValueError(f"shares must be >= 0, got a minimum of {a.min():.3g}")
    sums = a.sum(axis=0)
    if np.any(sums > 1.0 + SHARE_TOL):
        n = int(np.argmax(sums))
        raise ValueError(
            f"shares' column sums (sum_k alpha_k[n]) must be <= 1, got {sums[n]:.6g} at slot {n}"
        )
    return np.mean(a * node_rates(config, q), axis=1)


_SCIPY: list[bool] = []  # [is scipy importable], found at the first call


def reported_maxmin_rate(config: ScenarioConfig, trajectory: np.ndarray) -> float:
    """:func:`maxmin_rate` for the envs' ``info["best_schedule_rate"]``: NaN, with one warning,
    when scipy (its LP solver) is not installed, so that an env needs only numpy and Gymnasium
    (``pip install scipy``, or the ``planners`` extra, brings the score back)."""
    if not _SCIPY:
        try:
            import scipy.optimize  # noqa: F401

            _SCIPY.append(True)
        except ImportError:
            _SCIPY.append(False)
            import warnings

            warnings.warn(
                "scipy is not installed: info['best_schedule_rate'] is NaN (pip install scipy)", stacklevel=2
            )
    return maxmin_rate(config, trajectory) if _SCIPY[0] else float("nan")
