"""The sum-rate AO of one slot written run by run: the reference ``model.miso_runs.sum_rate_runs``
(and ``miso_slot.alternate``, a batch of one) is compared with bit for bit.

Each function is the module docstring's step for one run, on the (K, N_t) channel matrix of the
run's phases: the MMSE receivers and weights, the WMMSE beams (the power multiplier by bisection)
and one closed-form phase sweep, iterated until an iteration gains less than ``tol`` (relative).
The compiled kernels are the model's own (``_wmmse_sweep``, ``_power_multiplier``): the batch is
checked for how it stacks the runs, not for how a kernel computes."""

from __future__ import annotations

import numpy as np

from ios_uav_env.model.miso import SlotChannel, user_rates
from ios_uav_env.model.miso_runs import _power_multiplier, _wmmse_sweep
from ios_uav_env.model.miso_slot import SlotSolution, _cascade


def receivers(
    H: np.ndarray, W: np.ndarray, weights: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """MMSE receivers u_k = h_k w_k / T_k and weights omega_k = 1 / e_k = 1 + SINR_k (times the
    users' ``weights`` alpha_k when given)."""
    r = H @ W
    total = np.sum(np.abs(r) ** 2, axis=1) + 1.0
    signal = np.diag(r)
    omega = 1.0 / (1.0 - np.abs(signal) ** 2 / total)
    return signal / total, omega if weights is None else weights * omega


def wmmse_beams(H: np.ndarray, W: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """One WMMSE beam update (N_t, K) of one run."""
    u, omega = receivers(H, W, weights)
    Q = H.conj().T @ ((omega * np.abs(u) ** 2)[:, None] * H)
    rhs = H.conj().T * (omega * u)[None, :]
    lam, U = np.linalg.eigh(Q)
    Z = U.conj().T @ rhs
    null = lam <= 1e-12 * max(lam.max(), 1e-300)
    Z[null] = 0.0
    lam = np.where(null, 0.0, lam)
    energy = np.sum(np.abs(Z) ** 2, axis=1)
    mu = _power_multiplier(energy, lam, null)
    scale = np.zeros_like(lam)
    live = energy > 0
    scale[live] = 1.0 / (lam[live] + mu)
    out = U @ (scale[:, None] * Z)
    power_out = float(np.sum(np.abs(out) ** 2))
    return out / np.sqrt(power_out) if power_out > 1.0 else out


def sum_rate_run(
    channel: SlotChannel,
    phases: np.ndarray,
    beams: np.ndarray,
    *,
    weights: np.ndarray | None = None,
    max_iter: int = 100,
    tol: float = 1e-7,
    start: str = "given",
) -> SlotSolution:
    """The AO of the (weighted) sum rate from (``phases``, ``beams``), one run."""
    alpha = None if weights is None else np.asarray(weights, dtype=float)

    def value_of(rates: np.ndarray) -> float:
        return float(np.sum(rates)) if alpha is None else float(alpha @ rates)

    psi = np.array(phases, dtype=float)
    H = channel.matrix(psi)
    W = np.array(beams, dtype=complex)
    value = value_of(user_rates(H, W))
    history = [value]
    for _ in range(max_iter):
        W = wmmse_beams(H, W, alpha)
        u, omega = receivers(H, W, alpha)
        cascade = _cascade(channel, W)
        v = _wmmse_sweep(np.exp(-1j * psi), cascade, H @ W, omega.astype(float), u.astype(complex))
        psi = np.mod(-np.angle(v), 2 * np.pi)
        H = channel.matrix(psi)
        new = value_of(user_rates(H, W))
        history.append(new)
        gain, value = new - value, new
        if gain <= tol * max(1.0, abs(value)):
            break
    rates = user_rates(H, W)
    return SlotSolution("sum", value_of(rates), rates, psi, W, start, np.array(history))
