"""The methods behind ``ios_uav_env.model.star_slot``: the result type, each side served alone,
the ES frontier and its branch and bound (derivations in ``star_slot``), time switching with NOMA,
and coupled or shared phases.

**TS with NOMA, max-min.** Reflecting, the rate pair lies in the NOMA region C_R of the SNRs
(eta (a_D^r + sum a^r)^2, eta (a_D^t)^2) (user t has its direct link only), transmitting in the
region C_T of (eta (a_D^r)^2, eta (a_D^t + sum a^t)^2); a time split lam reaches
(1 - lam) C_R + lam C_T, and over lam the set K = conv(C_R u C_T). Each region is the degraded
broadcast channel's capacity region, convex and comprehensive, so rho (1, 1) is in K iff
rho <= h(w) = max_{x in K} w x_r + (1 - w) x_t for every w in [0, 1] (a separating hyperplane):
the optimum is min_w h(w), h is convex (a support function), and every w gives an upper bound.
h(w) = max(h_R(w), h_T(w)); in one region, with the strong user's power fraction x, the weighted
sum is c_s log2(1 + x g_s) - c_w log2(1 + x g_w) + const, whose derivative vanishes at most once,
at x = (c_w g_w - c_s g_s) / (g_s g_w (c_s - c_w)), so its maximum is at x = 0, 1 or there
(:func:`weighted_noma`). Golden-section search on w gives the bound; the value is the best
(1 - lam) x + lam y over the maximisers x of C_R and y of C_T found (and each region's own
max-min point), lam from equal rates: by Caratheodory a point of K is such a mix.

**Coupled or shared phases (ES, and the fixed split) under NOMA.** Both are settings of
independent phases, so the independent-phase optimum bounds them. The value is a feasible
setting found by minorise-maximise steps on c_r A_r + c_t A_t: |h_s| >= Re(h_s e^{-j psi_s}) with
equality at psi_s = arg h_s, so with the directions psi fixed the surrogate separates per element
into Re(e^{-j theta} (A x e^{j alpha} + B y e^{j beta'})), A = c_r a^r, B = c_t a^t,
alpha = phi^r - psi_r, beta' = phi^t - psi_t - s pi/2 (s = 0 shared, +-1 coupled: theta^t =
theta^r + s pi/2). Its maximum over theta is |A x e^{j alpha} + B y e^{j beta'}|, and over the
ES amplitudes (x, y) = (cos gamma, sin gamma) the square A^2 cos^2 gamma + B^2 sin^2 gamma +
A B cos(delta) sin(2 gamma), delta = alpha - beta', is largest at 2 gamma =
atan2(max(A B cos delta, 0), (A^2 - B^2) / 2); coupled phases take the better sign. Each step
cannot lower c_r A_r + c_t A_t; the steps run from the frontier settings of 11 weights and the
independent optimum's, and the best max-min rate is kept. On surfaces of at most 256 elements a
coordinate search then polishes it (:func:`coordinate_search`: element by element, the best of a
grid of its settings with the others held; from every start when M <= 32).

**b-bit phases** are bounded by the continuous optimum. The value is the continuous setting with
each side's phases replaced by that side's exact b-bit optimum
(:func:`~ios_uav_env.model.star.best_discrete_phases`; independent phases, MS), or the
minorise-maximise steps with theta on the grid (coupled, shared: the +-pi/2 offset stays on the
grid for b >= 2); with independent phases the coordinate search polishes it too (M <= 256).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ios_uav_env.model.regions import weighted_noma
from ios_uav_env.model.star import (
    StarChannels,
    StarSurface,
    best_discrete_phases,
    noma_maxmin,
    noma_rates,
    phase_grid,
    quantise,
    side_amplitude,
)

#: Relative gap at which the branch and bound stops (the TS search runs to 1e-12 in the weight).
DEFAULT_TOL = 1e-6
_MAX_NODES = 4000
_MM_WEIGHTS = np.linspace(0.0, 1.0, 11)
_MM_STEPS = 40
#: Largest M for the coordinate search that polishes the coupled, shared and b-bit settings.
LOCAL_SEARCH_MAX_M = 256
_SWEEPS = 3
#: Up to this M the coordinate search starts from every minorise-maximise result, not the best only.
_MULTI_START_MAX_M = 32


@dataclass(frozen=True)
class SlotOptimum:
    """A feasible setting's ``value`` and a certified ``upper`` bound on the slot's optimum (bps/Hz)."""

    value: float  # objective of the setting in ``setting`` (max-min or sum rate)
    upper: float  # no setting of the surface scores more (>= value)
    rates: tuple[float, float]  # (R_r, R_t) of the setting
    method: str  # how value and upper were found
    setting: dict = field(default_factory=dict, repr=False)  # u_r, u_t, theta_r, theta_t, split/share/lam

    @property
    def gap(self) -> float:
        """upper - value (0 where the optimum is closed form)."""
        return self.upper - self.value


def rate_of(ch: StarChannels, amp: float) -> float:
    return math.log2(1 + ch.eta * amp * amp)


def side_best(ch: StarChannels, side: str, u: np.ndarray, bits: int | None) -> tuple[float, np.ndarray]:
    """Best amplitude of one side with amplitudes ``u`` and its phases (aligned or exact b-bit)."""
    a, phi, d = (ch.a_r, ch.phi_r, ch.direct_r) if side == "r" else (ch.a_t, ch.phi_t, ch.direct_t)
    amps = u * a
    if bits is None:
        return d + float(amps.sum()), phi.copy()
    theta, amp = best_discrete_phases(amps, phi, d, bits)
    return amp, theta


def full_side(ch: StarChannels, surface: StarSurface, side: str) -> tuple[float, np.ndarray, np.ndarray]:
    """A side served alone: (amplitude, u, theta) with the whole surface on it (or the fixed split)."""
    if surface.protocol == "fixed":
        u = np.full(ch.M, ch.fixed_r if side == "r" else ch.fixed_t)
    else:
        u = np.ones(ch.M)
    amp, theta = side_best(ch, side, u, surface.bits)
    return amp, u, theta


def maxmin_of(ch: StarChannels, amp_r: np.ndarray, amp_t: np.ndarray) -> np.ndarray:
    return noma_maxmin(ch.eta * np.square(amp_r), ch.eta * np.square(amp_t))[0]


def frontier_point(ch: StarChannels, w: float) -> tuple[float, float, np.ndarray, np.ndarray]:
    """The ES frontier point of weight w: per element u = ((1-w) a^r, w a^t) / norm."""
    x, y = (1 - w) * ch.a_r, w * ch.a_t
    norm = np.hypot(x, y)
    safe = np.where(norm > 0, norm, 1.0)
    u_r, u_t = np.where(norm > 0, x / safe, 1.0), y / safe
    return ch.direct_r + float(ch.a_r @ u_r), ch.direct_t + float(ch.a_t @ u_t), u_r, u_t


def es_frontier_bb(
    ch: StarChannels, tol: float = DEFAULT_TOL, objective: Callable[..., Any] | None = None
) -> tuple[float, float, float]:
    """Branch and bound on the ES frontier weight (``star_slot``'s docstring): (value, upper, w*).

    The interval of largest bound is halved until its bound is within ``tol`` (relative) of the
    best value; the bound over an interval is first order in its width, so the count of
    evaluations grows like tol^(-1/2) (about 1300 at 1e-6). After 4000 the current bound is
    returned, still certified, with a wider gap. ``objective(ch, A_r, A_t)``: the slot's value of
    the two amplitudes, nondecreasing in both (default: the NOMA max-min, :func:`maxmin_of`; the
    box bound over an interval needs only that monotonicity)."""
    value_of = objective or maxmin_of
    pts = {w: frontier_point(ch, w)[:2] for w in (0.0, 1.0)}
    best_w = max(pts, key=lambda w: float(value_of(ch, *pts[w])))
    lower = float(value_of(ch, *pts[best_w]))
    heap = [(-float(value_of(ch, pts[0.0][0], pts[1.0][1])), 0.0, 1.0)]
    for _ in range(_MAX_NODES):
        bound, w1, w2 = heap[0]
        if -bound - lower <= tol * max(lower, 1e-300):
            break
        heapq.heappop(heap)
        mid = 0.5 * (w1 + w2)
        pts[mid] = frontier_point(ch, mid)[:2]
        value = float(value_of(ch, *pts[mid]))
        if value > lower:
            lower, best_w = value, mid
        for a, b in ((w1, mid), (mid, w2)):
            heapq.heappush(heap, (-float(value_of(ch, pts[a][0], pts[b][1])), a, b))
    return lower, max(lower, -heap[0][0]), best_w


def noma_setting(ch: StarChannels, amp_r: float, amp_t: float, **setting: np.ndarray) -> tuple:
    g_r, g_t = ch.eta * amp_r * amp_r, ch.eta * amp_t * amp_t
    value, split = noma_maxmin(g_r, g_t)
    rates = noma_rates(g_r, g_t, split)
    return float(value), (float(rates[0]), float(rates[1])), dict(setting, split=float(split))


def discrete_sides(ch: StarChannels, bits: int, u_r: np.ndarray, u_t: np.ndarray) -> tuple:
    amp_r, th_r = side_best(ch, "r", u_r, bits)
    amp_t, th_t = side_best(ch, "t", u_t, bits)
    return amp_r, amp_t, th_r, th_t


def ts_noma(ch: StarChannels, surface: StarSurface) -> SlotOptimum:
    full_r, _, th_r = full_side(ch, surface, "r")
    full_t, _, th_t = full_side(ch, surface, "t")
    return ts_amplitudes(ch, full_r, full_t, th_r, th_t)


def ts_amplitudes(
    ch: StarChannels, full_r: float, full_t: float, th_r: np.ndarray, th_t: np.ndarray
) -> SlotOptimum:
    """TS with NOMA, max-min, given each side's amplitude at its phases (module docstring)."""
    periods = (
        (ch.eta * full_r**2, ch.eta * ch.direct_t**2),  # reflecting: user t has its direct link only
        (ch.eta * ch.direct_r**2, ch.eta * full_t**2),  # transmitting
    )
    points: list[list[tuple[float, float, float]]] = [[], []]  # per period: (R_r, R_t, split) found
    for i, g in enumerate(periods):  # each period's own max-min point
        _, split = noma_maxmin(*g)
        rates = noma_rates(*g, split)
        points[i].append((float(rates[0]), float(rates[1]), float(split)))

    def h(w: float) -> float:
        out = []
        for i, g in enumerate(periods):
            value, r_r, r_t, split = weighted_noma(*g, w)
            points[i].append((r_r, r_t, split))
            out.append(value)
        return max(out)

    lo, hi = 0.0, 1.0
    inv = (math.sqrt(5) - 1) / 2
    a, b = hi - inv * (hi - lo), lo + inv * (hi - lo)
    fa, fb = h(a), h(b)
    upper = min(h(0.0), h(1.0), fa, fb)
    while hi - lo > 1e-12:
        if fa <= fb:
            hi, b, fb = b, a, fa
            a = hi - inv * (hi - lo)
            fa = h(a)
        else:
            lo, a, fa = a, b, fb
            b = lo + inv * (hi - lo)
            fb = h(b)
        upper = min(upper, fa, fb)
    # one point of each period mixed, (1 - lam) x + lam y, lam from equal rates (Caratheodory: a
    # point of conv(C_R u C_T) is such a mix), clipped to [0, 1]
    x, y = np.array(points[0])[:, None, :], np.array(points[1])[None, :, :]
    dx, dy = x[..., 0] - x[..., 1], y[..., 0] - y[..., 1]
    den = dx - dy
    lam = np.clip(np.divide(dx, den, out=np.zeros_like(den), where=den != 0), 0.0, 1.0)
    mixed = (1 - lam)[..., None] * x[..., :2] + lam[..., None] * y[..., :2]
    score = mixed.min(axis=-1)
    i, j = np.unravel_index(int(np.argmax(score)), score.shape)
    value = float(score[i, j])
    setting = dict(
        theta_r=th_r, theta_t=th_t, lam=float(lam[i, j]), split_reflect=float(x[i, 0, 2]),
        split_transmit=float(y[0, j, 2]), reflect=periods[0], transmit=periods[1],
    )  # fmt: skip
    rates = (float(mixed[i, j, 0]), float(mixed[i, j, 1]))
    method = "time split of the two NOMA regions; bound: the dual min_w h(w)"
    return SlotOptimum(value, max(upper, value), rates, method, setting)


def mm_phases(
    ch: StarChannels, surface: StarSurface, c_r: float, c_t: float, u_r: np.ndarray, u_t: np.ndarray
) -> tuple:
    """Minorise-maximise steps on c_r A_r + c_t A_t with coupled or shared phases (module docstring)."""
    fixed = surface.protocol == "fixed"
    theta_r = np.angle(
        c_r * u_r * ch.a_r * np.exp(1j * ch.phi_r) + c_t * u_t * ch.a_t * np.exp(1j * ch.phi_t)
    )
    signs = np.zeros(ch.M) if surface.phases == "shared" else np.ones(ch.M)
    theta_t = theta_r + signs * np.pi / 2
    for _ in range(_MM_STEPS):
        h_r = ch.direct_r + np.sum(u_r * ch.a_r * np.exp(1j * (ch.phi_r - theta_r)))
        h_t = ch.direct_t + np.sum(u_t * ch.a_t * np.exp(1j * (ch.phi_t - theta_t)))
        alpha, beta = ch.phi_r - np.angle(h_r), ch.phi_t - np.angle(h_t)
        big_a, big_b = c_r * ch.a_r, c_t * ch.a_t
        best_val = np.full(ch.M, -1.0)
        for sign in (0.0,) if surface.phases == "shared" else (1.0, -1.0):
            shift = beta - sign * np.pi / 2
            if fixed:
                x, y = u_r, u_t
            else:
                delta = alpha - shift
                gamma = 0.5 * np.arctan2(
                    np.maximum(big_a * big_b * np.cos(delta), 0.0), 0.5 * (big_a**2 - big_b**2)
                )
                x, y = np.cos(gamma), np.sin(gamma)
            z = big_a * x * np.exp(1j * alpha) + big_b * y * np.exp(1j * shift)
            theta = np.angle(z)
            if surface.bits is not None:
                theta = quantise(theta, surface.bits)
            val = np.real(z * np.exp(-1j * theta))
            take = val > best_val
            best_val = np.where(take, val, best_val)
            theta_r = np.where(take, theta, theta_r)
            theta_t = np.where(take, theta + sign * np.pi / 2, theta_t)
            if not fixed:
                u_r, u_t = np.where(take, x, u_r), np.where(take, y, u_t)
    theta_r, theta_t = quantise(theta_r, surface.bits), quantise(theta_t, surface.bits)
    amp_r = side_amplitude(u_r * ch.a_r, ch.phi_r, ch.direct_r, theta_r)
    amp_t = side_amplitude(u_t * ch.a_t, ch.phi_t, ch.direct_t, theta_t)
    return amp_r, amp_t, dict(u_r=u_r, u_t=u_t, theta_r=theta_r, theta_t=theta_t)


def _candidates(ch: StarChannels, surface: StarSurface) -> tuple[np.ndarray, ...]:
    """One element's settings on a grid: (u_r, u_t, theta_r, theta_t), each (C,)."""
    theta = phase_grid(surface.bits) if surface.bits else np.linspace(0, 2 * np.pi, 24, endpoint=False)
    gamma = np.linspace(0, np.pi / 2, 11)
    if surface.phases == "independent":
        g, a, b = (x.ravel() for x in np.meshgrid(gamma, theta, theta, indexing="ij"))
    else:
        offsets = [0.0] if surface.phases == "shared" else [np.pi / 2, -np.pi / 2]
        g, a, o = (x.ravel() for x in np.meshgrid(gamma, theta, offsets, indexing="ij"))
        b = quantise(a + o, surface.bits)
    if surface.protocol == "fixed":
        return np.full(a.size, ch.fixed_r), np.full(a.size, ch.fixed_t), a, b
    return np.cos(g), np.sin(g), a, b


def coordinate_search(ch: StarChannels, surface: StarSurface, setting: dict) -> dict:
    """Polish a NOMA max-min setting of at most ``LOCAL_SEARCH_MAX_M`` elements: element by element,
    the best of a grid of its settings (``_candidates``, on the b-bit grid if any) with the others
    held, kept only if the max-min rate rises; up to 3 sweeps. The result is a setting of the same
    surface, never worse."""
    if ch.M > LOCAL_SEARCH_MAX_M:
        return setting
    u_r, u_t = setting["u_r"].astype(float), setting["u_t"].astype(float)
    th_r, th_t = setting["theta_r"].astype(float), setting["theta_t"].astype(float)
    c_ur, c_ut, c_thr, c_tht = _candidates(ch, surface)
    t_r = u_r * ch.a_r * np.exp(1j * (ch.phi_r - th_r))
    t_t = u_t * ch.a_t * np.exp(1j * (ch.phi_t - th_t))
    h_r, h_t = ch.direct_r + t_r.sum(), ch.direct_t + t_t.sum()
    current = float(maxmin_of(ch, abs(h_r), abs(h_t)))
    for _ in range(_SWEEPS):
        improved = False
        for m in range(ch.M):
            cand_r = c_ur * ch.a_r[m] * np.exp(1j * (ch.phi_r[m] - c_thr))
            cand_t = c_ut * ch.a_t[m] * np.exp(1j * (ch.phi_t[m] - c_tht))
            values = maxmin_of(ch, np.abs(h_r - t_r[m] + cand_r), np.abs(h_t - t_t[m] + cand_t))
            k = int(np.argmax(values))
            if values[k] > current * (1 + 1e-12):
                h_r, h_t = h_r - t_r[m] + cand_r[k], h_t - t_t[m] + cand_t[k]
                t_r[m], t_t[m], current, improved = cand_r[k], cand_t[k], float(values[k]), True
                u_r[m], u_t[m], th_r[m], th_t[m] = c_ur[k], c_ut[k], c_thr[k], c_tht[k]
        if not improved:
            break
    return dict(u_r=u_r, u_t=u_t, theta_r=th_r, theta_t=th_t)


def setting_value(ch: StarChannels, setting: dict) -> tuple:
    """noma_setting of a (u, theta) setting: its amplitudes re-summed, then the max-min split."""
    amp_r = side_amplitude(setting["u_r"] * ch.a_r, ch.phi_r, ch.direct_r, setting["theta_r"])
    amp_t = side_amplitude(setting["u_t"] * ch.a_t, ch.phi_t, ch.direct_t, setting["theta_t"])
    return noma_setting(ch, amp_r, amp_t, **setting)


def joint_phases(ch: StarChannels, surface: StarSurface, tol: float) -> SlotOptimum:
    if surface.protocol == "fixed":
        u_r0, u_t0 = np.full(ch.M, ch.fixed_r), np.full(ch.M, ch.fixed_t)
        upper = float(maxmin_of(ch, ch.direct_r + float(ch.a_r @ u_r0), ch.direct_t + float(ch.a_t @ u_t0)))
        weights = _MM_WEIGHTS
    else:
        _, upper, w_star = es_frontier_bb(ch, tol)
        weights = np.unique(np.concatenate([_MM_WEIGHTS, [w_star]]))
    starts = []
    for w in weights:
        if surface.protocol != "fixed":
            _, _, u_r0, u_t0 = frontier_point(ch, float(w))
        amp_r, amp_t, setting = mm_phases(ch, surface, 1 - w, w, u_r0.copy(), u_t0.copy())
        starts.append(noma_setting(ch, amp_r, amp_t, **setting))
    starts.sort(key=lambda out: -out[0])
    best = starts[0]
    for start in starts if ch.M <= _MULTI_START_MAX_M else starts[:1]:
        polished = setting_value(ch, coordinate_search(ch, surface, start[2]))
        best = polished if polished[0] > best[0] else best
    method = f"{surface.phases} phases by minorise-maximise; bound: independent continuous phases"
    return SlotOptimum(best[0], max(upper, best[0]), best[1], method, best[2])
