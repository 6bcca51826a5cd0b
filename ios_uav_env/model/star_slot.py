"""The per-slot optimum of a STAR surface serving two users (``ios_uav_env.model.star``).

:func:`slot_optimum` returns a feasible setting's value and a certified upper bound on the
optimum of one slot at one UAV position, for any protocol, phase model, phase resolution and
access scheme, with the objective max-min (``"maxmin"``: max min(R_r, R_t)) or sum rate. Notation
as in ``star``: A_s = |h_s| the amplitude of user s, g_s = eta A_s^2.

**Which cases are closed form (value == upper).**

- *Aligned sides.* With independent phases each side's sum is largest with every term in phase
  with the direct path, theta_m^s = phi_m^s, whatever the amplitudes: A_s = a_D^s + sum_m u_m^s
  a_m^s. Where only one side carries power on an element (MS, TS, TDMA) the coupled and shared
  models bind nothing, so the same holds for them.
- *TDMA.* Each user is served in its share with the whole surface on its side (u^s = 1; the
  ``"fixed"`` split: u^s of the configured surface), c_s = log2(1 + eta A_s^2); max over the
  share of min(tau c_r, (1 - tau) c_t) is c_r c_t / (c_r + c_t) at tau = c_t / (c_r + c_t); the
  sum rate is max(c_r, c_t). TS under TDMA is the same schedule (transmit while serving t).
- *Sum rate.* Every rate pair of one setting has R_r + R_t <= log2(1 + max(g_r, g_t)) (NOMA's
  sum is largest with all power on the stronger user), so the sum-rate optimum gives the whole
  surface and all power to the better side: max(c_r, c_t), for every protocol.
- *b-bit phases, one side.* :func:`~ios_uav_env.model.star.best_discrete_phases` is exact.

**ES, independent continuous phases, NOMA max-min: branch and bound on the frontier.** The set
of reachable (A_r, A_t) is the image of the convex set {u >= 0, (u^r)^2 + (u^t)^2 <= 1} under a
linear map, hence convex; its Pareto frontier is traced by the maximisers of (1 - w) A_r + w A_t,
w in [0, 1], which are per element u_m = ((1 - w) a_m^r, w a_m^t) / ||.||, with A_r nonincreasing
and A_t nondecreasing in w. The max-min NOMA rate F(A_r, A_t) is nondecreasing in both, so on
[w1, w2] it is at most F(A_r(w1), A_t(w2)): that bound and the evaluated frontier points run a
branch and bound on w to a relative gap ``tol``.

**MS.** The settings are 2^M points; their convex hull's frontier is the polyline through the
M + 1 "threshold" settings (elements sorted by a_m^t / a_m^r, the first k transmitting: a
fractional knapsack). The value is the best threshold setting, the bound the largest box bound
F(A_r(k), A_t(k + 1)) over the polyline's segments.

**TS, NOMA.** Reflecting, the pair of rates lies in the NOMA region C_R of SNRs (eta (a_D^r +
sum a^r)^2, eta (a_D^t)^2), transmitting in C_T; a time split reaches conv(C_R u C_T). The
regions are convex and comprehensive, so the max-min rate is min over w in [0, 1] of
h(w) = max over both regions of w R_r + (1 - w) R_t (a separating hyperplane), h is convex and each
region's weighted maximum is closed form (one stationary point in the split). Any w bounds the
optimum; golden-section search on w gives the bound, the best mix of two of the maximisers found
the value.

**Coupled or shared phases (ES, and the fixed split) under NOMA.** The independent-phase optimum
is the bound. The value is a feasible setting from minorise-maximise steps on c_r A_r + c_t A_t
(|h| >= Re(h e^{-j psi}), equal at psi = arg h): with the directions fixed, each element's best
(u, theta) is closed form (the larger eigenvalue of a 2 x 2 form in u; theta the argument of the
combined term; for coupled phases the better sign of +-pi/2), run for several weights c.
**b-bit phases** are bounded by the continuous optimum; the value is the continuous setting with
each side's phases replaced by that side's exact b-bit optimum (independent), or rounded
(coupled, shared: the +-pi/2 offset stays on the grid for b >= 2).
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, field

import numpy as np

from ios_uav_env.model.star import (
    ACCESS,
    OBJECTIVES,
    StarChannels,
    StarSurface,
    best_discrete_phases,
    check_setting,
    noma_maxmin,
    noma_rates,
    quantise,
    side_amplitude,
    tdma_maxmin,
    tdma_rates,
    ts_rates,
)

#: Relative gap at which the branch and bound and the golden-section search stop.
DEFAULT_TOL = 1e-6
_MAX_NODES = 4000
_MM_WEIGHTS = np.linspace(0.0, 1.0, 11)
_MM_STEPS = 40


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


def _check(access: str, objective: str, tol: float) -> None:
    if access not in ACCESS:
        raise ValueError(f"access must be one of {ACCESS}, got {access!r}")
    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {OBJECTIVES}, got {objective!r}")
    if not (isinstance(tol, float | int) and 0 < tol < 1):
        raise ValueError(f"tol must be a number in (0, 1), got {tol!r}")


def _rate(ch: StarChannels, amp: float) -> float:
    return math.log2(1 + ch.eta * amp * amp)


def _side(ch: StarChannels, side: str, u: np.ndarray, bits: int | None) -> tuple[float, np.ndarray]:
    """Best amplitude of one side with amplitudes ``u`` and its phases (aligned or exact b-bit)."""
    a, phi, d = (ch.a_r, ch.phi_r, ch.direct_r) if side == "r" else (ch.a_t, ch.phi_t, ch.direct_t)
    amps = u * a
    if bits is None:
        return d + float(amps.sum()), phi.copy()
    theta, amp = best_discrete_phases(amps, phi, d, bits)
    return amp, theta


def _full(ch: StarChannels, surface: StarSurface, side: str) -> tuple[float, np.ndarray, np.ndarray]:
    """A side served alone: (amplitude, u, theta) with the whole surface on it (or the fixed split)."""
    if surface.protocol == "fixed":
        u = np.full(ch.M, ch.fixed_r if side == "r" else ch.fixed_t)
    else:
        u = np.ones(ch.M)
    amp, theta = _side(ch, side, u, surface.bits)
    return amp, u, theta


def _tdma(ch: StarChannels, surface: StarSurface, objective: str) -> SlotOptimum:
    amp_r, u_r, th_r = _full(ch, surface, "r")
    amp_t, u_t, th_t = _full(ch, surface, "t")
    c_r, c_t = _rate(ch, amp_r), _rate(ch, amp_t)
    if objective == "maxmin":
        value, share = tdma_maxmin(c_r, c_t)
    else:
        value, share = max(c_r, c_t), float(c_r >= c_t)
    setting = dict(u_r=u_r, u_t=u_t, theta_r=th_r, theta_t=th_t, share=share)
    return SlotOptimum(value, value, (share * c_r, (1 - share) * c_t), "closed form (TDMA)", setting)


def _sum_rate(ch: StarChannels, surface: StarSurface) -> SlotOptimum:
    """Sum rate, one setting: the whole surface and all power to the better side (closed form)."""
    best = max(("r", "t"), key=lambda s: _full(ch, surface, s)[0])
    amp, u, theta = _full(ch, surface, best)
    zero = np.zeros(ch.M)
    if surface.protocol == "fixed":  # both sides carry their fixed amplitude, phases shared
        u_r, u_t, th_r, th_t = np.full(ch.M, ch.fixed_r), np.full(ch.M, ch.fixed_t), theta, theta
    elif best == "r":
        u_r, u_t, th_r, th_t = u, zero, theta, theta
    else:
        u_r, u_t, th_r, th_t = zero, u, theta, theta
    rate = _rate(ch, amp)
    split = 1.0 if best == "r" else 0.0
    rates = (rate, 0.0) if best == "r" else (0.0, rate)
    # as a TS setting: the better side's period for the whole slot, all power to its user
    ts = dict(lam=float(best == "t"), split_reflect=1.0, split_transmit=0.0)
    setting = dict(u_r=u_r, u_t=u_t, theta_r=th_r, theta_t=th_t, split=split, **ts)
    return SlotOptimum(rate, rate, rates, "closed form (sum rate: the better side)", setting)


def _f(ch: StarChannels, amp_r: np.ndarray, amp_t: np.ndarray) -> np.ndarray:
    return noma_maxmin(ch.eta * np.square(amp_r), ch.eta * np.square(amp_t))[0]


def _frontier(ch: StarChannels, w: float) -> tuple[float, float, np.ndarray, np.ndarray]:
    """The ES frontier point of weight w: per element u = ((1-w) a^r, w a^t) / norm."""
    x, y = (1 - w) * ch.a_r, w * ch.a_t
    norm = np.hypot(x, y)
    safe = np.where(norm > 0, norm, 1.0)
    u_r, u_t = np.where(norm > 0, x / safe, 1.0), y / safe
    return ch.direct_r + float(ch.a_r @ u_r), ch.direct_t + float(ch.a_t @ u_t), u_r, u_t


def es_frontier_bb(ch: StarChannels, tol: float = DEFAULT_TOL) -> tuple[float, float, float]:
    """Branch and bound on the ES frontier weight (module docstring): (value, upper, w*)."""
    pts = {w: _frontier(ch, w)[:2] for w in (0.0, 1.0)}
    best_w = max(pts, key=lambda w: float(_f(ch, *pts[w])))
    lower = float(_f(ch, *pts[best_w]))
    heap = [(-float(_f(ch, pts[0.0][0], pts[1.0][1])), 0.0, 1.0)]
    for _ in range(_MAX_NODES):
        bound, w1, w2 = heap[0]
        if -bound - lower <= tol * max(lower, 1e-300):
            break
        heapq.heappop(heap)
        mid = 0.5 * (w1 + w2)
        pts[mid] = _frontier(ch, mid)[:2]
        value = float(_f(ch, *pts[mid]))
        if value > lower:
            lower, best_w = value, mid
        for a, b in ((w1, mid), (mid, w2)):
            heapq.heappush(heap, (-float(_f(ch, pts[a][0], pts[b][1])), a, b))
    return lower, max(lower, -heap[0][0]), best_w


def _noma_setting(ch: StarChannels, amp_r: float, amp_t: float, **setting: np.ndarray) -> tuple:
    g_r, g_t = ch.eta * amp_r * amp_r, ch.eta * amp_t * amp_t
    value, split = noma_maxmin(g_r, g_t)
    rates = noma_rates(g_r, g_t, split)
    return float(value), (float(rates[0]), float(rates[1])), dict(setting, split=float(split))


def _discrete_sides(ch: StarChannels, bits: int, u_r: np.ndarray, u_t: np.ndarray) -> tuple:
    amp_r, th_r = _side(ch, "r", u_r, bits)
    amp_t, th_t = _side(ch, "t", u_t, bits)
    return amp_r, amp_t, th_r, th_t


def _es_independent(ch: StarChannels, surface: StarSurface, tol: float) -> SlotOptimum:
    value, upper, w = es_frontier_bb(ch, tol)
    amp_r, amp_t, u_r, u_t = _frontier(ch, w)
    th_r, th_t = ch.phi_r.copy(), ch.phi_t.copy()
    method = "branch and bound on the ES frontier"
    if surface.bits is not None:
        amp_r, amp_t, th_r, th_t = _discrete_sides(ch, surface.bits, u_r, u_t)
        method += f", each side's exact {surface.bits}-bit phases (bound: continuous)"
    value, rates, setting = _noma_setting(ch, amp_r, amp_t, u_r=u_r, u_t=u_t, theta_r=th_r, theta_t=th_t)
    return SlotOptimum(value, max(upper, value), rates, method, setting)


def _ms(ch: StarChannels, surface: StarSurface) -> SlotOptimum:
    order = np.argsort(-(ch.a_t / np.where(ch.a_r > 0, ch.a_r, 1e-300)), kind="stable")
    amp_t = ch.direct_t + np.concatenate([[0.0], np.cumsum(ch.a_t[order])])
    amp_r = ch.direct_r + ch.a_r.sum() - np.concatenate([[0.0], np.cumsum(ch.a_r[order])])
    values = _f(ch, amp_r, amp_t)
    upper = float(max(values.max(), _f(ch, amp_r[:-1], amp_t[1:]).max()))
    candidates = [int(np.argmax(values))]
    method = "best threshold setting; bound: the hull's polyline"
    if surface.bits is not None:
        candidates = [int(k) for k in np.argsort(-values)[:5]]
        method += f", each side's exact {surface.bits}-bit phases"
    best = None
    for k in candidates:
        u_t = np.zeros(ch.M)
        u_t[order[:k]] = 1.0
        u_r = 1.0 - u_t
        if surface.bits is None:
            a_r, a_t, th_r, th_t = amp_r[k], amp_t[k], ch.phi_r.copy(), ch.phi_t.copy()
        else:
            a_r, a_t, th_r, th_t = _discrete_sides(ch, surface.bits, u_r, u_t)
        out = _noma_setting(ch, a_r, a_t, u_r=u_r, u_t=u_t, theta_r=th_r, theta_t=th_t)
        if best is None or out[0] > best[0]:
            best = out
    return SlotOptimum(best[0], max(upper, best[0]), best[1], method, best[2])


def _weighted_noma(g_r: float, g_t: float, w: float) -> tuple[float, float, float, float]:
    """max over the split of w R_r + (1 - w) R_t for SNRs (g_r, g_t): (value, R_r, R_t, split).
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


def _ts_noma(ch: StarChannels, surface: StarSurface) -> SlotOptimum:
    full_r, _, th_r = _full(ch, surface, "r")
    full_t, _, th_t = _full(ch, surface, "t")
    return _ts_amplitudes(ch, full_r, full_t, th_r, th_t)


def _ts_amplitudes(
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
            value, r_r, r_t, split = _weighted_noma(*g, w)
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


def _mm(
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


def _joint_phases(ch: StarChannels, surface: StarSurface, tol: float) -> SlotOptimum:
    if surface.protocol == "fixed":
        u_r0, u_t0 = np.full(ch.M, ch.fixed_r), np.full(ch.M, ch.fixed_t)
        upper = float(_f(ch, ch.direct_r + float(ch.a_r @ u_r0), ch.direct_t + float(ch.a_t @ u_t0)))
        weights = _MM_WEIGHTS
    else:
        _, upper, w_star = es_frontier_bb(ch, tol)
        weights = np.unique(np.concatenate([_MM_WEIGHTS, [w_star]]))
    best = None
    for w in weights:
        if surface.protocol != "fixed":
            _, _, u_r0, u_t0 = _frontier(ch, float(w))
        amp_r, amp_t, setting = _mm(ch, surface, 1 - w, w, u_r0.copy(), u_t0.copy())
        out = _noma_setting(ch, amp_r, amp_t, **setting)
        if best is None or out[0] > best[0]:
            best = out
    method = f"{surface.phases} phases by minorise-maximise; bound: independent continuous phases"
    return SlotOptimum(best[0], max(upper, best[0]), best[1], method, best[2])


def slot_optimum(
    ch: StarChannels,
    surface: StarSurface,
    access: str = "noma",
    objective: str = "maxmin",
    tol: float = DEFAULT_TOL,
) -> SlotOptimum:
    """The slot's optimum for ``surface`` at the channels ``ch``: value, certified upper bound and
    the setting (see the module docstring for each case and its derivation)."""
    _check(access, objective, tol)
    if access == "tdma":
        return _tdma(ch, surface, objective)
    if objective == "sum":
        return _sum_rate(ch, surface)
    if surface.protocol == "ts":
        return _ts_noma(ch, surface)
    if surface.protocol == "ms":
        return _ms(ch, surface)
    if surface.protocol == "es" and surface.phases == "independent":
        return _es_independent(ch, surface, tol)
    return _joint_phases(ch, surface, tol)


def evaluate(ch: StarChannels, surface: StarSurface, access: str, setting: dict) -> tuple[float, float]:
    """Rates (R_r, R_t) of a ``setting`` (as :attr:`SlotOptimum.setting`), checked against the
    surface (``star.check_setting``): TDMA (``u_*``, ``theta_*``, ``share``: each user served by its
    side's part), TS with NOMA (``theta_*``, ``lam``, ``split_reflect``, ``split_transmit``) or one
    NOMA setting (``u_*``, ``theta_*``, ``split``)."""
    if access not in ACCESS:
        raise ValueError(f"access must be one of {ACCESS}, got {access!r}")
    theta_r, theta_t = setting["theta_r"], setting["theta_t"]
    if surface.protocol == "ts" and access == "noma":
        ones, zeros = np.ones(ch.M), np.zeros(ch.M)
        check_setting(surface, ones, zeros, theta_r, theta_r)
        check_setting(surface, zeros, ones, theta_t, theta_t)
        amp_r = side_amplitude(ch.a_r, ch.phi_r, ch.direct_r, theta_r)
        amp_t = side_amplitude(ch.a_t, ch.phi_t, ch.direct_t, theta_t)
        reflect = (ch.eta * amp_r**2, ch.eta * ch.direct_t**2)
        transmit = (ch.eta * ch.direct_r**2, ch.eta * amp_t**2)
        return ts_rates(
            reflect, transmit, setting["lam"], setting["split_reflect"], setting["split_transmit"]
        )
    u_r, u_t = setting["u_r"], setting["u_t"]
    check_setting(
        surface, u_r, u_t, theta_r, theta_t, (ch.fixed_r, ch.fixed_t), simultaneous=access == "noma"
    )
    amp_r = side_amplitude(u_r * ch.a_r, ch.phi_r, ch.direct_r, theta_r)
    amp_t = side_amplitude(u_t * ch.a_t, ch.phi_t, ch.direct_t, theta_t)
    if access == "tdma":
        return tdma_rates(_rate(ch, amp_r), _rate(ch, amp_t), setting["share"])
    rates = noma_rates(ch.eta * amp_r**2, ch.eta * amp_t**2, setting["split"])
    return float(rates[0]), float(rates[1])


def random_phase_value(
    ch: StarChannels, surface: StarSurface, access: str, objective: str, rng: np.random.Generator
) -> float:
    """A reference row: the optimum's setting with its phases redrawn uniformly (on the b-bit grid
    if ``surface.bits``; theta^t = theta^r, or + pi/2, as the phase model asks), the power split,
    share or time split then chosen best for them."""
    opt = slot_optimum(ch, surface, access, objective)
    theta_r = quantise(rng.uniform(0, 2 * np.pi, ch.M), surface.bits)
    offset = {"independent": None, "shared": 0.0, "coupled": np.pi / 2}[surface.phases]
    theta_t = quantise(rng.uniform(0, 2 * np.pi, ch.M), surface.bits) if offset is None else theta_r + offset
    one_side = access == "tdma" or surface.protocol == "ts"
    u_r = np.full(ch.M, ch.fixed_r) if surface.protocol == "fixed" else opt.setting.get("u_r", np.ones(ch.M))
    u_t = np.full(ch.M, ch.fixed_t) if surface.protocol == "fixed" else opt.setting.get("u_t", np.ones(ch.M))
    if one_side and surface.protocol != "fixed":
        u_r, u_t = np.ones(ch.M), np.ones(ch.M)
    amp_r = side_amplitude(u_r * ch.a_r, ch.phi_r, ch.direct_r, theta_r)
    amp_t = side_amplitude(u_t * ch.a_t, ch.phi_t, ch.direct_t, theta_t)
    if objective == "sum":
        return max(_rate(ch, amp_r), _rate(ch, amp_t))
    if access == "tdma":
        return tdma_maxmin(_rate(ch, amp_r), _rate(ch, amp_t))[0]
    if surface.protocol == "ts":
        return _ts_amplitudes(ch, amp_r, amp_t, theta_r, theta_t).value
    return float(_f(ch, amp_r, amp_t))
