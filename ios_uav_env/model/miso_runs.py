"""Many weighted-sum AO runs of one slot at once: :func:`ios_uav_env.model.miso_slot.alternate`
with ``objective="sum"`` for R (start, weights) pairs, as array operations over the runs.

A scorer that prices a slot at J weights runs the AO from S starts at each of them, J x S runs on
the same channel (``model.miso_sdma``: J up to 15, S up to 2K). One run is a few dozen numpy calls
on K x N_t matrices per iteration, so a run costs its calls' overhead, not its arithmetic; here
each call holds every run still iterating. The arithmetic is :func:`alternate`'s, operation for
operation, on the same matrix layouts (the same BLAS and LAPACK calls per matrix, the same
reductions along a contiguous axis, the same compiled loops), so every run's phases, beams, rates
and value equal :func:`alternate`'s from the same start bit for bit (tested); a run stops after the
iteration :func:`alternate` stops at, and the others go on without it.
"""

from __future__ import annotations

import numpy as np

from ios_uav_env.jit import jit
from ios_uav_env.model.miso import SlotChannel
from ios_uav_env.model.miso_slot import _SHORT_SUM, _power_multiplier, _wmmse_sweep, aligned_starts

__all__ = ["best_weighted_rates", "weighted_sum_runs"]

#: A run's power multiplier that the compiled loop leaves to :func:`miso_slot._power_multiplier`
#: (more live eigenvalues than numpy sums left to right, :data:`miso_slot._SHORT_SUM`).
_LEFT = -1.0


def weighted_sum_runs(
    channel: SlotChannel,
    phases: np.ndarray,
    beams: np.ndarray,
    weights: np.ndarray,
    *,
    max_iter: int = 100,
    tol: float = 1e-7,
) -> tuple[np.ndarray, np.ndarray]:
    """(values (R,), rates (R, K)): run i is ``alternate(channel, "sum", phases[i], beams[i],
    weights=weights[i], max_iter=max_iter, tol=tol)``'s value and rates, bit for bit (module
    docstring). ``phases`` (R, M) rad, ``beams`` (R, N_t, K) of total power <= 1, ``weights``
    (R, K) finite and >= 0."""
    k_n, n_t, m_n = channel.K, channel.n_t, channel.M
    psi = np.array(phases, dtype=float)
    W = np.array(beams, dtype=complex)
    alpha = np.array(weights, dtype=float)
    r_n = len(psi)
    if psi.shape != (r_n, m_n) or not np.all(np.isfinite(psi)):
        raise ValueError(f"phases must be a finite (R, M = {m_n}) array of rad, got shape {psi.shape}")
    if W.shape != (r_n, n_t, k_n) or not np.all(np.isfinite(W)):
        raise ValueError(f"beams must be a finite complex (R, N_t = {n_t}, K = {k_n}) array, got {W.shape}")
    if np.any(np.sum(np.abs(W.reshape(r_n, -1)) ** 2, axis=1) > 1.0 + 1e-9):
        raise ValueError("beams must have total power sum_k ||w_k||^2 in [0, 1] (units of P) in every run")
    if alpha.shape != (r_n, k_n) or not np.all(np.isfinite(alpha)) or np.any(alpha < 0):
        raise ValueError(f"weights must be a finite (R, K = {k_n}) array of numbers >= 0, got {alpha.shape}")
    if not (isinstance(max_iter, (int, np.integer)) and max_iter >= 0):
        raise ValueError(f"max_iter must be an integer >= 0, got {max_iter!r}")
    if not (tol >= 0):
        raise ValueError(f"tol must be a number >= 0, got {tol!r}")
    H = _matrices(channel, psi)
    value = _values(alpha, _rates(H, W))
    live = np.arange(r_n)
    for _ in range(max_iter):
        if not live.size:
            break
        h, a = H[live], alpha[live]
        w = _wmmse_beams(h, W[live], a)
        v = _wmmse_sweeps(np.exp(-1j * psi[live]), *_sweep_terms(channel, h, w, a))
        p = np.mod(-np.angle(v), 2 * np.pi)
        h = _matrices(channel, p)
        new = _values(a, _rates(h, w))
        gain = new - value[live]
        psi[live], W[live], H[live], value[live] = p, w, h, new
        live = live[gain > tol * np.maximum(1.0, np.abs(new))]  # alternate's stopping rule, per run
    rates = _rates(H, W)
    return _values(alpha, rates), rates


def best_weighted_rates(channel: SlotChannel, weights: np.ndarray, *, max_iter: int = 100) -> np.ndarray:
    """(J, K): row j the rates of ``optimise_slot(channel, "sum", random_starts=0, max_iter=max_iter,
    weights=weights[j])``, the best run (the first of equal values) from ``miso_slot.aligned_starts``,
    computed as the J x S runs of :func:`weighted_sum_runs`."""
    w = np.asarray(weights, dtype=float)
    starts = aligned_starts(channel)
    j_n, s_n = len(w), len(starts)
    phases = np.array([psi for _, psi, _ in starts])
    beams = np.array([b for _, _, b in starts], dtype=complex)
    values, rates = weighted_sum_runs(
        channel, np.tile(phases, (j_n, 1)), np.tile(beams, (j_n, 1, 1)), np.repeat(w, s_n, axis=0),
        max_iter=max_iter,
    )  # fmt: skip
    best = np.argmax(values.reshape(j_n, s_n), axis=1)  # the first largest, as max() over the runs
    return rates.reshape(j_n, s_n, -1)[np.arange(j_n), best]


def _matrices(channel: SlotChannel, psi: np.ndarray) -> np.ndarray:
    """H (R, K, N_t) of each run's phases (R, M): ``SlotChannel.matrix`` row by row."""
    return (channel.coef * np.exp(-1j * psi)[:, None, :]) @ channel.to_elements + channel.direct


def _rates(H: np.ndarray, W: np.ndarray) -> np.ndarray:
    """(R, K): ``miso.user_rates`` of each run."""
    gains = np.abs(H @ W) ** 2
    signal = np.diagonal(gains, axis1=1, axis2=2).copy()
    return np.log2(1.0 + signal / (gains.sum(axis=2) - signal + 1.0))


def _values(alpha: np.ndarray, rates: np.ndarray) -> np.ndarray:
    """(R,): each run's weighted sum alpha . R as ``alternate`` takes it (numpy's dot of two rows)."""
    return np.array([float(a @ r) for a, r in zip(alpha, rates, strict=True)])


def _receivers(H: np.ndarray, W: np.ndarray, alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(u, alpha omega), each (R, K): ``miso_slot._receivers`` of each run."""
    r = H @ W
    total = np.sum(np.abs(r) ** 2, axis=2) + 1.0
    signal = np.diagonal(r, axis1=1, axis2=2)
    omega = 1.0 / (1.0 - np.abs(signal) ** 2 / total)
    return signal / total, alpha * omega


def _wmmse_beams(H: np.ndarray, W: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """(R, N_t, K): ``miso_slot.wmmse_beams`` of each run."""
    u, omega = _receivers(H, W, alpha)
    Hh = H.conj().transpose(0, 2, 1)
    Q = Hh @ ((omega * np.abs(u) ** 2)[:, :, None] * H)
    rhs = Hh * (omega * u)[:, None, :]
    lam, U = np.linalg.eigh(Q)
    Z = U.conj().transpose(0, 2, 1) @ rhs
    null = lam <= 1e-12 * np.maximum(lam.max(axis=1), 1e-300)[:, None]
    Z[null] = 0.0
    lam = np.where(null, 0.0, lam)
    energy = np.sum(np.abs(Z) ** 2, axis=2)
    hi = np.sqrt(energy.sum(axis=1))
    mu = np.empty(len(H))
    _multipliers(energy, lam, null, hi, mu)
    for i in np.flatnonzero(mu == _LEFT):
        mu[i] = _power_multiplier(energy[i], lam[i], null[i])
    live = energy > 0
    scale = np.divide(1.0, lam + mu[:, None], out=np.zeros_like(lam), where=live)
    out = U @ (scale[:, :, None] * Z)
    power = np.sum((np.abs(out) ** 2).reshape(len(out), -1), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where((power > 1.0)[:, None, None], out / np.sqrt(power)[:, None, None], out)


@jit(fastmath=False)
def _multipliers(
    energy: np.ndarray, lam: np.ndarray, null: np.ndarray, hi: np.ndarray, mu: np.ndarray
) -> None:
    """``mu`` (R,): each run's power multiplier as ``miso_slot._power_multiplier`` finds it, where at
    most :data:`miso_slot._SHORT_SUM` eigenvalues are live (numpy's sums are then left to right);
    :data:`_LEFT` where more are."""
    for r in range(energy.shape[0]):
        n_live, dead_live, total = 0, False, 0.0
        for i in range(energy.shape[1]):
            if energy[r, i] > 0:
                n_live += 1
                dead_live = dead_live or null[r, i]
        if n_live > _SHORT_SUM:
            mu[r] = _LEFT
            continue
        if not dead_live:
            for i in range(energy.shape[1]):
                if energy[r, i] > 0:
                    total += energy[r, i] / lam[r, i] ** 2
        if not (dead_live or total > 1.0):
            mu[r] = 0.0
            continue
        lo, top = 0.0, hi[r]
        for _ in range(200):
            mid = 0.5 * (lo + top)
            total = 0.0
            for i in range(energy.shape[1]):
                if energy[r, i] > 0:
                    total += energy[r, i] / (lam[r, i] + mid) ** 2
            if total > 1.0:
                lo = mid
            else:
                top = mid
            if top - lo <= 1e-15 * top:
                break
        mu[r] = top


def _sweep_terms(
    channel: SlotChannel, H: np.ndarray, W: np.ndarray, alpha: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(B (R, M, K, K), H W (R, K, K), omega (R, K), u (R, K)): ``miso_slot._sum_rate_phases``'
    arguments of ``_wmmse_sweep`` for each run."""
    u, omega = _receivers(H, W, alpha)
    cascade = np.ascontiguousarray(
        channel.coef.T[None, :, :, None] * (channel.to_elements @ W)[:, :, None, :]
    )
    return cascade, H @ W, omega.astype(float), u.astype(complex)


@jit(fastmath=False)
def _wmmse_sweeps(
    v: np.ndarray, B: np.ndarray, r: np.ndarray, omega: np.ndarray, u: np.ndarray
) -> np.ndarray:
    """``miso_slot._wmmse_sweep`` of each run, ``v`` (R, M) updated in place and returned."""
    for i in range(v.shape[0]):
        _wmmse_sweep(v[i], B[i], r[i], omega[i], u[i])
    return v
