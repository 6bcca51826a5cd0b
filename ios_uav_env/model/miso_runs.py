"""Many sum-rate AO runs of one slot at once: the AO of ``miso_slot``'s module docstring with
``objective="sum"`` (weighted or not) for R starts, as array operations over the runs; a single
run, ``miso_slot.alternate``'s sum rate and :func:`wmmse_beams`, is a batch of one.

A scorer that prices a slot at J weights runs the AO from S starts at each of them, J x S runs on
the same channel (``model.miso_sdma``: J up to 15, S up to 2K), and the per-slot optimum runs it
from every start of ``miso_slot.slot_optimum``. One run is a few dozen numpy calls on K x N_t
matrices per iteration, so a run costs its calls' overhead, not its arithmetic; here each call holds
every run still iterating. The arithmetic is that of the AO written run by run, operation for
operation, on the same matrix layouts (the same BLAS and LAPACK calls per matrix, the same
reductions along a contiguous axis, the same compiled loops), so every run's phases, beams, rates,
value and history equal that run's alone from the same start bit for bit, whatever else the batch
holds (tested against the AO written run by run); a run stops after the iteration it would stop at
alone, and the others go on without it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ios_uav_env.jit import jit
from ios_uav_env.model.miso import SlotChannel, aligned_phases, mrt_beams, zf_beams

__all__ = [
    "Runs", "aligned_starts", "best_weighted_rates", "or_alone", "sum_rate_runs", "weighted_settings",
    "wmmse_beams",
]  # fmt: skip

#: A run's power multiplier that the compiled loop leaves to :func:`_power_multiplier` (more live
#: eigenvalues than numpy sums left to right, :data:`_SHORT_SUM`).
_LEFT = -1.0


@dataclass(frozen=True, eq=False)
class Runs:
    """The ends of R runs (:func:`sum_rate_runs`): ``values`` (R,) the objective, ``rates`` (R, K)
    bps/Hz, ``phases`` (R, M) rad, ``beams`` (R, N_t, K), and each run's ``histories[i]``, its
    objective at the start and after each iteration (``SlotSolution.history``)."""

    values: np.ndarray
    rates: np.ndarray
    phases: np.ndarray
    beams: np.ndarray
    histories: list[np.ndarray]


def sum_rate_runs(
    channel: SlotChannel,
    phases: np.ndarray,
    beams: np.ndarray,
    weights: np.ndarray | None = None,
    *,
    max_iter: int = 100,
    tol: float = 1e-7,
) -> Runs:
    """Run i ends where the same AO run alone ends, bit for bit (module docstring): ``alternate(
    channel, "sum", phases[i], beams[i], weights=None or weights[i], max_iter=max_iter, tol=tol)``.
    ``phases`` (R, M) rad, ``beams`` (R, N_t, K) of total power <= 1, ``weights`` (R, K) finite and
    >= 0, or None: the sum rate."""
    k_n, n_t, m_n = channel.K, channel.n_t, channel.M
    psi = np.array(phases, dtype=float)
    W = np.array(beams, dtype=complex)
    r_n = len(psi)
    if psi.shape != (r_n, m_n) or not np.all(np.isfinite(psi)):
        raise ValueError(f"phases must be a finite (R, M = {m_n}) array of rad, got shape {psi.shape}")
    if W.shape != (r_n, n_t, k_n) or not np.all(np.isfinite(W)):
        raise ValueError(f"beams must be a finite complex (R, N_t = {n_t}, K = {k_n}) array, got {W.shape}")
    if np.any(np.sum(np.abs(W.reshape(r_n, -1)) ** 2, axis=1) > 1.0 + 1e-9):
        raise ValueError("beams must have total power sum_k ||w_k||^2 in [0, 1] (units of P) in every run")
    alpha = None if weights is None else np.array(weights, dtype=float)
    if alpha is not None and (
        alpha.shape != (r_n, k_n) or not np.all(np.isfinite(alpha)) or np.any(alpha < 0)
    ):
        raise ValueError(f"weights must be a finite (R, K = {k_n}) array of numbers >= 0, got {alpha.shape}")
    if not (isinstance(max_iter, (int, np.integer)) and max_iter >= 0):
        raise ValueError(f"max_iter must be an integer >= 0, got {max_iter!r}")
    if not (tol >= 0):
        raise ValueError(f"tol must be a number >= 0, got {tol!r}")
    H = _matrices(channel, psi)
    value = _values(alpha, _rates(H, W))
    histories = [[v] for v in value.tolist()]
    live = np.arange(r_n)
    for _ in range(max_iter):
        if not live.size:
            break
        h, a = H[live], None if alpha is None else alpha[live]
        w = _wmmse_beams(h, W[live], a)
        v = _wmmse_sweeps(np.exp(-1j * psi[live]), *_sweep_terms(channel, h, w, a))
        p = np.mod(-np.angle(v), 2 * np.pi)
        h = _matrices(channel, p)
        new = _values(a, _rates(h, w))
        gain = new - value[live]
        psi[live], W[live], H[live], value[live] = p, w, h, new
        for i, run_value in zip(live.tolist(), new.tolist(), strict=True):
            histories[i].append(run_value)
        live = live[gain > tol * np.maximum(1.0, np.abs(new))]  # alternate's stopping rule, per run
    rates = _rates(H, W)
    return Runs(_values(alpha, rates), rates, psi, W, [np.array(h) for h in histories])


def wmmse_beams(H: np.ndarray, W: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """One WMMSE beam update at the receivers and weights of (``H`` (K, N_t), ``W`` (N_t, K)): the
    exact minimiser of the weighted MSE over sum_k ||w_k||^2 <= 1 (shape (N_t, K)); ``weights``
    alpha_k (default 1) weigh the users' rates (the weighted sum rate). A batch of one run."""
    alpha = None if weights is None else np.asarray(weights, dtype=float)[None]
    return _wmmse_beams(np.asarray(H, dtype=complex)[None], np.asarray(W, dtype=complex)[None], alpha)[0]


def best_weighted_rates(channel: SlotChannel, weights: np.ndarray, *, max_iter: int = 100) -> np.ndarray:
    """(J, K): row j the rates of ``optimise_slot(channel, "sum", random_starts=0, max_iter=max_iter,
    weights=weights[j])``, the best run (the first of equal values) from ``miso_slot.aligned_starts``,
    computed as the J x S runs of :func:`sum_rate_runs`."""
    w = np.asarray(weights, dtype=float)
    starts = aligned_starts(channel)
    j_n, s_n = len(w), len(starts)
    phases = np.array([psi for _, psi, _ in starts])
    beams = np.array([b for _, _, b in starts], dtype=complex)
    runs = sum_rate_runs(
        channel, np.tile(phases, (j_n, 1)), np.tile(beams, (j_n, 1, 1)), np.repeat(w, s_n, axis=0),
        max_iter=max_iter,
    )  # fmt: skip
    best = np.argmax(runs.values.reshape(j_n, s_n), axis=1)  # the first largest, as max() over the runs
    return runs.rates.reshape(j_n, s_n, -1)[np.arange(j_n), best]


def or_alone(w: np.ndarray, rates: np.ndarray, solo: np.ndarray) -> np.ndarray:
    """The better setting at weights ``w`` of the AO's ``rates`` (K,) and each user served alone
    (``solo``, ``miso.tdma_rates``): ``rates``, or the first user alone whose w_k R_k is larger
    than w . ``rates`` (its rate for it, 0 for the others)."""
    k = int(np.argmax(w * solo))
    if w[k] * solo[k] > float(w @ rates):
        rates = np.where(np.arange(len(solo)) == k, solo, 0.0)
    return rates


def weighted_settings(
    channel: SlotChannel, weights: np.ndarray, solo: np.ndarray, *, max_iter: int = 100
) -> np.ndarray:
    """(J, K): the slot's setting at each of ``weights`` (J, K), the better of the AO's
    (:func:`best_weighted_rates`) and a user alone (``solo``, ``miso.tdma_rates``; :func:`or_alone`)."""
    w = np.asarray(weights, dtype=float)
    rates = best_weighted_rates(channel, w, max_iter=max_iter)
    return np.array([or_alone(wj, rj, solo) for wj, rj in zip(w, rates, strict=True)])


def aligned_starts(channel: SlotChannel) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """The deterministic starts of ``miso_slot.optimise_slot``, as (name, phases, beams): each user's
    aligned phases with MRT and, when N_t >= K and the channels are independent, ZF beams."""
    starts = []
    for k in range(channel.K):
        psi = aligned_phases(channel, k)
        H = channel.matrix(psi)
        starts.append((f"aligned {k} MRT", psi, mrt_beams(H)))
        if channel.n_t >= channel.K:
            try:
                starts.append((f"aligned {k} ZF", psi, zf_beams(H)))
            except ValueError:  # dependent channels: no ZF start
                pass
    return starts


def _power_multiplier(energy: np.ndarray, lam: np.ndarray, null: np.ndarray) -> float:
    """The power constraint's multiplier mu >= 0 of :func:`wmmse_beams` for the energies |Z_i|^2 of
    the right-hand side along Q's eigenvectors and Q's eigenvalues ``lam`` (zero where ``null``):
    0 when the unconstrained beams fit, else the root of sum_i energy_i / (lam_i + mu)^2 = 1 by
    bisection."""
    live_energy, live_lam = energy[energy > 0], lam[energy > 0]

    def power(mu: float) -> float:
        return float((live_energy / (live_lam + mu) ** 2).sum())

    if not (np.any((energy > 0) & null) or power(0.0) > 1.0):
        return 0.0
    hi = float(np.sqrt(energy.sum()))  # power(hi) <= 1
    if live_energy.size <= _SHORT_SUM:  # the compiled bisection, numpy's sums bit for bit
        return _power_level(live_energy, live_lam, hi)
    lo = 0.0
    for _ in range(200):
        mu = 0.5 * (lo + hi)
        lo, hi = (mu, hi) if power(mu) > 1.0 else (lo, mu)
        if hi - lo <= 1e-15 * hi:
            break
    return hi


#: Arrays up to this length are summed by numpy's reduction left to right (its pairwise sum adds
#: blocks under 8 in one loop; tested): :func:`_power_level` reproduces it.
_SHORT_SUM = 7


@jit(fastmath=False)
def _power_level(energy: np.ndarray, lam: np.ndarray, hi: float) -> float:
    """:func:`wmmse_beams`' bisection on the power multiplier mu: the least hi found with
    sum_i energy_i / (lam_i + mu)^2 <= 1, each sum added in numpy's order (:data:`_SHORT_SUM`)."""
    lo = 0.0
    for _ in range(200):
        mu = 0.5 * (lo + hi)
        total = 0.0
        for i in range(energy.size):
            total += energy[i] / (lam[i] + mu) ** 2
        if total > 1.0:
            lo = mu
        else:
            hi = mu
        if hi - lo <= 1e-15 * hi:
            break
    return hi


@jit(fastmath=False)
def _wmmse_sweep(v: np.ndarray, B: np.ndarray, r: np.ndarray, omega: np.ndarray, u: np.ndarray) -> np.ndarray:
    """One pass of the closed-form element updates of the weighted MSE (``miso_slot``'s module docstring);
    ``r`` (K, K) = H W is kept current in place."""
    M, K = B.shape[0], B.shape[1]
    for m in range(M):
        z = 0j
        for k in range(K):
            acc = 0j
            for j in range(K):
                rho = r[k, j] - v[m] * B[m, k, j]
                acc += np.conj(rho) * B[m, k, j]
            z += omega[k] * (2.0 * abs(u[k]) ** 2 * acc - 2.0 * np.conj(u[k]) * B[m, k, k])
        size = abs(z)
        if size > 0.0:
            new = -np.conj(z) / size
            step = new - v[m]
            for k in range(K):
                for j in range(K):
                    r[k, j] += step * B[m, k, j]
            v[m] = new
    return v


def _matrices(channel: SlotChannel, psi: np.ndarray) -> np.ndarray:
    """H (R, K, N_t) of each run's phases (R, M): ``SlotChannel.matrix`` row by row."""
    return (channel.coef * np.exp(-1j * psi)[:, None, :]) @ channel.to_elements + channel.direct


def _rates(H: np.ndarray, W: np.ndarray) -> np.ndarray:
    """(R, K): ``miso.user_rates`` of each run."""
    gains = np.abs(H @ W) ** 2
    signal = np.diagonal(gains, axis1=1, axis2=2).copy()
    return np.log2(1.0 + signal / (gains.sum(axis=2) - signal + 1.0))


def _values(alpha: np.ndarray | None, rates: np.ndarray) -> np.ndarray:
    """(R,): each run's objective as ``alternate`` takes it: the sum of its rates, or its weighted
    sum alpha . R (numpy's dot of two rows)."""
    if alpha is None:
        return rates.sum(axis=1)
    return np.array([float(a @ r) for a, r in zip(alpha, rates, strict=True)])


def _receivers(H: np.ndarray, W: np.ndarray, alpha: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """(u, omega or alpha omega), each (R, K): each run's MMSE receivers u_k = h_k w_k / T_k and
    weights omega_k = 1 / e_k = 1 + SINR_k (times alpha_k when given)."""
    r = H @ W
    total = np.sum(np.abs(r) ** 2, axis=2) + 1.0
    signal = np.diagonal(r, axis1=1, axis2=2)
    omega = 1.0 / (1.0 - np.abs(signal) ** 2 / total)
    return signal / total, omega if alpha is None else alpha * omega


def _wmmse_beams(H: np.ndarray, W: np.ndarray, alpha: np.ndarray | None) -> np.ndarray:
    """(R, N_t, K): :func:`wmmse_beams` of each run."""
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
    """``mu`` (R,): each run's power multiplier as ``_power_multiplier`` finds it, where at
    most :data:`_SHORT_SUM` eigenvalues are live (numpy's sums are then left to right);
    :data:`_LEFT` where more are."""
    live_energy, live_lam = np.empty(energy.shape[1]), np.empty(energy.shape[1])
    for r in range(energy.shape[0]):
        n_live, dead_live, total = 0, False, 0.0
        for i in range(energy.shape[1]):
            if energy[r, i] > 0:
                live_energy[n_live], live_lam[n_live] = energy[r, i], lam[r, i]
                n_live += 1
                dead_live = dead_live or null[r, i]
        if n_live > _SHORT_SUM:
            mu[r] = _LEFT
            continue
        if not dead_live:
            for i in range(n_live):
                total += live_energy[i] / live_lam[i] ** 2
        if dead_live or total > 1.0:
            mu[r] = _power_level(live_energy[:n_live], live_lam[:n_live], hi[r])
        else:
            mu[r] = 0.0


def _sweep_terms(
    channel: SlotChannel, H: np.ndarray, W: np.ndarray, alpha: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(B (R, M, K, K), H W (R, K, K), omega (R, K), u (R, K)): the arguments of
    ``_wmmse_sweep`` for each run (the phases' update of the weighted MSE)."""
    u, omega = _receivers(H, W, alpha)
    cascade = np.ascontiguousarray(
        channel.coef.T[None, :, :, None] * (channel.to_elements @ W)[:, :, None, :]
    )
    return cascade, H @ W, omega.astype(float), u.astype(complex)


@jit(fastmath=False)
def _wmmse_sweeps(
    v: np.ndarray, B: np.ndarray, r: np.ndarray, omega: np.ndarray, u: np.ndarray
) -> np.ndarray:
    """``_wmmse_sweep`` of each run, ``v`` (R, M) updated in place and returned."""
    for i in range(v.shape[0]):
        _wmmse_sweep(v[i], B[i], r[i], omega[i], u[i])
    return v
