r"""The propulsion model's terms and the lower bounds of the power and of the move costs.

The move costs C(g, w, b) of :mod:`baselines.energy_bound.relaxation` (J) and the 1-D bounds of
P(V) - s V (W) that make them; the package docstring (``baselines.energy_bound``) says how they
enter the certified bound.

**The move cost** C(g, w, b) (:func:`move_cost_lower_bound`). For m in a box, r = |m| lies in
[r_lo, r_hi] (the box's least and greatest norms, r_hi <= D) and b . m <= |b| r c_max, with c_max
the largest cosine between b and a point of the box (1 when the ray along b meets the box; else
at a corner). So f(m) - b . m >= dt min over V in [r_lo, r_hi] / dt of P(V) - |b| c_max V, a
one-dimensional problem (:func:`tilted_power_lower_bound`): with P = A + I, A(V) = P0 (1 + 3 V^2
/ U_tip^2) + c V^3 convex and I(V) = P_i y(V) non-increasing, on a piece [l, r] of the interval
P(V) - s V >= min_{[l, r]} (A(V) - s V) + I(r), the first term exact (A' = s is a quadratic
equation). Both searches are branch and bound: pieces (of the speed interval; sub-boxes of the
box, for b != 0) whose bound exceeds the value of the function at a sampled point cannot hold
the minimum and are dropped, the others are split, down to ``SPEED_TOL`` and a sixteenth of the
box; the least bound left is returned (the piece of the minimiser is never dropped). Valid
whatever the shape of P; the sub-boxes make the angular decoupling of second order.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

import ios_uav_env as ie
from ios_uav_env import ScenarioConfig

#: Branch and bound of the 1-D power problems: pieces are split until narrower than this (m/s).
SPEED_TOL = 1e-4
#: Absolute slack (a fraction of P(0) dt, J) taken off every move cost (rounding).
COST_SLACK = 1e-12


# --- the propulsion model's terms -----------------------------------------------------------------


def propulsion_coefficients(model: Any) -> dict[str, float]:
    """The constants of P(V) by term: ``p0`` (W, blade profile P0), ``pi`` (W, induced power in
    hover P_i), ``u_tip`` (m/s, rotor tip speed), ``v0`` (m/s, mean induced velocity in hover),
    ``c3`` (kg/m, d0 rho s A / 2), read from ``model`` (an ``ios_uav_env.PropulsionModel``).

    The planners that need P(V) term by term use these; :func:`check_terms` checks that the
    terms add up to ``ios_uav_env.propulsion_power``."""
    return {
        "p0": float(model.P0),
        "pi": float(model.P_i),
        "u_tip": float(model.U_tip),
        "v0": float(model.v0),
        "c3": float(model.drag_coefficient),
    }


def induced_ratio(speed: Any, v0: float) -> np.ndarray:
    """y(V) = (sqrt(1 + V^4 / (4 v0^4)) - V^2 / (2 v0^2))^(1/2), written without cancellation as
    y^2 = 1 / (sqrt(1 + V^4 / (4 v0^4)) + V^2 / (2 v0^2)) (the two factors' product is 1)."""
    h = 0.5 * (np.asarray(speed, dtype=float) / v0) ** 2
    return 1.0 / np.sqrt(np.sqrt(1.0 + h * h) + h)


def _convex(v: np.ndarray, k: dict[str, float]) -> np.ndarray:
    """A(V): blade profile + parasite power (W), convex and non-decreasing in V >= 0."""
    return k["p0"] * (1.0 + 3.0 * v * v / k["u_tip"] ** 2) + k["c3"] * v * v * v


def _induced(v: np.ndarray, k: dict[str, float]) -> np.ndarray:
    """I(V): induced power (W), non-increasing in V >= 0."""
    return k["pi"] * induced_ratio(v, k["v0"])


def terms_power(speed: Any, coefficients: dict[str, float]) -> np.ndarray:
    """P(V) = A(V) + I(V) (W) from :func:`propulsion_coefficients`' terms."""
    v = np.asarray(speed, dtype=float)
    return _convex(v, coefficients) + _induced(v, coefficients)


def power_slope(speed: Any, coefficients: dict[str, float]) -> np.ndarray:
    """P'(V) (W s/m) from the terms: A'(V) = 6 P0 V / U_tip^2 + 3 c V^2 and, with
    x = V^2 / (2 v0^2) and y = (sqrt(1 + x^2) + x)^(-1/2), I'(V) = -P_i y^3 (1 + x / sqrt(1 + x^2))
    V / (2 v0^2)."""
    k = coefficients
    v = np.asarray(speed, dtype=float)
    x = v * v / (2.0 * k["v0"] ** 2)
    y = 1.0 / np.sqrt(np.sqrt(1.0 + x * x) + x)
    d_induced = -k["pi"] * y**3 * (1.0 + x / np.sqrt(1.0 + x * x)) * v / (2.0 * k["v0"] ** 2)
    return 6.0 * k["p0"] * v / k["u_tip"] ** 2 + 3.0 * k["c3"] * v * v + d_induced


def check_terms(config: ScenarioConfig, rel: float = 1e-9) -> dict[str, float]:
    """:func:`propulsion_coefficients` of ``config.propulsion``, after checking that their terms
    give ``ios_uav_env.propulsion_power`` (to ``rel``) on [0, 2 v_max]: ``RuntimeError`` if
    the model's P(V) is not the one written term by term here."""
    k = propulsion_coefficients(config.propulsion)
    speeds = np.linspace(0.0, 2.0 * config.v_max, 65)
    exact = np.asarray(ie.propulsion_power(speeds, config.propulsion), dtype=float)
    if not np.allclose(terms_power(speeds, k), exact, rtol=rel, atol=0.0):
        raise RuntimeError(
            "P(V) by terms differs from ios_uav_env.propulsion_power: update "
            "baselines.energy_bound.propulsion_coefficients to the model"
        )
    return k


# --- the 1-D and 2-D lower bounds -----------------------------------------------------------------


def _tilted_convex_min(lo: np.ndarray, hi: np.ndarray, s: np.ndarray, k: dict[str, float]) -> np.ndarray:
    """min over [lo, hi] of A(V) - s V (A convex): at the root of A'(V) = s clipped to [lo, hi]."""
    a, c = 6.0 * k["p0"] / k["u_tip"] ** 2, 3.0 * k["c3"]  # A'(V) = a V + c V^2
    root = np.where(
        s > 0, 2.0 * np.maximum(s, 0.0) / (a + np.sqrt(a * a + 4.0 * c * np.maximum(s, 0.0))), 0.0
    )
    v = np.clip(root, lo, hi)
    return _convex(v, k) - s * v


def convex_from(coefficients: dict[str, float]) -> float:
    """V_c = v0 (4/3)^(1/4) (m/s): the induced power I(V) = P_i y(V) is convex on [V_c, inf).

    With x = V^2 / (2 v0^2), s = sqrt(1 + x^2) and g = s + x, y = g^(-1/2), y'(x) = -g^(-1/2) / (2 s)
    and y''(x) = (3/4) g^(-1/2) / s^2 - (1/2) g^(-3/2) / s^3, so I''(V) = (P_i / v0^2) (2 x y''(x) +
    y'(x)) has the sign of x s + x^2 - 1 = x g - 1 (use 1 / g = s - x), which is increasing in x
    and 0 at x = 1 / sqrt(3)."""
    return coefficients["v0"] * (4.0 / 3.0) ** 0.25


def _convex_part_bound(lo: np.ndarray, hi: np.ndarray, s: np.ndarray, k: dict[str, float]) -> np.ndarray:
    """min over [lo, hi] (inside [V_c, inf), where P(V) - s V is convex) of P(V) - s V, bounded
    below by the tangent at t, the root of the derivative found by bisection (or an end):
    phi(V) >= phi(t) + phi'(t) (V - t) >= phi(t) + min(phi'(t) (lo - t), phi'(t) (hi - t))."""
    a, b = lo.copy(), hi.copy()
    for _ in range(64):  # bisection on the non-decreasing derivative
        mid = 0.5 * (a + b)
        up = power_slope(mid, k) - s > 0
        b = np.where(up, mid, b)
        a = np.where(up, a, mid)
    t = np.clip(0.5 * (a + b), lo, hi)
    d = power_slope(t, k) - s
    return terms_power(t, k) - s * t + np.minimum(d * (lo - t), d * (hi - t))


def tilted_power_lower_bound(
    config: ScenarioConfig, v_lo: Any, v_hi: Any, slope: Any = 0.0, pieces: int = 16, tol: float = SPEED_TOL
) -> np.ndarray:
    """A lower bound (W) of min over V in [v_lo, v_hi] of P(V) - slope V, per broadcast element
    (speeds in m/s, 0 <= v_lo <= v_hi; slope in W s/m, any sign). On [V_c, inf)
    (:func:`convex_from`) the function is convex: a tangent at the minimiser bounds it. Below
    V_c, branch and bound over pieces, within about |I'| ``tol`` of the minimum (module
    docstring, "The move cost"); ``tol`` = inf: one pass over ``pieces`` pieces there."""
    k = check_terms(config)
    lo, hi, s = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (v_lo, v_hi, slope)))
    shape = lo.shape
    lo, hi, s = lo.ravel(), hi.ravel(), s.ravel()
    if np.any(~np.isfinite(lo) | ~np.isfinite(hi) | ~np.isfinite(s) | (lo < 0) | (hi < lo)):
        raise ValueError("speed intervals must be finite with 0 <= v_lo <= v_hi (m/s), slopes finite")
    m = lo.size
    out = np.full(m, np.inf)
    if m == 0:
        return out.reshape(shape)
    vc = convex_from(k)
    upper_part = hi >= vc
    if np.any(upper_part):
        a = np.maximum(lo[upper_part], vc)
        out[upper_part] = _convex_part_bound(a, hi[upper_part], s[upper_part], k)
    lower_part = np.flatnonzero(lo < vc)
    if len(lower_part):
        out[lower_part] = np.minimum(
            out[lower_part],
            _piecewise_bound(
                lo[lower_part], np.minimum(hi[lower_part], vc), s[lower_part], k, pieces, tol
            ),  # fmt: skip
        )
    return out.reshape(shape)


def _piecewise_bound(
    lo: np.ndarray, hi: np.ndarray, s: np.ndarray, k: dict[str, float], pieces: int, tol: float
) -> np.ndarray:
    """Branch and bound of min over [lo, hi] of P(V) - s V with the piece bound
    min_{[l, r]} (A(V) - s V) + I(r) (module docstring)."""
    m = lo.size

    def tilted(v: np.ndarray, ids: np.ndarray) -> np.ndarray:
        return terms_power(v, k) - s[ids] * v

    all_ids = np.arange(m)
    upper = np.minimum(tilted(lo, all_ids), tilted(hi, all_ids))  # sampled values: >= the minimum
    ids = np.repeat(all_ids, pieces)
    t = np.arange(pieces + 1) / pieces
    edges = lo[:, None] + (hi - lo)[:, None] * t
    left, right = edges[:, :-1].ravel(), edges[:, 1:].ravel()
    while True:
        bound = _tilted_convex_min(left, right, s[ids], k) + _induced(right, k)
        np.minimum.at(upper, ids, tilted(0.5 * (left + right), ids))
        # a dropped piece's bound exceeds a sampled value: no minimum there (the margin keeps the
        # minimiser's piece when its bound and a sample there agree up to rounding)
        keep = bound <= upper[ids] + 1e-12 * (np.abs(upper[ids]) + 1.0)
        ids, left, right, bound = ids[keep], left[keep], right[keep], bound[keep]
        wide = (right - left) > tol
        if not np.any(wide):
            break
        split = 8
        w_ids, w_l, w_r = ids[wide], left[wide], right[wide]
        e = w_l[:, None] + (w_r - w_l)[:, None] * (np.arange(split + 1) / split)
        ids = np.concatenate([ids[~wide], np.repeat(w_ids, split)])
        left = np.concatenate([left[~wide], e[:, :-1].ravel()])
        right = np.concatenate([right[~wide], e[:, 1:].ravel()])
    out = np.full(m, np.inf)
    np.minimum.at(out, ids, bound)
    return out


def _max_cosine(lo: np.ndarray, hi: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The largest cos(angle(m, u)) over the boxes [lo, hi] (rows; u unit vectors): 1 where a
    box holds the origin or the ray along u meets it, else at one of its corners (the box's
    directions form an arc whose ends are corners)."""
    inside = (lo <= 0) & (hi >= 0)  # per axis: the origin's coordinate lies in the slab
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = lo / u, hi / u
    t_near = np.where(u != 0, np.minimum(t1, t2), np.where(inside, -np.inf, np.inf))
    t_far = np.where(u != 0, np.maximum(t1, t2), np.where(inside, np.inf, -np.inf))
    enter, leave = t_near.max(axis=1), t_far.min(axis=1)
    hits = np.all(inside, axis=1) | ((enter <= leave) & (leave >= 0))
    corners = np.stack([np.column_stack([x[:, 0], y[:, 1]]) for x in (lo, hi) for y in (lo, hi)], axis=1)
    norms = np.linalg.norm(corners, axis=2)
    cos = np.einsum("mcj,mj->mc", corners, u) / np.where(norms > 0, norms, 1.0)
    return np.where(hits, 1.0, np.where(norms > 0, cos, 1.0).max(axis=1))


def _norm_range(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least and greatest |m| over the boxes [lo, hi] (rows)."""
    near = np.hypot(
        np.maximum(0.0, np.maximum(lo[:, 0], -hi[:, 0])), np.maximum(0.0, np.maximum(lo[:, 1], -hi[:, 1]))
    )
    far = np.hypot(
        np.maximum(np.abs(lo[:, 0]), np.abs(hi[:, 0])), np.maximum(np.abs(lo[:, 1]), np.abs(hi[:, 1]))
    )
    return near, far


def _sector_bound(
    config: ScenarioConfig, lo: np.ndarray, hi: np.ndarray, b: np.ndarray, coarse: bool = False
) -> np.ndarray:
    """A lower bound (J) of min over m in the box [lo, hi] with |m| <= D of f(m) - b . m, per
    row (inf where the box and the disk do not meet): r = |m| in [r_lo, r_hi], b . m <= |b| r
    c_max, then the 1-D bound of P(V) - |b| c_max V (module docstring, "The move cost");
    ``coarse``: the 1-D bound in one pass over 4 pieces (weaker, cheap: for pruning)."""
    d, dt = config.D, config.dt
    near, far = _norm_range(lo, hi)
    ok = near <= d * (1.0 + 1e-12)
    out = np.full(lo.shape[0], np.inf)
    if not np.any(ok):
        return out
    bn = np.linalg.norm(b, axis=1)
    cmax = np.zeros(lo.shape[0])
    moving = ok & (bn > 0)
    if np.any(moving):
        cmax[moving] = _max_cosine(lo[moving], hi[moving], b[moving] / bn[moving, None])
    r_lo = np.minimum(near, d)
    r_hi = np.maximum(np.minimum(far, d), r_lo)
    problems = np.column_stack([r_lo, r_hi, bn * cmax])[ok]
    uniq, inverse = np.unique(problems, axis=0, return_inverse=True)  # shared 1-D problems once
    options = {"pieces": 4, "tol": math.inf} if coarse else {}
    low = tilted_power_lower_bound(config, uniq[:, 0] / dt, uniq[:, 1] / dt, uniq[:, 2], **options)
    out[ok] = dt * low[inverse.ravel()]
    return out


def move_cost_lower_bound(
    config: ScenarioConfig, g: Any, half: Any, b: Any, min_size: float | None = None
) -> np.ndarray:
    """A lower bound (J) of C(g, b) = min over m in the box g + [-half, half]^2 with |m| <= D
    of f(m) - b . (m - g), f(m) = dt P(|m| / dt), per row: ``g`` (M, 2) m, ``half`` (M,) or a
    number (m), ``b`` (M, 2) J/m. ``inf`` where the box holds no m with |m| <= D.

    b = 0: the radial 1-D bound over the box's norms. Otherwise branch and bound over
    sub-boxes with :func:`_sector_bound` (first order in a sub-box's size only through its
    angular width, so small sub-boxes are tight): a sub-box whose bound exceeds f - b . m at
    some sampled point of the same box is dropped, the rest are split in four down to
    ``min_size`` (m, default half / 16); the least bound left is returned (module docstring)."""
    g = np.atleast_2d(np.asarray(g, dtype=float))
    b = np.ascontiguousarray(np.broadcast_to(np.asarray(b, dtype=float), g.shape))
    w = np.broadcast_to(np.asarray(half, dtype=float), (g.shape[0],)).copy()
    rows = np.column_stack([g, w, b])
    uniq, inverse = np.unique(rows, axis=0, return_inverse=True)
    gu, wu, bu = uniq[:, :2], uniq[:, 2], uniq[:, 3:]
    reachable = _norm_range(gu - wu[:, None], gu + wu[:, None])[0] <= config.D * (1.0 + 1e-12)
    low = np.full(len(gu), np.inf)
    radial = np.flatnonzero(reachable & np.all(bu == 0, axis=1))
    if len(radial):
        low[radial] = _sector_bound(
            config, gu[radial] - wu[radial, None], gu[radial] + wu[radial, None], bu[radial]
        )
    tilted = np.flatnonzero(reachable & np.any(bu != 0, axis=1))
    if len(tilted):
        low[tilted] = _branch_and_bound(config, gu[tilted], wu[tilted], bu[tilted], min_size)
    slack = COST_SLACK * float(ie.propulsion_power(0.0, config.propulsion)) * config.dt
    out = low + np.einsum("ij,ij->i", bu, gu) - slack
    return out[inverse.ravel()]


def _branch_and_bound(
    config: ScenarioConfig, g: np.ndarray, w: np.ndarray, b: np.ndarray, min_size: float | None
) -> np.ndarray:
    """min over the box g +- w with |m| <= D of f(m) - b . m, bounded below by branch and bound
    over sub-boxes (see :func:`move_cost_lower_bound`)."""
    m = len(g)
    d, dt, model = config.D, config.dt, config.propulsion
    smallest = w / 16.0 if min_size is None else np.full(m, float(min_size))
    ids = np.repeat(np.arange(m), 4)
    sign = np.array([[-1, -1], [-1, 1], [1, -1], [1, 1]], dtype=float)
    centre = (g[:, None, :] + 0.5 * w[:, None, None] * sign[None]).reshape(-1, 2)
    size = np.repeat(0.5 * w, 4)  # half-width of each sub-box
    upper = np.full(m, np.inf)
    while True:
        lo, hi = centre - size[:, None], centre + size[:, None]
        bound = _sector_bound(config, lo, hi, b[ids], coarse=True)
        r = np.linalg.norm(centre, axis=1)
        inside = r <= d
        values = np.full(len(ids), np.inf)
        values[inside] = dt * np.asarray(ie.propulsion_power(r[inside] / dt, model)) - np.einsum(
            "ij,ij->i", b[ids[inside]], centre[inside]
        )
        np.minimum.at(upper, ids, values)
        keep = np.isfinite(bound) & (bound <= upper[ids] + 1e-12 * (np.abs(upper[ids]) + 1.0))
        ids, centre, size, bound = ids[keep], centre[keep], size[keep], bound[keep]
        wide = size > smallest[ids]
        if not np.any(wide):  # the last level: the exact 1-D bounds, pruned again
            bound = _sector_bound(config, centre - size[:, None], centre + size[:, None], b[ids])
            break
        ci, cc, cs = ids[wide], centre[wide], 0.5 * size[wide]
        ids = np.concatenate([ids[~wide], np.repeat(ci, 4)])
        centre = np.concatenate(
            [centre[~wide], (cc[:, None, :] + cs[:, None, None] * sign[None]).reshape(-1, 2)]
        )
        size = np.concatenate([size[~wide], np.repeat(cs, 4)])
    out = np.full(m, np.inf)
    np.minimum.at(out, ids, bound)
    return out
