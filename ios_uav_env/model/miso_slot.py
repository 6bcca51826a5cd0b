"""The per-slot optimum of the multi-antenna UAV: the surface's phases and the K beams, jointly.

For a :class:`~ios_uav_env.model.miso.SlotChannel` (K users, N_t antennas, M elements; powers in
units of P, noise 1) this maximises the sum rate or the max-min rate over the shared phase shifts
psi (M,) and the beams W (N_t, K), sum_k ||w_k||^2 <= 1, by alternating optimisation (AO) from
several starts. Each block update never lowers the objective, so every start ends at least where it
began; the starts include MRT and ZF with each user's aligned phases, so the result is never below
those baselines, and :func:`~ios_uav_env.model.miso.slot_bounds` bounds it from above.

**Sum rate: WMMSE** (Shi, Razaviyayn, Luo & He, IEEE TSP 2011). With MMSE receivers
u_k = h_k w_k / T_k, T_k = sum_j |h_k w_j|^2 + 1, the MSE e_k = 1 / (1 + SINR_k) and weights
omega_k = 1 / e_k, the augmented objective f = sum_k (omega_k e_k - ln omega_k) satisfies
min_{u, omega} f = K - sum_k ln(1 + SINR_k). The beams' update is
its exact minimiser under the power constraint, w_j = omega_j u_j (Q + mu I)^-1 h_j^H with
Q = sum_k omega_k |u_k|^2 h_k^H h_k and mu >= 0 the power's multiplier (bisection); the phases' update
minimises f one element at a time in closed form: with r_kj = h_k w_j = rho_kj + v_m B_mkj
(B_mkj = c_km g_m^T w_j, rho without element m), f = Re{v_m z} + const with
z = sum_k omega_k (2 |u_k|^2 sum_j conj(rho_kj) B_mkj - 2 conj(u_k) B_mkk), least at v_m = -conj(z)/|z|
(psi_m = -arg v_m). u and omega are refreshed before each block, so the sum rate never decreases.

**Max-min rate.** Given the phases, the max-min SINR under a sum-power constraint is solved
exactly through uplink-downlink duality (Schubert & Boche, IEEE TVT 2004; Wiesel, Eldar & Shamai,
IEEE TSP 2006): the dual uplink powers lambda (sum lambda = 1) are the fixed point of
lambda = f(lambda) / sum f(lambda), f_k = 1 / (h_k (I + sum_{j != k} lambda_j h_j^H h_j)^-1 h_k^H), the
balanced SINR is 1 / sum_k f_k, the beams point along the MMSE filters (I + sum_j lambda_j h_j^H
h_j)^-1 h_k^H and their downlink powers solve the K x K linear system that equalises the SINRs
(:func:`maxmin_beams`); a new beam set is kept only if it raises the minimum. The phases are then
improved one element at a time by a 1-D search over the element's phase (a coarse grid of 16, then
8 halving steps about the best) of min_k SINR_k at the beams' directions, the K powers rebalanced
for each candidate by 4 normalised rounds p_k proportional to (sum_{j != k} g_kj p_j + 1) / g_kk
(g_kj = |h_k d_j|^2, d_j the unit directions; the fixed point equalises the SINRs). Each candidate
is scored by the exact min SINR of its powers, and the state moves only to a strictly better one,
so the max-min rate never decreases either. (With the powers fixed, the balanced optimum is a
corner: a phase that helps one user hurts another, and a plain min-SINR search would stall.)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ios_uav_env.model.miso import (
    SLOT_OBJECTIVES,
    SlotChannel,
    aligned_phases,
    check_beams,
    check_objective,
    mrt_beam,
    mrt_beams,
    objective_value,
    random_phases,
    sinr,
    user_rates,
)
from ios_uav_env.model.miso_runs import aligned_starts, sum_rate_runs, wmmse_beams
from ios_uav_env.model.phase_sweep import maxmin_sweep


@dataclass(frozen=True, eq=False)
class SlotSolution:
    """The best AO run of a slot: its objective value, rates, phases and beams."""

    objective: str  # "sum" or "maxmin"
    value: float  # bps/Hz, the objective at (phases, beams)
    rates: np.ndarray  # (K,) bps/Hz, each user's rate
    phases: np.ndarray  # (M,) rad, the surface's shared phase shifts psi
    beams: np.ndarray  # (N_t, K), total power <= 1 (units of P)
    start: str  # the start it came from ("aligned k MRT", "aligned k ZF", "random i MRT")
    history: np.ndarray = field(repr=False)  # objective at the start and after each AO iteration


def optimise_slot(
    channel: SlotChannel,
    objective: str = "sum",
    *,
    random_starts: int = 2,
    rng: np.random.Generator | None = None,
    max_iter: int = 100,
    tol: float = 1e-7,
    weights: np.ndarray | None = None,
) -> SlotSolution:
    """The best of :func:`alternate` over the starts: each user's aligned phases with MRT and (when
    N_t >= K) ZF beams, and ``random_starts`` random phase draws (from ``rng``, default seed 0)
    with MRT beams. ``weights``: the weighted sum rate (:func:`alternate`)."""
    check_objective(objective)
    _check_weights(weights, channel.K, objective)
    starts = optimise_starts(channel, random_starts, np.random.default_rng(0) if rng is None else rng)
    return best_of_starts(channel, objective, starts, weights=weights, max_iter=max_iter, tol=tol)


def optimise_starts(
    channel: SlotChannel, random_starts: int, rng: np.random.Generator
) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """:func:`optimise_slot`'s starts: ``miso_runs.aligned_starts``, then ``random_starts`` random
    phase draws from ``rng`` with MRT beams."""
    if not (isinstance(random_starts, (int, np.integer)) and random_starts >= 0):
        raise ValueError(f"random_starts must be an integer >= 0, got {random_starts!r}")
    starts = aligned_starts(channel)
    for i in range(random_starts):
        psi = random_phases(channel, rng)
        starts.append((f"random {i} MRT", psi, mrt_beams(channel.matrix(psi))))
    return starts


def best_of_starts(
    channel: SlotChannel,
    objective: str,
    starts: list[tuple[str, np.ndarray, np.ndarray]],
    *,
    weights: np.ndarray | None = None,
    max_iter: int = 100,
    tol: float = 1e-7,
) -> SlotSolution:
    """The best :func:`alternate` run from each of ``starts`` (name, phases, beams): the first of the
    largest values. The sum rate's runs (weighted or not) go at once, ``miso_runs.sum_rate_runs``,
    each :func:`alternate`'s bit for bit; the max-min's one after the other."""
    check_objective(objective)
    alpha = _check_weights(weights, channel.K, objective)
    if not starts:
        raise ValueError("starts must hold at least one (name, phases, beams) start")
    if objective != "sum":
        runs = [alternate(channel, objective, psi, W, max_iter=max_iter, tol=tol, start=name)
                for name, psi, W in starts]  # fmt: skip
        return max(runs, key=lambda run: run.value)
    batch = sum_rate_runs(
        channel, np.array([psi for _, psi, _ in starts], dtype=float),
        np.array([W for _, _, W in starts], dtype=complex),
        None if alpha is None else np.tile(alpha, (len(starts), 1)), max_iter=max_iter, tol=tol,
    )  # fmt: skip
    i = int(np.argmax(batch.values))  # the first largest, as max() over the runs
    return SlotSolution(
        "sum", float(batch.values[i]), batch.rates[i].copy(), batch.phases[i].copy(), batch.beams[i].copy(),
        starts[i][0], batch.histories[i],
    )  # fmt: skip


def alone_starts(channel: SlotChannel) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """Each user k alone at full power: its aligned phases, MRT on its row, the other beams zero
    (TDMA's sum-rate points as simultaneous settings; WMMSE keeps a zero beam zero), as
    (name, phases, beams) starts of :func:`alternate`."""
    starts = []
    for k in range(channel.K):
        phases = aligned_phases(channel, k)
        beams = np.zeros((channel.n_t, channel.K), dtype=complex)
        beams[:, k] = mrt_beam(channel.matrix(phases)[k])
        starts.append((f"user {k} alone", phases, beams))
    return starts


def slot_optimum(
    channel: SlotChannel,
    objective: str = "sum",
    *,
    warm: SlotSolution | None = None,
    max_iter: int = 100,
    tol: float = 1e-7,
) -> SlotSolution:
    """The per-slot AO value of a slot without random draws: :func:`optimise_slot` with no random
    start, then :func:`alternate` from each user alone (:func:`alone_starts`; the sum rate only,
    so its value is at least TDMA's, one user all the slot) and from ``warm`` (a setting of
    another slot, e.g. the previous one's optimum: its phases and beams are feasible here too).
    Deterministic: the same channel and ``warm`` give the same solution bit for bit. The sum
    rate's runs go at once (:func:`best_of_starts`)."""
    starts = [*aligned_starts(channel), *(alone_starts(channel) if objective == "sum" else [])]
    if warm is not None:
        starts.append(("warm", warm.phases, warm.beams))
    return best_of_starts(channel, objective, starts, max_iter=max_iter, tol=tol)


def alternate(
    channel: SlotChannel,
    objective: str,
    phases: np.ndarray,
    beams: np.ndarray,
    *,
    max_iter: int = 100,
    tol: float = 1e-7,
    start: str = "given",
    weights: np.ndarray | None = None,
) -> SlotSolution:
    """AO from (``phases``, ``beams``): beams then phases per iteration (the module docstring), until
    an iteration gains less than ``tol`` (relative) or after ``max_iter`` iterations. The objective
    never decreases (up to rounding): ``history`` records it. ``weights`` (K,) >= 0 (objective
    "sum" only): the weighted sum rate sum_k alpha_k R_k instead (WMMSE with the alpha_k)."""
    check_objective(objective)
    alpha = _check_weights(weights, channel.K, objective)
    if not (isinstance(max_iter, (int, np.integer)) and max_iter >= 0):
        raise ValueError(f"max_iter must be an integer >= 0, got {max_iter!r}")
    if not (tol >= 0):
        raise ValueError(f"tol must be a number >= 0, got {tol!r}")
    psi = channel.check_phases(phases).copy()
    check_beams(beams, (channel.K, channel.n_t))
    W = np.array(beams, dtype=complex)  # (a copy in the caller's memory order: products round by it)
    if objective == "sum":  # the sum rate's runs: a batch of one
        a = None if alpha is None else alpha[None]
        runs = sum_rate_runs(channel, psi[None], W[None], a, max_iter=max_iter, tol=tol)
        value, rates, psi, W = float(runs.values[0]), runs.rates[0], runs.phases[0], runs.beams[0]
        return SlotSolution("sum", value, rates, psi, W, start, runs.histories[0])
    H = channel.matrix(psi)
    value = _value(user_rates(H, W), objective, alpha)
    history = [value]
    for _ in range(max_iter):
        candidate = maxmin_beams(H)
        if np.min(sinr(H, candidate)) > np.min(sinr(H, W)):
            W = candidate
        v, W = _maxmin_phases(channel, H, W, np.exp(-1j * psi))
        psi = np.mod(-np.angle(v), 2 * np.pi)
        H = channel.matrix(psi)
        new = _value(user_rates(H, W), objective, alpha)
        history.append(new)
        gain, value = new - value, new
        if gain <= tol * max(1.0, abs(value)):
            break
    rates = user_rates(H, W)
    return SlotSolution(objective, _value(rates, objective, alpha), rates, psi, W, start, np.array(history))


def _check_weights(weights: np.ndarray | None, k: int, objective: str) -> np.ndarray | None:
    """``weights`` as a float (K,) array of finite numbers >= 0 (or None), for the sum rate only."""
    if weights is None:
        return None
    if objective != "sum":
        raise ValueError(f"weights weigh the sum rate: they need objective 'sum', got {objective!r}")
    w = np.asarray(weights, dtype=float)
    if w.shape != (k,) or not np.all(np.isfinite(w)) or np.any(w < 0):
        raise ValueError(f"weights must be K = {k} finite numbers >= 0, got {weights!r}")
    return w


def _value(rates: np.ndarray, objective: str, alpha: np.ndarray | None) -> float:
    """The objective of ``rates``; with ``alpha`` the weighted sum sum_k alpha_k R_k."""
    return objective_value(rates, objective) if alpha is None else float(alpha @ rates)


def _cascade(channel: SlotChannel, W: np.ndarray) -> np.ndarray:
    """B (M, K, K): B[m, k, j] = c_km g_m^T w_j, element m's term of h_k w_j per unit v_m."""
    return np.ascontiguousarray(channel.coef.T[:, :, None] * (channel.to_elements @ W)[:, None, :])


# --- the max-min rate: SINR balancing and a 1-D phase search -------------------------------------


def maxmin_beams(H: np.ndarray, *, max_iter: int = 2000, tol: float = 1e-13) -> np.ndarray:
    """Beams (N_t, K) of total power 1 balancing the K SINRs at the max-min optimum for ``H`` (the
    module docstring: the normalised uplink fixed point, then the downlink powers)."""
    K, n_t = H.shape
    # (K, N_t^2): h_k^H h_k, row k; sum_k lam_k h_k^H h_k is the product with lam as a (1, K) row,
    # the very product np.tensordot(lam, outer, axes=1) makes (its reshapes and np.dot), without
    # its Python overhead in a loop of up to max_iter turns
    outer = (H.conj()[:, :, None] * H[:, None, :]).reshape(K, n_t * n_t)
    lam = np.full(K, 1.0 / K)
    eye = np.eye(n_t)
    Hh = H.conj().T
    for _ in range(max_iter):
        S = eye + np.dot(lam.reshape(1, K), outer).reshape(n_t, n_t)
        X = np.linalg.solve(S, Hh)  # (N_t, K): S^-1 h_k^H
        y = np.real(np.sum(H * X.T, axis=1))  # h_k S^-1 h_k^H
        f = (1.0 - lam * y) / y  # 1 / (h_k S_{-k}^-1 h_k^H)
        new = f / f.sum()
        done = np.abs(new - lam).max() <= tol
        lam = new
        if done:
            break
    S = eye + np.dot(lam.reshape(1, K), outer).reshape(n_t, n_t)
    X = np.linalg.solve(S, Hh)
    directions = X / np.linalg.norm(X, axis=0)
    gains = np.abs(H @ directions) ** 2
    y = np.real(np.sum(H * X.T, axis=1))
    gamma = 1.0 / np.sum((1.0 - lam * y) / y)
    system = np.diag(np.diag(gains)) / gamma - (gains - np.diag(np.diag(gains)))
    try:
        p = np.linalg.solve(system, np.ones(K))
    except np.linalg.LinAlgError:
        p = lam
    if not np.all(np.isfinite(p)) or np.any(p <= 0):
        p = lam
    return directions * np.sqrt(p / p.sum())


def _maxmin_phases(
    channel: SlotChannel, H: np.ndarray, W: np.ndarray, v: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """One max-min phase pass at the beams' directions; returns the phases' v and the new beams."""
    norms = np.linalg.norm(W, axis=0)
    live = norms > 0
    directions = np.where(live, W / np.where(live, norms, 1.0), mrt_beams(H) * np.sqrt(H.shape[0]))
    powers = norms**2
    v, powers = maxmin_sweep(v.copy(), _cascade(channel, directions), H @ directions, powers, 16, 8, 4)
    return v, directions * np.sqrt(powers)


__all__ = [
    "SLOT_OBJECTIVES", "SlotSolution", "aligned_starts", "alone_starts", "alternate", "best_of_starts",
    "maxmin_beams", "optimise_slot", "optimise_starts", "slot_optimum", "wmmse_beams",
]  # fmt: skip
