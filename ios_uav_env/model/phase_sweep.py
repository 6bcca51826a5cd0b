"""The element-wise phase searches of the multi-antenna UAV's per-slot optima.

Both alternating optimisations over a slot's surface phases and beams (the SDMA max-min AO of
``ios_uav_env.model.miso_slot``, the NOMA AO of ``ios_uav_env.model.miso_noma_slot``) improve the
phases one element at a time by the same 1-D search: with r_kj = h_k w_j = rho_kj + v_m B_mkj
(B_mkj = c_km g_m^T w_j, the cascade of element m), element m's factor v_m = e^{j theta} is moved
along a coarse grid of ``n_grid`` phases about its current one, then ``n_halvings`` pairs of
halving steps about the best so far (:func:`sweep_angle`); each candidate changes r by the
rank-one term (theta's factor - v_m) B_m, and the state moves only to a strictly better value, so a
pass never lowers its objective. What the sweeps score differs:

- :func:`maxmin_sweep` (SDMA): the min SINR at the beams' directions, the K powers rebalanced for
  each candidate (:func:`balanced`, normalised Jacobi rounds of the SINR-equalising fixed point;
  with the powers fixed the balanced optimum is a corner and a plain min-SINR search stalls);
- :func:`sic_sweep` (NOMA): the exact SIC objective (``miso_noma``'s sum or min rate in the
  decoding order).

All are compiled in IEEE arithmetic (``fastmath=False``) and run the same in plain Python.
"""

from __future__ import annotations

import numpy as np

from ios_uav_env.jit import copy_into, jit
from ios_uav_env.model.miso_noma import _value

__all__ = ["add_rank_one", "balanced", "maxmin_sweep", "sic_sweep", "sweep_angle"]


@jit(inline=True, fastmath=False)
def sweep_angle(c: int, n_grid: int, base: float, best_angle: float) -> float:
    """The c-th candidate phase of a search: base + 2 pi c / n_grid on the coarse grid (c < n_grid),
    then alternately -h and +h about the best so far, h = (2 pi / n_grid) 2^-(1 + (c - n_grid) // 2)."""
    if c < n_grid:
        return base + 2.0 * np.pi * c / n_grid
    h = 2.0 * np.pi / n_grid * 0.5 ** ((c - n_grid) // 2 + 1)
    return best_angle + (2 * (c % 2) - 1) * h


@jit(inline=True, fastmath=False)
def add_rank_one(out: np.ndarray, r: np.ndarray, step: complex, B: np.ndarray, m: int) -> None:
    """out[k, j] = r[k, j] + step B[m, k, j] for the K x K products (``out`` may be ``r``)."""
    K = r.shape[0]
    for k in range(K):
        for j in range(K):
            out[k, j] = r[k, j] + step * B[m, k, j]


@jit(fastmath=False)
def balanced(
    r: np.ndarray,
    B: np.ndarray,
    m: int,
    step: complex,
    p: np.ndarray,
    rounds: int,
    g: np.ndarray,
    q: np.ndarray,
) -> float:
    """Element m's factor moved by ``step`` (``r`` = H D unchanged, D the unit directions): writes
    into ``q`` the powers after ``rounds`` normalised balancing rounds from ``p`` (sum 1),
    q_k proportional to (sum_{j != k} g_kj q_j + 1) / g_kk, and returns their exact min SINR
    (``g`` (K, K + 1) is work space: the gains |h_k d_j|^2 and a column)."""
    K = r.shape[0]
    for k in range(K):
        q[k] = p[k]
        for j in range(K):
            g[k, j] = abs(r[k, j] + step * B[m, k, j]) ** 2
    for _ in range(rounds):
        size = 0.0
        for k in range(K):  # a Jacobi round: the new values in g's last column first
            total = 1.0
            for j in range(K):
                if j != k:
                    total += g[k, j] * q[j]
            g[k, K] = total / g[k, k] if g[k, k] > 0.0 else 0.0
            size += g[k, K]
        if not size > 0.0:
            break
        for k in range(K):
            q[k] = g[k, K] / size
    worst = np.inf
    for k in range(K):
        total = 1.0
        for j in range(K):
            if j != k:
                total += g[k, j] * q[j]
        worst = min(worst, g[k, k] * q[k] / total)
    return worst


@jit(fastmath=False)
def maxmin_sweep(
    v: np.ndarray, B: np.ndarray, r: np.ndarray, p: np.ndarray, n_grid: int, n_halvings: int, rounds: int
) -> tuple[np.ndarray, np.ndarray]:
    """One pass of 1-D searches over each element's phase (a coarse grid, then halving steps about
    the best) of the min SINR at the beams' directions, the powers ``p`` rebalanced for each
    candidate; the state moves only to a strictly better one. ``r`` = H D is kept current."""
    M, K = B.shape[0], B.shape[1]
    g, q, best_p = np.empty((K, K + 1)), np.empty(K), p.copy()
    current = balanced(r, B, 0, 0j, p, 0, g, q)
    for m in range(M):
        now = v[m]
        base = np.angle(now)
        best, best_angle = current, base
        copy_into(best_p, p)
        for c in range(n_grid + 2 * n_halvings):
            angle = sweep_angle(c, n_grid, base, best_angle)  # c = 0: the current phase, rebalanced
            step = 0j if c == 0 else np.exp(1j * angle) - now
            value = balanced(r, B, m, step, p, rounds, g, q)
            if value > best:
                best, best_angle = value, angle
                copy_into(best_p, q)
        if best > current:
            current = best
            copy_into(p, best_p)
            if best_angle != base:
                new = np.exp(1j * best_angle)
                step = new - now
                add_rank_one(r, r, step, B, m)
                v[m] = new
    return v, p


@jit(fastmath=False)
def sic_sweep(
    v: np.ndarray, B: np.ndarray, X: np.ndarray, order: np.ndarray, total: bool, n_grid: int, n_halvings: int
) -> np.ndarray:
    """One pass of 1-D searches over each element's phase of the exact SIC objective (the module
    docstring); ``X`` = H W is kept current in place."""
    M, K = B.shape[0], B.shape[1]
    Y, out = np.empty_like(X), np.empty(K)
    current = _value(X, order, total, out)
    for m in range(M):
        now = v[m]
        base = np.angle(now)
        best, best_angle = current, base
        for c in range(1, n_grid + 2 * n_halvings):
            angle = sweep_angle(c, n_grid, base, best_angle)
            step = np.exp(1j * angle) - now
            add_rank_one(Y, X, step, B, m)
            value = _value(Y, order, total, out)
            if value > best:
                best, best_angle = value, angle
        if best > current:
            current = best
            new = np.exp(1j * best_angle)
            step = new - now
            add_rank_one(X, X, step, B, m)
            v[m] = new
    return v
