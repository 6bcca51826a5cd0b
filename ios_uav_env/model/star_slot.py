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

**TS with NOMA, coupled or shared phases under NOMA, b-bit phases:** see
``ios_uav_env.model.star_frontier``, which also holds the methods above.
"""

from __future__ import annotations

import numpy as np

from ios_uav_env.model.star import (
    ACCESS,
    OBJECTIVES,
    StarChannels,
    StarSurface,
    check_setting,
    noma_rates,
    quantise,
    side_amplitude,
    tdma_maxmin,
    ts_rates,
)
from ios_uav_env.model.star_frontier import (
    DEFAULT_TOL,
    SlotOptimum,
    coordinate_search,
    discrete_sides,
    es_frontier_bb,
    frontier_point,
    full_side,
    joint_phases,
    maxmin_of,
    noma_setting,
    rate_of,
    setting_value,
    ts_amplitudes,
    ts_noma,
)
from ios_uav_env.model.star_rows import (
    StarRows,
    rates_of,
    side_amplitudes,
    tdma_maxmin_rows,
    tdma_rates_rows,
    tdma_sides,
)

__all__ = [
    "DEFAULT_TOL", "SlotOptimum", "evaluate", "evaluate_rows", "random_phase_value", "slot_optima",
    "slot_optimum",
]  # fmt: skip


def _check(access: str, objective: str, tol: float) -> None:
    if access not in ACCESS:
        raise ValueError(f"access must be one of {ACCESS}, got {access!r}")
    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {OBJECTIVES}, got {objective!r}")
    if not (isinstance(tol, float | int) and 0 < tol < 1):
        raise ValueError(f"tol must be a number in (0, 1), got {tol!r}")


def _tdma(ch: StarChannels, surface: StarSurface, objective: str) -> SlotOptimum:
    amp_r, u_r, th_r, amp_t, u_t, th_t = (
        v[0] for v in tdma_sides(StarRows.of([ch]), surface.protocol, surface.bits)
    )
    c_r, c_t = float(rates_of(ch.eta, amp_r)), float(rates_of(ch.eta, amp_t))
    if objective == "maxmin":
        value, share = tdma_maxmin(c_r, c_t)
    else:
        value, share = max(c_r, c_t), float(c_r >= c_t)
    setting = dict(u_r=u_r, u_t=u_t, theta_r=th_r, theta_t=th_t, share=share)
    return SlotOptimum(value, value, (share * c_r, (1 - share) * c_t), "closed form (TDMA)", setting)


def _sum_rate(ch: StarChannels, surface: StarSurface) -> SlotOptimum:
    """Sum rate, one setting: the whole surface and all power to the better side (closed form)."""
    best = max(("r", "t"), key=lambda s: full_side(ch, surface, s)[0])
    amp, u, theta = full_side(ch, surface, best)
    zero = np.zeros(ch.M)
    if surface.protocol == "fixed":  # both sides carry their fixed amplitude, phases shared
        u_r, u_t, th_r, th_t = np.full(ch.M, ch.fixed_r), np.full(ch.M, ch.fixed_t), theta, theta
    elif best == "r":
        u_r, u_t, th_r, th_t = u, zero, theta, theta
    else:
        u_r, u_t, th_r, th_t = zero, u, theta, theta
    rate = rate_of(ch, amp)
    split = 1.0 if best == "r" else 0.0
    rates = (rate, 0.0) if best == "r" else (0.0, rate)
    # as a TS setting: the better side's period for the whole slot, all power to its user
    ts = dict(lam=float(best == "t"), split_reflect=1.0, split_transmit=0.0)
    setting = dict(u_r=u_r, u_t=u_t, theta_r=th_r, theta_t=th_t, split=split, **ts)
    return SlotOptimum(rate, rate, rates, "closed form (sum rate: the better side)", setting)


def _es_independent(ch: StarChannels, surface: StarSurface, tol: float) -> SlotOptimum:
    value, upper, w = es_frontier_bb(ch, tol)
    amp_r, amp_t, u_r, u_t = frontier_point(ch, w)
    th_r, th_t = ch.phi_r.copy(), ch.phi_t.copy()
    method = "branch and bound on the ES frontier"
    if surface.bits is not None:
        amp_r, amp_t, th_r, th_t = discrete_sides(ch, surface.bits, u_r, u_t)
        method += f", each side's exact {surface.bits}-bit phases (bound: continuous)"
    value, rates, setting = noma_setting(ch, amp_r, amp_t, u_r=u_r, u_t=u_t, theta_r=th_r, theta_t=th_t)
    if surface.bits is not None:
        polished = setting_value(ch, coordinate_search(ch, surface, setting))
        if polished[0] > value:
            value, rates, setting = polished
            method += " and a coordinate search"
    return SlotOptimum(value, max(upper, value), rates, method, setting)


def _ms(ch: StarChannels, surface: StarSurface) -> SlotOptimum:
    order = np.argsort(-(ch.a_t / np.where(ch.a_r > 0, ch.a_r, 1e-300)), kind="stable")
    amp_t = ch.direct_t + np.concatenate([[0.0], np.cumsum(ch.a_t[order])])
    amp_r = ch.direct_r + ch.a_r.sum() - np.concatenate([[0.0], np.cumsum(ch.a_r[order])])
    values = maxmin_of(ch, amp_r, amp_t)
    upper = float(max(values.max(), maxmin_of(ch, amp_r[:-1], amp_t[1:]).max()))
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
            a_r, a_t, th_r, th_t = discrete_sides(ch, surface.bits, u_r, u_t)
        out = noma_setting(ch, a_r, a_t, u_r=u_r, u_t=u_t, theta_r=th_r, theta_t=th_t)
        if best is None or out[0] > best[0]:
            best = out
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
        return ts_noma(ch, surface)
    if surface.protocol == "ms":
        return _ms(ch, surface)
    if surface.protocol == "es" and surface.phases == "independent":
        return _es_independent(ch, surface, tol)
    return joint_phases(ch, surface, tol)


def evaluate(ch: StarChannels, surface: StarSurface, access: str, setting: dict) -> tuple[float, float]:
    """Rates (R_r, R_t) of a ``setting`` (as :attr:`SlotOptimum.setting`), checked against the
    surface (``star.check_setting``): TDMA (``u_*``, ``theta_*``, ``share``: each user served by its
    side's part), TS with NOMA (``theta_*``, ``lam``, ``split_reflect``, ``split_transmit``) or one
    NOMA setting (``u_*``, ``theta_*``, ``split``). Other than TS with NOMA, :func:`evaluate_rows`
    on one row."""
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
    key = "share" if access == "tdma" else "split"
    one = {name: np.asarray(setting[name], dtype=np.float64)[None] for name in (*_SETTING, key)}
    rate_r, rate_t = _rates(StarRows.of([ch]), access, one)
    return float(rate_r[0]), float(rate_t[0])


#: The element arrays of a setting (besides its share or split).
_SETTING = ("u_r", "u_t", "theta_r", "theta_t")


def _rates(rows: StarRows, access: str, setting: dict) -> tuple[np.ndarray, np.ndarray]:
    """(R_r, R_t) per row of a checked setting (TDMA: ``share``; NOMA: ``split``)."""
    amp_r = side_amplitudes(setting["u_r"] * rows.a_r, rows.phi_r, rows.direct_r, setting["theta_r"])
    amp_t = side_amplitudes(setting["u_t"] * rows.a_t, rows.phi_t, rows.direct_t, setting["theta_t"])
    if access == "tdma":
        return tdma_rates_rows(rates_of(rows.eta, amp_r), rates_of(rows.eta, amp_t), setting["share"])
    return noma_rates(rows.eta * amp_r**2, rows.eta * amp_t**2, setting["split"])


def evaluate_rows(
    rows: StarRows, surface: StarSurface, access: str, setting: dict
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`evaluate` of one setting per row, as arrays: ``setting``'s ``u_*`` and ``theta_*``
    with shape (..., M), its ``share`` (TDMA) or ``split`` (NOMA) with shape (...), checked
    against the surface as :func:`evaluate` checks one (any bad row refuses the whole call).
    Row i of the result is :func:`evaluate` of row i, bit for bit. Not for TS with NOMA."""
    if access not in ACCESS:
        raise ValueError(f"access must be one of {ACCESS}, got {access!r}")
    if surface.protocol == "ts" and access == "noma":
        raise ValueError("protocol 'ts' with access 'noma' is evaluated slot by slot (evaluate), not by rows")
    key = "share" if access == "tdma" else "split"
    arrays = {name: np.asarray(setting[name], dtype=np.float64) for name in (*_SETTING, key)}
    fixed = (rows.fixed_r[..., None], rows.fixed_t[..., None])
    check_setting(surface, *(arrays[name] for name in _SETTING), fixed, simultaneous=access == "noma")
    return _rates(rows, access, arrays)


def slot_optima(
    rows: StarRows,
    surface: StarSurface,
    access: str = "noma",
    objective: str = "maxmin",
    tol: float = DEFAULT_TOL,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`slot_optimum`'s value and upper bound of every row, as arrays (shape: the rows').
    TDMA (closed form) is computed over the rows at once, and row i is :func:`slot_optimum` of
    row i bit for bit; the other cases run :func:`slot_optimum` row by row."""
    _check(access, objective, tol)
    shape = rows.direct_r.shape
    if access == "tdma":
        amp_r, _, _, amp_t, _, _ = tdma_sides(rows, surface.protocol, surface.bits)
        c_r, c_t = rates_of(rows.eta, amp_r), rates_of(rows.eta, amp_t)
        value = tdma_maxmin_rows(c_r, c_t)[0] if objective == "maxmin" else np.maximum(c_r, c_t)
        return value, value.copy()
    value, upper = np.zeros(shape), np.zeros(shape)
    for index in np.ndindex(shape):
        part = rows.take(index)
        fields = {name: getattr(part, name) for name in ("a_r", "a_t", "phi_r", "phi_t")}
        scalars = {
            name: float(getattr(part, name)) for name in ("direct_r", "direct_t", "eta", "fixed_r", "fixed_t")
        }
        best = slot_optimum(StarChannels(**fields, **scalars), surface, access, objective, tol)
        value[index], upper[index] = best.value, best.upper
    return value, upper


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
        return max(rate_of(ch, amp_r), rate_of(ch, amp_t))
    if access == "tdma":
        return tdma_maxmin(rate_of(ch, amp_r), rate_of(ch, amp_t))[0]
    if surface.protocol == "ts":
        return ts_amplitudes(ch, amp_r, amp_t, theta_r, theta_t).value
    return float(maxmin_of(ch, amp_r, amp_t))
