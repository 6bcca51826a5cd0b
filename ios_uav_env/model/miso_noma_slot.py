"""The per-slot NOMA optimum of the multi-antenna UAV: beams and phases for a stated decoding order.

For a :class:`~ios_uav_env.model.miso.SlotChannel` and a decoding order pi
(``miso_noma.decoding_order``: ascending G_k by default), this maximises the sum or the minimum of
the SIC rates R_pi(j) = min_{i >= j} log2(1 + SINR_{i<-j}) (``miso_noma``) over the beams W on the
unit sphere ||W||_F = 1 (full power is optimal: ``miso_noma``) and the shared phases psi, by
alternating optimisation (AO) from several starts. Every step is *accepted only if the exact
objective rises*, so each run's value never falls below its start's, and the result is at least the
best start.

**Ascent on the beams and the phases** (:func:`improve_beams` for the beams alone): up to
``BEAM_STEPS`` accepted steps of projected ascent on the sphere with backtracking, the beams and
the phases moved jointly. With T_ij = sum_{l >= j} |h_i w_l|^2 + 1 and I_ij = T_ij - |h_i w_j|^2
(positions in the order), r_ij = log2(T_ij / I_ij) and

    d r_ij / d conj(w_l) = h_i^H (h_i w_l) ([l >= j] / T_ij - [l > j] / I_ij) / ln 2,
    d r_ij / d psi_m = (2 / ln 2) sum_l ([l >= j] / T_ij - [l > j] / I_ij)
                       * Re{conj(h_i w_l) (-j v_m c_im g_m^T w_l)}

(v_m = exp(-j psi_m); the beams' part projected on the sphere's tangent). The objective's min over
decoders is not differentiable where two rates tie, which is where the max-min optimum sits, so
the direction is, for the max-min, the least-norm point of the convex hull of the gradients of the
rates within a width t of the smallest (the steepest ascent direction of their minimum; Frank-Wolfe
on the simplex), and for the sum the gradient of a soft-min -t ln sum_i exp(-r_ij / t) per message
j over its decoders. The step (W + s d_W) / ||W + s d_W||, psi + s d_psi along the unit direction
starts at twice the last accepted s (at most 1) and halves until the exact objective rises; if
none does, the width t (10 % of the mean rate) is cut tenfold, twice, then set to 0 (the least
rates' own gradients) before the block gives up.

**Phases**: one pass of 1-D searches over each element's phase (a coarse grid of 16, then 8 halving
steps about the best, ``phase_sweep.sic_sweep``, as the SDMA max-min AO's) of the exact objective at
the current beams, h_k w_j moving by (v_m' - v_m) c_km g_m^T w_j; an element moves only to a strictly
better phase, and the pass is kept only if the objective recomputed from the new phases is higher.

**Starts** (:func:`noma_starts`): for each user k its aligned phases (``miso.aligned_phases``) with
(a) MRT at equal powers and (b) one common beam, the principal direction of sum_i h_i^H h_i /
||h_i||^2, with powers falling along the order (K - j for position j: the first decoded, which
every user must decode, gets most), the NOMA form of the single-antenna power split; for the sum
rate also (c) each user alone at full power (``miso_slot.alone_starts``), so the sum-rate value is
at least TDMA's (one user all the slot). No SIC setting needs to beat SDMA: a message decoded by
several users must reach all of them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ios_uav_env.jit import jit
from ios_uav_env.model.miso import SlotChannel, aligned_phases, check_objective, mrt_beams
from ios_uav_env.model.miso_noma import _value, check_order, decoding_order
from ios_uav_env.model.miso_slot import _cascade, alone_starts
from ios_uav_env.model.phase_sweep import sic_sweep

__all__ = ["NomaSolution", "improve_beams", "noma_alternate", "noma_optimum", "noma_starts"]

#: Beam steps per AO iteration, and the phase search's grid and halvings.
BEAM_STEPS, N_GRID, N_HALVINGS = 10, 16, 8
_LN2 = math.log(2.0)


@dataclass(frozen=True, eq=False)
class NomaSolution:
    """The best NOMA AO run of a slot: its objective value, rates, phases, beams and order."""

    objective: str  # "sum" or "maxmin"
    value: float  # bps/Hz, the objective of the SIC rates at (phases, beams, order)
    rates: np.ndarray  # (K,) bps/Hz, each user's SIC rate
    phases: np.ndarray  # (M,) rad, the surface's shared phase shifts psi
    beams: np.ndarray  # (N_t, K), total power 1 (units of P)
    order: np.ndarray  # (K,) the decoding order, first decoded first
    start: str  # the start it came from
    history: np.ndarray = field(repr=False)  # objective at the start and after each AO iteration


def _objective(H: np.ndarray, W: np.ndarray, order: np.ndarray, total: bool) -> float:
    return float(_value(np.ascontiguousarray(H @ W), order, total, np.empty(H.shape[0])))


def _parts(H: np.ndarray, W: np.ndarray, order: np.ndarray):
    """In order positions: H's rows, X = H W, T, I and the rates r (K, K) (row decoder, column message;
    +inf above the diagonal, where no decoder is)."""
    K = H.shape[0]
    Hs = H[order]
    X = Hs @ W[:, order]
    g = np.abs(X) ** 2
    T = 1.0 + np.cumsum(g[:, ::-1], axis=1)[:, ::-1]
    interference = T - g
    r = np.where(np.tril(np.ones((K, K), dtype=bool)), np.log1p(g / interference) / _LN2, np.inf)
    return Hs, X, T, interference, r


def _gradients(
    H: np.ndarray, W: np.ndarray, order: np.ndarray, B: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray]:
    """The rates r (K, K) (:func:`_parts`) and the real gradient of each r_ij, (K, K, n): the beams'
    tangent part (real, then imaginary parts of W's entries, user columns), then the phases' when
    ``B`` (M, K, K), v_m c_im g_m^T w_l in positions, is given (the module docstring)."""
    K = H.shape[0]
    Hs, X, T, interference, r = _parts(H, W, order)
    lpos = np.arange(K)
    D = (lpos[None, None, :] >= lpos[None, :, None]) / T[:, :, None]
    D = D - (lpos[None, None, :] > lpos[None, :, None]) / interference[:, :, None]  # D[i, j, l]
    pos = np.einsum("in,il,ijl->ijnl", Hs.conj(), X, D) / _LN2
    grad = np.empty_like(pos)
    grad[..., order] = pos
    grad = 2.0 * (grad - np.einsum("nl,ijnl->ij", W.conj(), grad).real[:, :, None, None] * W)
    parts = [grad.real.reshape(K, K, -1), grad.imag.reshape(K, K, -1)]
    if B is not None:  # d X_il / d psi_m = -j v_m c_im g_m^T w_l
        parts.append(2.0 / _LN2 * np.real(-1j * np.einsum("ijl,il,mil->ijm", D, X.conj(), B)))
    return r, np.concatenate(parts, axis=2)


def _unit(d: np.ndarray) -> np.ndarray | None:
    size = float(np.linalg.norm(d))
    return d / size if size > 1e-300 and math.isfinite(size) else None


def _direction(r: np.ndarray, G: np.ndarray, total: bool, width: float) -> np.ndarray | None:
    """A unit ascent direction from the rates ``r`` and their gradients ``G`` (:func:`_gradients`;
    the module docstring): for the sum, the soft-min's gradient at temperature ``width`` (0: the
    least decoder's); for the max-min, the least-norm point of the convex hull of the gradients of
    the rates within ``width`` of the minimum (the steepest ascent direction of their minimum)."""
    if total:  # one soft-min per message (column) over its decoders
        if width > 0:
            e = np.exp(-(r - r.min(axis=0)) / width)
        else:
            e = (np.arange(len(r))[:, None] == np.argmin(r, axis=0)[None, :]).astype(float)
        return _unit(np.einsum("ij,ijn->n", e / e.sum(axis=0), G))
    active = G[r <= r.min() + width]
    return _unit(_least_norm(active @ active.T, 200) @ active)


@jit(fastmath=False)
def _least_norm(gram: np.ndarray, iters: int) -> np.ndarray:
    """Weights lam on the simplex (approximately) minimising lam' gram lam: Frank-Wolfe with exact
    line search (the least-norm point of the convex hull of the vectors whose Gram matrix is given)."""
    n = gram.shape[0]
    lam = np.full(n, 1.0 / n)
    for _ in range(iters):
        grad = gram @ lam
        a = int(np.argmin(grad))
        # along diff = e_a - lam: slope diff' gram lam = grad_a - lam' grad,
        # curvature diff' gram diff = gram_aa - 2 grad_a + lam' grad
        quad = lam @ grad
        slope = grad[a] - quad
        curve = gram[a, a] - 2.0 * grad[a] + quad
        if curve <= 0.0 or slope >= 0.0:
            break
        step = min(-slope / curve, 1.0)
        lam *= 1.0 - step
        lam[a] += step
    return lam


def improve_beams(
    H: np.ndarray, beams: np.ndarray, order: np.ndarray, objective: str, *, steps: int = BEAM_STEPS
) -> tuple[np.ndarray, float]:
    """Up to ``steps`` accepted ascent steps on the beams alone, the phases fixed (``H``), from
    ``beams`` (N_t, K), nonzero; returns the beams (unit Frobenius norm) and their objective, never
    below the start's at full power. ``order``: a permutation of the users (``check_order``)."""
    check_objective(objective)
    H = np.asarray(H, dtype=complex)
    if H.ndim != 2 or not np.all(np.isfinite(H)):
        raise ValueError(f"H must be a finite (K, N_t) channel matrix, got shape {H.shape}")
    W = _checked_start_beams(beams, H.shape[1], H.shape[0])
    if not np.any(W):
        raise ValueError("beams must be nonzero (the ascent starts from their direction)")
    if not (isinstance(steps, (int, np.integer)) and not isinstance(steps, bool) and steps >= 0):
        raise ValueError(f"steps must be an integer >= 0, got {steps!r}")
    pi = check_order(order, H.shape[0])
    _, _, W, value = _ascend(None, H, None, W / np.linalg.norm(W), pi, objective, int(steps))
    return W, value


def _checked_start_beams(beams: object, n_t: int, k: int) -> np.ndarray:
    """``beams`` as a finite complex (N_t, K) array of any power (a start, normalised by the
    caller), else ``ValueError`` naming what is wrong."""
    try:
        W = np.array(beams, dtype=complex)
    except (TypeError, ValueError):
        raise ValueError(
            f"beams must be a complex array of shape ({n_t}, {k}) (N_t, K), got {beams!r}"
        ) from None
    if W.shape != (n_t, k):
        raise ValueError(f"beams must be a complex array of shape ({n_t}, {k}) (N_t, K), got shape {W.shape}")
    if not np.all(np.isfinite(W)):
        raise ValueError("beams must be finite: they have NaN or infinite entries")
    return W


def _ascend(
    channel: SlotChannel | None,
    H: np.ndarray,
    psi: np.ndarray | None,
    W: np.ndarray,
    order: np.ndarray,
    objective: str,
    steps: int,
) -> tuple[np.ndarray | None, np.ndarray, np.ndarray, float]:
    """Up to ``steps`` accepted ascent steps on the beams (unit norm ``W``) and, with ``channel``,
    jointly on the phases ``psi`` (H = channel.matrix(psi)): returns (psi, H, W, value)."""
    total = objective == "sum"
    value = _objective(H, W, order, total)
    scale = max(abs(value) / (H.shape[0] if total else 1), 1e-3)
    s, n = 0.5, W.size
    for _ in range(steps):
        moved = False
        B = None
        if channel is not None:
            B = np.exp(-1j * psi)[:, None, None] * _cascade(channel, W)[:, order][:, :, order]
        r, G = _gradients(H, W, order, B)
        for width in (0.1 * scale, 0.01 * scale, 0.001 * scale, 0.0):
            d = _direction(r, G, total, width)
            if d is None:
                continue
            dW = (d[:n] + 1j * d[n : 2 * n]).reshape(W.shape)
            step = min(2.0 * s, 1.0)
            while step > 1e-9 and not moved:
                cand_W = W + step * dW
                cand_W /= np.linalg.norm(cand_W)
                cand_psi, cand_H = psi, H
                if channel is not None:
                    cand_psi = np.mod(psi + step * d[2 * n :], 2 * np.pi)
                    cand_H = channel.matrix_unchecked(cand_psi)  # (finite: psi and d are)
                new = _objective(cand_H, cand_W, order, total)
                if new > value:
                    psi, H, W, value, s, moved = cand_psi, cand_H, cand_W, new, step, True
                step *= 0.5
            if moved:
                break
        if not moved:
            break
    return psi, H, W, value


def noma_alternate(
    channel: SlotChannel,
    objective: str,
    phases: np.ndarray,
    beams: np.ndarray,
    *,
    order: object = None,
    max_iter: int = 30,
    tol: float = 1e-7,
    start: str = "given",
) -> NomaSolution:
    """AO from (``phases``, ``beams``) for the decoding ``order`` (default
    ``miso_noma.decoding_order``): beams then phases per iteration, each block kept only if the
    objective rises, until an iteration gains less than ``tol`` (relative) or after ``max_iter``.
    ``history`` records the objective, nondecreasing. Zero ``beams`` start from equal-power MRT."""
    check_objective(objective)
    if not (isinstance(max_iter, (int, np.integer)) and not isinstance(max_iter, bool) and max_iter >= 0):
        raise ValueError(f"max_iter must be an integer >= 0, got {max_iter!r}")
    if isinstance(tol, bool) or not (isinstance(tol, (int, float, np.floating)) and tol >= 0):
        raise ValueError(f"tol must be a number >= 0 (relative), got {tol!r}")
    pi = decoding_order(channel, order)
    total = objective == "sum"
    psi = np.mod(channel.check_phases(phases), 2 * np.pi)
    H = channel.matrix(psi)
    W = _checked_start_beams(beams, channel.n_t, channel.K)
    W = W / np.linalg.norm(W) if np.linalg.norm(W) > 0 else mrt_beams(H)
    value = _objective(H, W, pi, total)
    history = [value]
    for _ in range(max_iter):
        before = value
        new_psi, new_H, new_W, new = _ascend(channel, H, psi, W, pi, objective, BEAM_STEPS)
        if new > value:
            psi, H, W, value = new_psi, new_H, new_W, new
        v = sic_sweep(np.exp(-1j * psi), _cascade(channel, W), H @ W, pi, total, N_GRID, N_HALVINGS)
        new_psi = np.mod(-np.angle(v), 2 * np.pi)
        new_H = channel.matrix(new_psi)
        new = _objective(new_H, W, pi, total)
        if new > value:
            psi, H, value = new_psi, new_H, new
        history.append(value)
        if value - before <= tol * max(1.0, abs(value)):
            break
    out = np.empty(channel.K)
    _value(np.ascontiguousarray(H @ W), pi, total, out)
    return NomaSolution(objective, value, out, psi, W, pi, start, np.array(history))


def noma_starts(
    channel: SlotChannel, objective: str, order: object = None
) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """The AO's starts (name, phases, beams) (the module docstring)."""
    check_objective(objective)
    pi = decoding_order(channel, order)
    K = channel.K
    powers = np.empty(K)
    powers[pi] = np.arange(K, 0, -1) / (K * (K + 1) / 2)
    starts = []
    for k in range(K):
        psi = aligned_phases(channel, k)
        H = channel.matrix(psi)
        starts.append((f"aligned {k} MRT", psi, mrt_beams(H)))
        norms = np.linalg.norm(H, axis=1)
        unit = H / np.where(norms > 0, norms, 1.0)[:, None]
        _, vectors = np.linalg.eigh(unit.conj().T @ unit)
        starts.append((f"aligned {k} common", psi, np.outer(vectors[:, -1], np.sqrt(powers))))
    if objective == "sum":
        starts += alone_starts(channel)
    return starts


def noma_optimum(
    channel: SlotChannel,
    objective: str = "sum",
    *,
    order: object = None,
    warm: NomaSolution | None = None,
    max_iter: int = 30,
    tol: float = 1e-7,
) -> NomaSolution:
    """The best :func:`noma_alternate` run over :func:`noma_starts` and ``warm`` (another slot's
    setting, e.g. the previous one's: its phases and beams are feasible here too). Deterministic:
    the same channel, order and ``warm`` give the same solution bit for bit."""
    starts = noma_starts(channel, objective, order)
    if warm is not None:
        starts.append(("warm", warm.phases, warm.beams))
    best = None
    for name, phases, beams in starts:
        run = noma_alternate(
            channel, objective, phases, beams, order=order, max_iter=max_iter, tol=tol, start=name
        )
        best = run if best is None or run.value > best.value else best
    return best
