r"""A certified upper bound on the energy efficiency (bits/J) of any feasible plan, one ground node.

**Dinkelbach on a relaxation.** For lambda >= 0 (bits/J) and a feasible trajectory q let
G_lambda(q) = B dt sum_{n=1}^{N} r(q[n]) - lambda E(q), with E(q) = sum_{n=1}^{N-1} f(m_n) the
propulsion energy (``ios_uav_env.energy``), m_n = q[n+1] - q[n] and f(m) = dt P(|m| / dt).

*Claim.* If U(mu) >= G_lambda(q) / (B dt) for every feasible q, with mu = lambda / (B dt), and
U(mu) <= 0, then EE(q) <= lambda for every feasible q.

*Proof.* E(q) > 0 (P > 0), so G_lambda(q) = E(q) (EE(q) - lambda) <= B dt U(mu) <= 0 gives
EE(q) <= lambda.

U below is a maximum over *relaxed paths* p of sum Rbar(p) - mu L(p), where every feasible q
maps to some p with sum_n r(q[n]) <= sum Rbar(p) and E(q) >= L(p); so U(mu) >= G_lambda(q) /
(B dt). Its least root is the best ratio sum Rbar / L of a relaxed path, and Dinkelbach's
iteration finds it: from mu_0 (a plan's EE / (B dt), or 0) take a best relaxed path p_k at mu_k
and set mu_{k+1} = (sum Rbar(p_k) / L(p_k)) (1 + ``BOUND_SLACK``). While U(mu_k) > 0,
U(mu_k) = L(p_k) (sum Rbar / L - mu_k) shows that the ratio exceeds mu_k, so mu increases, each
step to above the ratio of the path just found; the paths being finitely many, some mu_k has
U(mu_k) <= 0, and B dt mu_k is returned. *The certificate is that last DP*: U <= 0 there,
whatever the iteration did before.

**The cells.** Fine squares of side h (``resolution``) cover the grid box of the DP planners
(``baselines.grid.grid_box``, rounded out to whole coarse cells); coarse squares of side k h,
k the largest odd number with k h <= D (:func:`coarse_factor`), cover the rest of the reach box
(``baselines.grid.reach_box``, which holds every way-point of every feasible plan). A feasible
q maps slot by slot to the cell holding q[n]; q[1] = q0 and q[N] = qF stay points. A relaxed
path moves between cells whose squares are at most D apart, keeps the time windows (at slot n
a cell within (n - 1) D of q0 and (N - n) D of qF), and earns per slot Rbar(cell) >= the sup
of the slot rate over the cell (``baselines.dp_bound.region_rate_bound``), and the exact rates
at q0 and qF.

**The energy of a relaxed path: multipliers on the moves.** Write q[n] = c_n + e_n for a slot
in the cell of centre c_n and side w_n, |e_n|_inf <= w_n / 2, and e = 0 at q0 and qF. Move n is
m_n = g_n + delta_n with g_n = c_{n+1} - c_n and delta_n = e_{n+1} - e_n. For any vectors b_n
(the *multipliers*, one per move, J/m), summation by parts gives

    E(q) = sum_n [f(m_n) - b_n . delta_n] + sum_{n=2}^{N-1} e_n . (b_{n-1} - b_n)

(the e's of q0 and qF are 0). Each bracket is >= the *move cost* C(g_n, w, b_n) = min over m in
the box g_n + [-w, w]^2 with |m| <= D of f(m) - b_n . (m - g_n), w = (w_n + w_{n+1}) / 2 (the
side of a point q0 or qF being 0), and e_n . a >= -(w_n / 2) |a|_1. So

    L(p) = sum_n C(g_n, w, b_n) - sum_{n=2}^{N-1} (w_n / 2) |b_{n-1} - b_n|_1 <= E(q)

for every q of p. With b = 0 this is the plain bound: each move costs the least energy the two
squares allow, and a path of relaxed moves can travel up to ~sqrt(2) h per slot farther than
its centres for that energy, an error of first order in h that adds up along the legs. With b_n
the energy gradient along a good plan the bracket is stationary at that plan's move, so the
error is of second order in h where the relaxed path follows it; the b's telescope on a
straight leg and the penalty charges only their changes (:func:`multipliers`: a weighted moving
average of a reference plan's gradient, whose weights cancel the gradient of an oscillating
loiter, about 0 at the minimum-power speed anyway). Where the relaxed path does not follow the
reference (it hovers while b is large, say), the bracket's minimum saves up to about |b| h per
move, a first-order error again; so :func:`solve` tries a few scalings of b, and b = 0, and
keeps the smallest bound (each is certified). :meth:`EnergyRelaxation.image` maps a trajectory
to its relaxed path (a test of the two inequalities).

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

**Tightness.** The bound converges to the optimum as h -> 0 (every relaxation vanishes). With
b = 0 and cells refined by an odd factor that keeps k h (each square a union of finer ones, the
same coarse cells), each finer relaxed path maps to a coarser one with no smaller reward and no
larger cost, so the bound does not increase as the cells shrink (up to the branch and bound's
tolerances).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

import ios_uav_env as ie
from baselines.dp_bound import region_rate_bound, relaxed_offsets
from baselines.grid import DEFAULT_MARGIN, MAX_TABLE_BYTES, grid_box, reach_box
from ios_uav_env import ScenarioConfig

#: Default cell side (m) of the relaxation.
DEFAULT_RESOLUTION = 5.0
#: Default window of the weighted moving average that makes the multipliers (even, >= 2).
DEFAULT_WINDOW = 12
#: Default multiplier variants of :func:`solve`, (scale, window): b = scale x the averaged gradient.
DEFAULT_VARIANTS = ((1.0, 12), (0.5, 12), (1.0, 24))
#: Each Dinkelbach step goes to the path's ratio times 1 + BOUND_SLACK (so the last DP certifies).
BOUND_SLACK = 1e-9
#: Branch and bound of the 1-D power problems: pieces are split until narrower than this (m/s).
SPEED_TOL = 1e-4
#: Absolute slack (a fraction of P(0) dt, J) taken off every move cost (rounding).
COST_SLACK = 1e-12
#: The multipliers are rounded to this fraction of the largest gradient component.
MULTIPLIER_STEP = 1.0 / 16.0
#: Smallest sub-box (fraction of the box's half-width) of the fine-coarse moves' costs.
INTERFACE_SPLIT = 0.5
#: Default cap on Dinkelbach's relaxed DP solves (the certificate included).
MAX_ITERS = 50

__all__ = [
    "DEFAULT_RESOLUTION", "DEFAULT_VARIANTS", "DEFAULT_WINDOW", "EnergyBound", "EnergyRelaxation",
    "check_terms", "coarse_factor", "convex_from", "induced_ratio", "move_cost_lower_bound", "multipliers",
    "power_slope", "propulsion_coefficients", "solve", "terms_power", "tilted_power_lower_bound",
]  # fmt: skip


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


def multipliers(config: ScenarioConfig, reference: Any = None, window: int = DEFAULT_WINDOW) -> np.ndarray:
    """The move multipliers b (N - 1, 2) (J/m): the centred weighted moving average (weights
    1, 2, ..., 2, 1 over ``window`` + 1 moves, fewer at the ends) of the energy gradient
    P'(V_n) m_n / |m_n| of the ``reference`` trajectory (N, 2) or Plan (0 for a move of length
    0), rounded to ``MULTIPLIER_STEP`` of its largest component; zeros when ``reference`` is
    None. Any b gives a valid bound; this one makes it tight where the reference is good."""
    n_moves = config.N - 1
    if reference is None:
        return np.zeros((n_moves, 2))
    q = np.asarray(getattr(reference, "trajectory", reference), dtype=float)
    if q.shape != (config.N, 2) or not np.all(np.isfinite(q)):
        raise ValueError(
            f"reference must be a finite (N={config.N}, 2) trajectory or a Plan, got shape {q.shape}"
        )
    if isinstance(window, bool) or not isinstance(window, (int, np.integer)) or window < 2 or window % 2:
        raise ValueError(f"window must be an even integer >= 2 (moves), got {window!r}")
    k = check_terms(config)
    m = np.diff(q, axis=0)
    length = np.linalg.norm(m, axis=1)
    unit = np.where(length[:, None] > 0, m / np.where(length > 0, length, 1.0)[:, None], 0.0)
    grad = power_slope(length / config.dt, k)[:, None] * unit
    # the kernel [1, 2, ..., 2, 1] cancels a sign flip every move exactly (an oscillating loiter)
    kernel = np.r_[1.0, np.full(int(window) - 1, 2.0), 1.0]
    counts = np.convolve(np.ones(n_moves), kernel, mode="same")
    b = np.column_stack([np.convolve(grad[:, j], kernel, mode="same") / counts for j in range(2)])
    # rounded to a few levels (any b is valid): the move costs are computed once per distinct b,
    # and what is left of a cancelled gradient (rounding) becomes 0
    step = MULTIPLIER_STEP * float(np.max(np.abs(grad))) if grad.size else 0.0
    return np.round(b / step) * step if step > 0 else np.zeros_like(b)


# --- the relaxation ---------------------------------------------------------------------------------


def coarse_factor(config: ScenarioConfig, resolution: float) -> int:
    """k, the odd number of fine cells per side of a coarse cell: the largest odd k with
    k h <= D (at least 1), so a coarse cell is about a move wide."""
    k = int(math.floor(config.D / resolution + 1e-9))
    return max(1, k if k % 2 else k - 1)


@dataclass
class _Grid:
    """Square cells of side ``side`` (m) centred at ``xs`` x ``ys``: which are states of the
    relaxation (a coarse cell inside the fine region is not), their rate bounds and their
    distances to q0 and qF."""

    side: float
    xs: np.ndarray
    ys: np.ndarray
    state: np.ndarray  # (ny, nx) bool
    reward: np.ndarray = field(default_factory=lambda: np.empty(0))  # (ny, nx) bps/Hz, Rbar
    d0: np.ndarray = field(default_factory=lambda: np.empty(0))  # (ny, nx) m, q0 to the square
    df: np.ndarray = field(default_factory=lambda: np.empty(0))  # (ny, nx) m, qF to the square

    @property
    def centres(self) -> np.ndarray:
        xx, yy = np.meshgrid(self.xs, self.ys)
        return np.stack([xx, yy], axis=-1)

    def fill(self, config: ScenarioConfig) -> None:
        """Compute the rate bounds and the distances to q0 and qF."""
        cen, half = self.centres, 0.5 * self.side
        x, y = cen[..., 0], cen[..., 1]
        self.reward = region_rate_bound(config, x - half, x + half, y - half, y + half)
        self.d0 = _square_distance(np.asarray(config.q0, float), cen, half)
        self.df = _square_distance(np.asarray(config.qF, float), cen, half)


def _square_distance(p: np.ndarray, centres: np.ndarray, half: float) -> np.ndarray:
    """Distance (m) from the point p to each square of half-side ``half`` at ``centres`` (..., 2)."""
    gap = np.maximum(0.0, np.abs(centres - p) - half)
    return np.hypot(gap[..., 0], gap[..., 1])


class EnergyRelaxation:
    """U(mu) of the module docstring for one config, cell side and multipliers b.

    The cells: fine squares of side h over the grid box (``baselines.grid.grid_box``, rounded
    out to whole coarse cells) and coarse squares of side k h (:func:`coarse_factor`) over the
    rest of the reach box (``baselines.grid.reach_box``: every way-point of a feasible plan lies
    in it). ``value(mu)`` -> (U, sum Rbar, L) of a best relaxed path, mu = lambda / (B dt)."""

    def __init__(
        self,
        config: ScenarioConfig,
        resolution: float,
        margin: float = DEFAULT_MARGIN,
        b: np.ndarray | None = None,
    ):
        if not isinstance(config, ScenarioConfig):
            raise TypeError(f"config must be a ScenarioConfig, got {type(config).__name__}")
        config.require_single_node("the energy-efficiency bound")
        if not (
            isinstance(resolution, (int, float)) and math.isfinite(resolution) and 0 < resolution <= config.D
        ):
            raise ValueError(
                f"resolution must be a finite number in (0, D={config.D:g}] m, got {resolution!r}"
            )
        if not (isinstance(margin, (int, float)) and math.isfinite(margin) and margin >= 0):
            raise ValueError(f"margin must be a finite number >= 0 (m), got {margin!r}")
        c, h = config, float(resolution)
        self.config, self.h = c, h
        self.b = np.zeros((c.N - 1, 2)) if b is None else np.asarray(b, dtype=float)
        if self.b.shape != (c.N - 1, 2) or not np.all(np.isfinite(self.b)):
            raise ValueError(
                f"b must be finite multipliers of shape (N - 1 = {c.N - 1}, 2), got {self.b.shape}"
            )
        check_terms(c)
        q0, qf = np.asarray(c.q0, float), np.asarray(c.qF, float)
        self.r0, self.rf = (float(r) for r in ie.slot_rates(c, np.array([q0, qf])))
        # N = 2: the one move q0 -> qF, exactly
        self.direct_cost = c.dt * float(ie.propulsion_power(math.dist(c.q0, c.qF) / c.dt, c.propulsion))
        if c.N < 3:
            return
        self.fine, self.coarse = self._grids(margin)
        self._check_size()
        self.fine.fill(c)
        self.coarse.fill(c)
        self._costs()

    def _grids(self, margin: float) -> tuple[_Grid, _Grid]:
        c, h = self.config, self.h
        k = coarse_factor(c, h)
        big = k * h
        x0, y0 = c.q0
        r_lo_x, r_hi_x, r_lo_y, r_hi_y = reach_box(c)
        g_lo_x, g_hi_x, g_lo_y, g_hi_y = grid_box(c, margin)

        def span(lo: float, hi: float, origin: float) -> tuple[int, int]:  # coarse indices meeting [lo, hi]
            return math.ceil((lo - origin) / big - 0.5), math.floor((hi - origin) / big + 0.5)

        cx0, cx1 = span(min(r_lo_x, g_lo_x), max(r_hi_x, g_hi_x), x0)
        cy0, cy1 = span(min(r_lo_y, g_lo_y), max(r_hi_y, g_hi_y), y0)
        fx0, fx1 = span(g_lo_x, g_hi_x, x0)
        fy0, fy1 = span(g_lo_y, g_hi_y, y0)
        cxs, cys = x0 + big * np.arange(cx0, cx1 + 1), y0 + big * np.arange(cy0, cy1 + 1)
        state = np.ones((len(cys), len(cxs)), dtype=bool)
        state[fy0 - cy0 : fy1 - cy0 + 1, fx0 - cx0 : fx1 - cx0 + 1] = False  # the fine region
        coarse = _Grid(big, cxs, cys, state)
        half_k = (k - 1) // 2
        fxs = x0 + h * np.arange(k * fx0 - half_k, k * fx1 + half_k + 1)
        fys = y0 + h * np.arange(k * fy0 - half_k, k * fy1 + half_k + 1)
        fine = _Grid(h, fxs, fys, np.ones((len(fys), len(fxs)), dtype=bool))
        self.k, self.fine_origin = k, (fy0 - cy0, fx0 - cx0)  # the fine region's first coarse cell
        return fine, coarse

    def _check_size(self) -> None:
        c = self.config
        cells = self.fine.state.size + self.coarse.state.size
        needed = 8 * max(c.N - 2, 0) * cells
        if needed > MAX_TABLE_BYTES:
            raise ValueError(
                f"resolution={self.h:g} m gives {self.fine.state.size} fine and {self.coarse.state.size} "
                f"coarse cells whose N - 2 float64 layers need {needed / 2**30:.1f} GiB, above "
                f"MAX_TABLE_BYTES={MAX_TABLE_BYTES / 2**30:g} GiB: use a coarser resolution, a smaller "
                "margin or a shorter T"
            )

    def _costs(self) -> None:
        """Every move cost C (module docstring) and every slot penalty, per move k."""
        c, h = self.config, self.h
        big = self.coarse.side
        n = c.N
        interior = np.arange(1, n - 2)  # moves between two free slots
        self.off_f = relaxed_offsets(h, c.D)  # (dy, dx)
        self.off_c = relaxed_offsets(big, c.D)
        # interface: fine cells whose square is within D of a coarse cell's (fine-index offsets u
        # from the coarse centre, which is a fine centre since k is odd)
        r = math.floor((c.D + 0.5 * (h + big)) / h) + 1
        uy, ux = np.mgrid[-r : r + 1, -r : r + 1]
        gap = np.hypot(
            np.maximum(0.0, np.abs(ux) * h - 0.5 * (h + big)),
            np.maximum(0.0, np.abs(uy) * h - 0.5 * (h + big)),
        )
        self.off_i = np.column_stack([uy[gap <= c.D * (1 + 1e-12)], ux[gap <= c.D * (1 + 1e-12)]])
        self._pairs()

        def table(g: np.ndarray, half: float, min_size: float | None = None) -> np.ndarray:
            out = np.zeros((n - 1, len(g)))
            if len(interior) and len(g):
                gg = np.tile(g, (len(interior), 1))
                bb = np.repeat(self.b[interior], len(g), axis=0)
                out[interior] = move_cost_lower_bound(c, gg, half, bb, min_size).reshape(
                    len(interior), len(g)
                )
            return out

        self.cost_f = table(self.off_f[:, ::-1] * h, h)
        self.cost_c = table(self.off_c[:, ::-1] * big, big)
        g_i = self.off_i[:, ::-1] * h  # fine cell -> coarse cell: c_C - c_F = -u h; coarse -> fine: u h
        # the interface's moves are few on any path (its cells lie a margin away from the scene):
        # coarser sub-boxes there
        w_i = 0.5 * (h + big)
        self.cost_fc = table(-g_i, w_i, INTERFACE_SPLIT * w_i)
        self.cost_cf = table(g_i, w_i, INTERFACE_SPLIT * w_i)
        q0, qf = np.asarray(c.q0, float), np.asarray(c.qF, float)
        self.first, self.last = {}, {}
        for name, grid in (("fine", self.fine), ("coarse", self.coarse)):
            cells = grid.centres.reshape(-1, 2)
            half = 0.5 * grid.side
            first = np.full(len(cells), np.inf)
            last = np.full(len(cells), np.inf)
            near0 = grid.d0.ravel() <= c.D * (1 + 1e-9)
            nearf = grid.df.ravel() <= c.D * (1 + 1e-9)
            if near0.any():
                first[near0] = move_cost_lower_bound(c, cells[near0] - q0, half, self.b[0])
            if nearf.any():
                last[nearf] = move_cost_lower_bound(c, qf - cells[nearf], half, self.b[-1])
            self.first[name], self.last[name] = (
                first.reshape(grid.state.shape),
                last.reshape(grid.state.shape),
            )
        jump = np.abs(self.b[0 : n - 2] - self.b[1 : n - 1]).sum(axis=1)  # |b_{k-1} - b_k|_1, k = 1..N-2
        self.pen_f = np.r_[0.0, 0.5 * h * jump]
        self.pen_c = np.r_[0.0, 0.5 * big * jump]

    def _pairs(self) -> None:
        """The interface pairs (fine flat index, coarse flat index, offset index)."""
        fine, coarse, k = self.fine, self.coarse, self.k
        fy0, fx0 = self.fine_origin
        nyf, nxf = fine.state.shape
        # only coarse cells within reach of the fine region (D plus a coarse cell, in coarse cells)
        reach = math.ceil(self.config.D / coarse.side) + 1
        near = np.zeros_like(coarse.state)
        ky, kx = nyf // k, nxf // k  # the fine region's size in coarse cells
        near[max(0, fy0 - reach) : fy0 + ky + reach, max(0, fx0 - reach) : fx0 + kx + reach] = True
        cj, ci = np.nonzero(coarse.state & near)
        half_k = (k - 1) // 2
        # the coarse cell's centre in fine indices (may lie outside the fine grid)
        cy_f, cx_f = (cj - fy0) * k + half_k, (ci - fx0) * k + half_k
        fy = cy_f[:, None] + self.off_i[None, :, 0]
        fx = cx_f[:, None] + self.off_i[None, :, 1]
        inside = (fy >= 0) & (fy < nyf) & (fx >= 0) & (fx < nxf)
        rows, cols = np.nonzero(inside)
        self.pair_f = fy[rows, cols] * nxf + fx[rows, cols]
        self.pair_c = cj[rows] * coarse.state.shape[1] + ci[rows]
        self.pair_o = cols

    def _allowed(self, grid: _Grid, k: int) -> np.ndarray:
        """The cells of ``grid`` allowed at slot k (0-based): within k D of q0 and (N-1-k) D of qF."""
        c, tol = self.config, 1 + 1e-9
        return grid.state & (grid.d0 <= k * c.D * tol) & (grid.df <= (c.N - 1 - k) * c.D * tol)

    def image(self, trajectory: Any) -> tuple[float, float, list[tuple[str, int, int]]]:
        """The relaxed path of a feasible ``trajectory`` (N, 2): (sum Rbar, L, its states), each
        slot mapped to the cell holding it (fine where the fine squares cover it). By the
        construction sum Rbar >= sum_n r(q[n]) and L <= E(q) (module docstring); ``ValueError``
        if a move of the image is not a relaxed move (an infeasible trajectory)."""
        c, q = self.config, np.asarray(trajectory, dtype=float)
        if q.shape != (c.N, 2):
            raise ValueError(f"trajectory must be (N={c.N}, 2), got {q.shape}")
        if c.N == 2:
            return self.r0 + self.rf, self.direct_cost, []
        fine, coarse = self.fine, self.coarse
        states: list[tuple[str, int, int]] = []
        for p in q[1:-1]:
            fx = int(np.clip(np.rint((p[0] - fine.xs[0]) / fine.side), 0, len(fine.xs) - 1))
            fy = int(np.clip(np.rint((p[1] - fine.ys[0]) / fine.side), 0, len(fine.ys) - 1))
            if np.all(np.abs(p - (fine.xs[fx], fine.ys[fy])) <= 0.5 * fine.side * (1 + 1e-12)):
                states.append(("fine", fy, fx))
                continue
            cx = int(np.rint((p[0] - coarse.xs[0]) / coarse.side))
            cy = int(np.rint((p[1] - coarse.ys[0]) / coarse.side))
            states.append(("coarse", cy, cx))
        grids = {"fine": fine, "coarse": coarse}
        rates = self.r0 + self.rf + sum(float(grids[s[0]].reward[s[1], s[2]]) for s in states)
        cost = float(self.first[states[0][0]][states[0][1:]]) + float(
            self.last[states[-1][0]][states[-1][1:]]
        )
        half_k = (self.k - 1) // 2
        fy0, fx0 = self.fine_origin
        columns = {
            "fine": {tuple(o): j for j, o in enumerate(self.off_f.tolist())},
            "coarse": {tuple(o): j for j, o in enumerate(self.off_c.tolist())},
            "interface": {tuple(o): j for j, o in enumerate(self.off_i.tolist())},
        }
        for k in range(1, c.N - 1):
            name, y, x = states[k - 1]
            cost -= float((self.pen_f if name == "fine" else self.pen_c)[k])
            if k == c.N - 2:
                break
            nxt = states[k]
            try:
                if nxt[0] == name:
                    j = columns[name][(nxt[1] - y, nxt[2] - x)]
                    cost += float((self.cost_f if name == "fine" else self.cost_c)[k][j])
                else:  # u: the fine cell's offset from the coarse cell's centre, in fine cells
                    (fy, fx), (cy, cx) = ((y, x), nxt[1:]) if name == "fine" else (nxt[1:], (y, x))
                    u = (fy - ((cy - fy0) * self.k + half_k), fx - ((cx - fx0) * self.k + half_k))
                    j = columns["interface"][u]
                    cost += float((self.cost_fc if name == "fine" else self.cost_cf)[k][j])
            except KeyError:
                raise ValueError(f"move {k} of the trajectory is not a relaxed move (infeasible?)") from None
        return rates, cost, states

    def dinkelbach(
        self, start: float = 0.0, max_iters: int = MAX_ITERS, label: str = "", progress: bool = False
    ) -> tuple[float, float, float, list[dict[str, Any]]]:
        """Dinkelbach's iteration on this relaxation from lambda = ``start`` (bits/J) (module
        docstring): (the certified bound lambda, bits/J, with U <= 0 there; the best path ratio
        found, bits/J; U at the bound; one record per DP). ``RuntimeError`` if ``max_iters`` DPs
        give no certificate."""
        c = self.config
        scale = c.bandwidth_hz * c.dt  # lambda = mu B dt
        mu = float(start) / scale
        records: list[dict[str, Any]] = []
        best_ratio = 0.0
        for _ in range(int(max_iters)):
            u, rates, cost = self.value(mu)
            if not cost > 0:
                raise ValueError(
                    f"a relaxed path has an energy bound L = {cost!r} J <= 0: the multipliers are too "
                    f"large for resolution={self.h!r} m (use a smaller resolution or no reference)"
                )
            ratio = rates / cost
            best_ratio = max(best_ratio, ratio)
            records.append({"b": label, "lambda": mu * scale, "U": u, "path_ratio": ratio * scale})
            if progress:
                lam_now, ratio_now = mu * scale, ratio * scale
                print(f"[ee-bound] b {label}: lambda {lam_now:.6f} bits/J  U {u:.3e}  ratio {ratio_now:.6f}")
            if u <= 0:
                return mu * scale, best_ratio * scale, u, records
            mu = max(ratio, mu) * (1.0 + BOUND_SLACK)
        raise RuntimeError(
            f"no certificate within max_iters={max_iters} relaxed DPs (b {label}, last U = {u:.3g})"
        )

    def value(self, mu: float) -> tuple[float, float, float]:
        """(U, sum Rbar, L) at mu = lambda / (B dt): U = max over relaxed paths of
        sum Rbar - mu L (>= G_lambda(q) / (B dt) for every feasible q), and a best path's two
        sums (bps/Hz summed over the N slots; J)."""
        c = self.config
        if c.N == 2:
            rates = self.r0 + self.rf
            return rates - mu * self.direct_cost, rates, self.direct_cost
        tables = self._tables(mu)
        return self._best_path(mu, tables)

    @staticmethod
    def _shift_max(values: np.ndarray, offsets: np.ndarray, costs: np.ndarray) -> np.ndarray:
        """out[y, x] = max over offsets o of values[(y, x) + o] - costs[o] (-inf outside)."""
        ny, nx = values.shape
        best = np.full((ny, nx), -np.inf)
        for (dy, dx), cost in zip(offsets, costs, strict=True):
            ys, yd = (slice(0, ny - dy), slice(dy, ny)) if dy >= 0 else (slice(-dy, ny), slice(0, ny + dy))
            xs, xd = (slice(0, nx - dx), slice(dx, nx)) if dx >= 0 else (slice(-dx, nx), slice(0, nx + dx))
            np.maximum(best[ys, xs], values[yd, xd] - cost, out=best[ys, xs])
        return best

    def _tables(self, mu: float) -> list[tuple[np.ndarray, np.ndarray]]:
        """(fine, coarse) values of slots k = 1..N-2 (index k - 1): the best of slots k..N-1
        (rewards minus mu times the costs of moves k..N-2, plus mu times the penalties of slots
        k..N-2: L subtracts them)."""
        c, fine, coarse = self.config, self.fine, self.coarse
        n = c.N
        tables: list[tuple[np.ndarray, np.ndarray]] = [(np.empty(0), np.empty(0))] * (n - 2)
        k = n - 2
        last = []
        for name, grid, pen in (("fine", fine, self.pen_f), ("coarse", coarse, self.pen_c)):
            ok = self._allowed(grid, k) & np.isfinite(self.last[name])
            last.append(
                np.where(
                    ok, grid.reward + self.rf - mu * (np.where(ok, self.last[name], 0.0) - pen[k]), -np.inf
                )
            )
        tables[-1] = (last[0], last[1])
        for k in range(n - 3, 0, -1):
            vf, vc = tables[k]  # slot k + 1
            af = self._shift_max(vf, self.off_f, mu * self.cost_f[k])
            ac = self._shift_max(vc, self.off_c, mu * self.cost_c[k])
            if len(self.pair_f):
                np.maximum.at(
                    af.ravel(), self.pair_f, vc.ravel()[self.pair_c] - mu * self.cost_fc[k][self.pair_o]
                )
                np.maximum.at(
                    ac.ravel(), self.pair_c, vf.ravel()[self.pair_f] - mu * self.cost_cf[k][self.pair_o]
                )
            tables[k - 1] = (
                np.where(self._allowed(fine, k), fine.reward + mu * self.pen_f[k] + af, -np.inf),
                np.where(self._allowed(coarse, k), coarse.reward + mu * self.pen_c[k] + ac, -np.inf),
            )
        return tables

    def _best_path(
        self, mu: float, tables: list[tuple[np.ndarray, np.ndarray]]
    ) -> tuple[float, float, float]:
        """U and a best path's sums, recovered forwards from the tables (a state is (grid, y, x))."""
        c = self.config
        grids = {"fine": self.fine, "coarse": self.coarse}
        best, state, cost = -math.inf, None, 0.0
        for idx, name in enumerate(("fine", "coarse")):
            first = self.first[name]
            vals = np.where(
                np.isfinite(first), tables[0][idx] - mu * np.where(np.isfinite(first), first, 0.0), -np.inf
            )
            j = int(np.argmax(vals))
            if vals.flat[j] > best:
                best, state = float(vals.flat[j]), (name, *np.unravel_index(j, vals.shape))
                cost = float(first.flat[j])
        if state is None or not math.isfinite(best):
            raise ValueError("no relaxed path reaches qF in time (the scenario admits no feasible plan)")
        total, rates = self.r0 + best, self.r0
        for k in range(1, c.N - 1):
            name, y, x = state
            grid = grids[name]
            rates += float(grid.reward[y, x])
            cost -= float((self.pen_f if name == "fine" else self.pen_c)[k])
            if k == c.N - 2:
                cost += float(self.last[name][y, x])
                break
            cands = self._successors(mu, k, state, tables[k])
            state, move_cost = max(cands, key=lambda t: t[2])[:2]
            cost += move_cost
        return total, rates + self.rf, cost

    def _successors(self, mu: float, k: int, state: tuple, nxt: tuple[np.ndarray, np.ndarray]) -> list[tuple]:
        """[(next state, move cost, value of the choice)] for move k from ``state``."""
        name, y, x = state
        out = []
        if name == "fine":
            own, offsets, costs, other = nxt[0], self.off_f, self.cost_f[k], "coarse"
        else:
            own, offsets, costs, other = nxt[1], self.off_c, self.cost_c[k], "fine"
        ny, nx = own.shape
        tgt = offsets + np.array([y, x])
        ok = (tgt[:, 0] >= 0) & (tgt[:, 0] < ny) & (tgt[:, 1] >= 0) & (tgt[:, 1] < nx)
        if ok.any():
            vals = np.full(len(tgt), -np.inf)
            vals[ok] = own[tgt[ok, 0], tgt[ok, 1]] - mu * costs[ok]
            j = int(np.argmax(vals))
            out.append(((name, int(tgt[j, 0]), int(tgt[j, 1])), float(costs[j]), float(vals[j])))
        flat = y * own.shape[1] + x
        if name == "fine":
            sel = np.flatnonzero(self.pair_f == flat)
            target, ctab, grid = self.pair_c[sel], self.cost_fc[k], nxt[1]
        else:
            sel = np.flatnonzero(self.pair_c == flat)
            target, ctab, grid = self.pair_f[sel], self.cost_cf[k], nxt[0]
        if len(sel):
            vals = grid.ravel()[target] - mu * ctab[self.pair_o[sel]]
            j = int(np.argmax(vals))
            yy, xx = np.unravel_index(int(target[j]), grid.shape)
            out.append(((other, int(yy), int(xx)), float(ctab[self.pair_o[sel][j]]), float(vals[j])))
        return out


@dataclass(frozen=True)
class EnergyBound:
    """The certified bound: no feasible plan of the scenario has an EE above ``upper_bound``."""

    upper_bound: float  # bits/J, certified: U(upper_bound / (B dt)) <= 0 for its relaxation
    relaxed_ratio: float  # bits/J, the best relaxed path's ratio found (<= upper_bound)
    certificate: float  # U at the bound (bps/Hz summed over the slots), <= 0
    resolution: float  # m, fine cell side h
    margin: float  # m, grid box margin
    variant: tuple[float, int] | None  # the winner's multipliers, (scale, window); None: b = 0
    plain_bound: float  # bits/J, the bound with b = 0 (= upper_bound when no reference is given)
    seconds: float  # wall time
    iterations: list[dict[str, float]] = field(default_factory=list)  # per DP: b, lambda, U, path ratio


def solve(
    config: ScenarioConfig,
    *,
    resolution: float = DEFAULT_RESOLUTION,
    margin: float = DEFAULT_MARGIN,
    reference: Any = None,
    variants: Any = DEFAULT_VARIANTS,
    start: float | None = None,
    max_iters: int = MAX_ITERS,
    progress: bool = False,
) -> EnergyBound:
    """The certified upper bound on the EE (bits/J) of every feasible plan of ``config`` (one node).

    Parameters
    ----------
    config : ScenarioConfig
        One ground node; its ``propulsion`` and ``bandwidth_hz`` define the EE.
    resolution : float
        Fine cell side h (m), in (0, D]; the bound tightens as it shrinks (module docstring).
    margin : float
        Widening (m, >= 0) of the fine cells' box, as the DP planners' grid box.
    reference : trajectory (N, 2) or Plan, optional
        The plan whose energy gradient makes the multipliers (:func:`multipliers`), typically
        the best plan found. None: b = 0 only.
    variants : sequence of (scale, window)
        With a reference, one bound per variant, b = scale x :func:`multipliers` with that
        window (scale in (0, 1], window even >= 2), and the bound with b = 0: every b is
        valid, and the smallest is returned. Which is tightest depends on how closely the
        relaxed optimum follows the reference: a relaxed path that hovers where b is large
        saves about |b| h per move, which a smaller scale limits.
    start : float, optional
        A first lambda (bits/J, >= 0); default: the reference's EE, else 0.
    max_iters : int
        Cap on the relaxed DP solves (>= 1) of each bound, its certificate included.
    progress : bool
        Print one line per DP.

    Returns
    -------
    EnergyBound
        ``upper_bound`` (bits/J), with U(upper_bound) <= 0 checked by the last DP.

    Raises
    ------
    ValueError
        A bad argument, K > 1 ground nodes, or tables above ``baselines.grid.MAX_TABLE_BYTES``.
    RuntimeError
        No certificate within ``max_iters`` DPs.
    """
    t0 = time.perf_counter()
    if not isinstance(config, ScenarioConfig):
        raise TypeError(f"config must be a ScenarioConfig, got {type(config).__name__}")
    if isinstance(max_iters, bool) or not isinstance(max_iters, (int, np.integer)) or max_iters < 1:
        raise ValueError(f"max_iters must be an integer >= 1, got {max_iters!r}")
    if start is not None and not (
        isinstance(start, (int, float))
        and not isinstance(start, bool)
        and math.isfinite(start)
        and start >= 0
    ):
        raise ValueError(f"start must be a finite number >= 0 (bits/J), got {start!r}")
    variants = tuple(variants) if reference is not None else ()
    tilts = {}
    for scale, window in variants:  # validates reference, scales and windows before any DP
        if not (isinstance(scale, (int, float)) and not isinstance(scale, bool) and 0 < scale <= 1):
            raise ValueError(f"a variant's scale must be a number in (0, 1], got {scale!r}")
        tilts[(float(scale), int(window))] = float(scale) * multipliers(config, reference, window)
    if reference is not None and not tilts:
        raise ValueError("variants must hold at least one (scale, window) pair when a reference is given")
    if start is None and reference is not None:
        start = float(ie.energy_efficiency(config, np.asarray(getattr(reference, "trajectory", reference))))
    lam0 = 0.0 if start is None else float(start)
    plain = EnergyRelaxation(config, resolution, margin)
    results: dict[Any, tuple[float, float, float, list[dict[str, Any]]]] = {
        None: plain.dinkelbach(lam0, max_iters, "0", progress)
    }
    for variant, b in tilts.items():
        relaxation = EnergyRelaxation(config, resolution, margin, b)
        results[variant] = relaxation.dinkelbach(lam0, max_iters, f"{variant[0]:g}x{variant[1]}", progress)
    label = min(results, key=lambda name: results[name][0])
    lam, ratio, u, _ = results[label]
    return EnergyBound(
        upper_bound=lam,
        relaxed_ratio=ratio,
        certificate=u,
        resolution=float(resolution),
        margin=float(margin),
        variant=label,
        plain_bound=results[None][0],
        seconds=time.perf_counter() - t0,
        iterations=[r for name in results for r in results[name][3]],
    )
