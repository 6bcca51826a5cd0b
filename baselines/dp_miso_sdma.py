r"""A multi-antenna UAV serving K users at once (SDMA): DP plans and a certified bound.

The scenario has ``antennas`` = N_t >= 2 and K in [2, 4] static ground nodes on an IOS of at most
``model.miso_sdma.MAX_ELEMENTS`` elements. Its score is the flight's max-min over the K users
with time sharing of the per-slot settings ``score_plan`` credits (``model.miso_sdma``: the
weighted-sum AO at the lattice weights and each user alone),

    V(q) = max { min_k R_k :  R = (1/N) sum_n R[n],  R[n] in conv(P(q[n])) },

P(q) the finite set of the settings' rate vectors at q. This module plans flights for it
(:func:`solve`) and bounds max_q V(q) over every feasible continuous flight, whatever the beams.

**The dual.** For w on the simplex, min_k R_k <= w . R, and the maximum of w . R over conv(P(q))
is f_w(q) = max_{R in P(q)} w . R, so V(q) <= (1/N) sum_n f_w(q[n]) for every trajectory and
max_q V(q) <= min_w max_q (1/N) sum_n f_w(q[n]).

**Plans.** The settings P(p) of every grid point p that a feasible flight can visit (|p - q0| +
|p - qF| <= (N - 1) D) are computed once (``miso_sdma.slot_points``, the scorer's own function, so a
grid path's points are the scorer's bit for bit); each w's map f_w is read from them. For a w the
grid DP (``baselines.grid.grid_path``) maximises (1/N) sum_n f_w(q[n]) over grid paths; its value
D(w) is convex in w and the path's per-slot maximisers give the cut D(w') >= G . w', so Kelley's
cutting planes (``dp_bound.kelley_step``, an LP over the K-simplex) minimise D over w from the
uniform weights, as ``dp-star`` does. Every w's path is a candidate, scored by the regions problem
on its cached settings (what ``score_plan`` computes), and the best is returned.

**The certified bound.** Every beam set and surface setting gives SINR_k <= p_k G_k(q) with p_k =
||w_k||^2, sum_k p_k <= 1, G_k the single-user gain (``miso.slot_bounds``), so f_w(q) <= F_w(G(q))
= max_{p >= 0, sum p <= 1} sum_k w_k log2(1 + p_k G_k) (``miso.weighted_sum_bound``),
nondecreasing in every gain. For two users it is max_{p in [0, 1]} w_0 log2(1 + p G_0) + w_1
log2(1 + (1 - p) G_1) in closed form (:func:`two_user_bound`); for K > 2 it is bounded by the
water-filling's Lagrangian dual at the bisected water level (:func:`water_filling_bound`: an upper
bound at every level, so rounding never breaks it). For the rank-one UAV-surface channel G_k =
S_k^2 N_t + 2 S_k |beta_k| + ||d_k||^2 <= N_t (S_k + a_D^k)^2 = N_t g_k, g_k = eta zeta_k^2 the
single-antenna SNR of user k with its aligned phases (|beta_k| <= N_t a_D^k, ||d_k||^2 = N_t
(a_D^k)^2; with per-element steering too: (sqrt(N_t) S_k + ||d_k||)^2). The relaxed DP of
``baselines.dp_relaxed`` bounds the single-antenna rate log2(1 + g_k) over every cell
(``region_rate_bound`` of the single-antenna node config), so a state of rate bounds Rbar_k is
worth F_w(N_t (2^Rbar_k - 1))_k >= sup over the cell of f_w, and its value UB(w) >= max_q (1/N)
sum_n f_w(q[n]) >= max_q V(q) for every w. Kelley minimises UB over w from the plans' best w; the
least UB met is returned, certified.

The bound gives up the interference (each user its best surface and no cross-talk) and the grid
relaxation's moves; its gap to the plan is reported, not hidden.
"""

from __future__ import annotations

import math
import time

import numpy as np

from baselines.dp_bound import CUT_TOL, kelley_minimise, kelley_step
from baselines.dp_relaxed import RelaxedDP, check_plain_grid, check_relaxed_grid
from baselines.dp_star import MAX_CUTS, _check_cuts, bound_cell, checked_start_weights
from baselines.grid import DEFAULT_MARGIN, grid_axes, grid_path, validate_grid_args
from baselines.plan import Plan
from baselines.registry import check as check_planner
from ios_uav_env import ScenarioConfig
from ios_uav_env.model.miso_sdma import check_sdma_scenario, sdma_pricer, slot_points
from ios_uav_env.model.regions import maxmin_regions

__all__ = ["SdmaRelaxedDP", "sdma_bound", "solve", "two_user_bound", "water_filling_bound"]

#: Relative slack on the closed-form bound (rounding of its logarithms).
BOUND_SLACK = 1e-12


def two_user_bound(
    g_0: np.ndarray, g_1: np.ndarray, w_0: float, w_1: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(value, R_0, R_1) of max over p in [0, 1] of w_0 log2(1 + p g_0) + w_1 log2(1 + (1 - p) g_1),
    elementwise over the gains (>= 0): the concave maximum is at the stationary point
    p = (w_0 g_0 (1 + g_1) - w_1 g_1) / ((w_0 + w_1) g_0 g_1) clipped to [0, 1]; ``value`` carries
    a relative slack :data:`BOUND_SLACK` (an upper bound whatever the rounding)."""
    g_0, g_1 = np.broadcast_arrays(np.asarray(g_0, dtype=float), np.asarray(g_1, dtype=float))
    with np.errstate(divide="ignore", invalid="ignore"):
        p = (w_0 * g_0 * (1 + g_1) - w_1 * g_1) / ((w_0 + w_1) * g_0 * g_1)
    p = np.where(g_1 <= 0, 1.0, np.where(g_0 <= 0, 0.0, np.clip(np.nan_to_num(p, nan=0.5), 0.0, 1.0)))
    r_0, r_1 = np.log2(1 + p * g_0), np.log2(1 + (1 - p) * g_1)
    return (w_0 * r_0 + w_1 * r_1) * (1 + BOUND_SLACK), r_0, r_1


def water_filling_bound(
    gains: np.ndarray, weights: np.ndarray, iterations: int = 100
) -> tuple[np.ndarray, np.ndarray]:
    """(value, rates (K, ...)) for gains (K, ...) >= 0 and weights (K,) >= 0, elementwise over the
    trailing axes: ``value`` >= max_{p >= 0, sum p <= 1} sum_k w_k log2(1 + p_k G_k) (the Lagrangian
    dual [mu + sum_k max_{p_k >= 0} (w_k ln(1 + p_k G_k) - mu p_k)] / ln 2 at the water level mu
    bisected in log scale, ``iterations`` halvings, times 1 + :data:`BOUND_SLACK`); ``rates`` the
    rates log2(1 + p_k G_k) of the powers p_k = (w_k / mu - 1 / G_k)^+ at the bracket's side where
    they sum to at most 1 (feasible: w' . rates <= value at w' for every w')."""
    g = np.maximum(np.asarray(gains, dtype=float), 0.0)
    w = np.asarray(weights, dtype=float).reshape((-1,) + (1,) * (g.ndim - 1))
    wg = w * g
    top = np.max(wg, axis=0)  # at mu = max_k w_k G_k every p_k = 0
    live = top > 0
    hi = np.log(np.where(live, top, 1.0))
    lo = hi - 60.0  # mu from top e^-60: the powers sum past 1 well before the gains reach e^60
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(g > 0, 1.0 / g, np.inf)

        def powers(log_mu: np.ndarray) -> np.ndarray:
            return np.where(wg > 0, np.maximum(w / np.exp(log_mu) - inv, 0.0), 0.0)

        for _ in range(iterations):
            mid = 0.5 * (lo + hi)
            over = powers(mid).sum(axis=0) > 1.0
            lo, hi = np.where(over, mid, lo), np.where(over, hi, mid)
        p = powers(hi)
        mu = np.exp(hi)
        terms = np.where(wg > 0, w * np.log1p(p * g) - mu * p, 0.0)
    value = np.where(live, (mu + terms.sum(axis=0)) / math.log(2.0), 0.0) * (1 + BOUND_SLACK)
    return value, np.log2(1 + p * g)


class SdmaRelaxedDP(RelaxedDP):
    """``dp_relaxed.RelaxedDP`` on the single-antenna node configs with the SDMA rewards of the
    module docstring: a state whose single-antenna rate bounds are Rbar_k is worth
    F_w(N_t (2^Rbar_k - 1))_k (:func:`two_user_bound` for two users, else
    :func:`water_filling_bound`)."""

    def __init__(self, config: ScenarioConfig, resolution: float, margin: float = DEFAULT_MARGIN) -> None:
        super().__init__(config.replace(antennas=1), resolution, margin)
        self.n_t = config.antennas

    def _bound(self, w: np.ndarray, bounds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        gains = self.n_t * (np.exp2(np.asarray(bounds, dtype=float)) - 1)
        if len(gains) == 2:
            value, r_0, r_1 = two_user_bound(gains[0], gains[1], float(w[0]), float(w[1]))
            return value, np.stack([r_0, r_1])
        return water_filling_bound(gains, w)

    def reward(self, w: np.ndarray, bounds: np.ndarray) -> np.ndarray:
        return self._bound(w, bounds)[0]

    def point(self, w: np.ndarray, bounds: np.ndarray) -> np.ndarray:
        return np.asarray(self._bound(w, bounds)[1], dtype=float).reshape(-1)


def _check(config: ScenarioConfig) -> None:
    check_planner("dp-miso-sdma", config)
    check_sdma_scenario(config)


def sdma_bound(
    config: ScenarioConfig,
    resolution: float = 6.25,
    margin: float = DEFAULT_MARGIN,
    *,
    max_cuts: int = MAX_CUTS,
    tol: float = CUT_TOL,
    start_weights: np.ndarray | None = None,
) -> tuple[float, np.ndarray, float, list[dict]]:
    """(upper bound >= every feasible flight's SDMA max-min, its w, Kelley's lower value,
    per-iteration records): min over w of the relaxed DP's UB(w) at cell side ``resolution``, by
    Kelley's cutting planes from ``start_weights`` (K numbers >= 0 summing to 1; default uniform)."""
    _check(config)
    validate_grid_args(config, resolution, margin)
    _check_cuts(max_cuts, tol)
    check_relaxed_grid(config, resolution, margin)
    w = checked_start_weights(start_weights, config.K)
    return kelley_minimise(SdmaRelaxedDP(config, resolution, margin).value, w, max_cuts=max_cuts, tol=tol)


def solve(
    config: ScenarioConfig,
    resolution: float = 12.5,
    margin: float = DEFAULT_MARGIN,
    *,
    bound_resolution: float | None = None,
    max_cuts: int = MAX_CUTS,
    tol: float = CUT_TOL,
    progress: bool = False,
) -> Plan:
    """The best grid plan found for an SDMA scenario and its certified bound (module docstring).

    ``resolution``: the grid (m, in (0, D]); ``bound_resolution``: the relaxed DP's cell side
    (default ``resolution`` / 2); ``max_cuts``, ``tol``: each Kelley run's iterations and relative
    stopping gap. ``info``: ``upper_bound`` (>= every feasible flight's max-min), ``bound_weights``,
    ``bound_lower``, ``gap`` (upper_bound / mean_rate - 1), ``grid_dual`` (min over the w tried of
    D(w): no grid path scores more), ``plan_source`` (``"dp<i>"``: the i-th w's path),
    ``candidates`` (each's score), ``cuts`` (per w: weights, D(w)), ``grid_points`` (the grid
    points whose settings were computed), ``resolution``, ``bound_resolution``, ``margin``."""
    t0 = time.perf_counter()
    _check(config)
    validate_grid_args(config, resolution, margin)
    _check_cuts(max_cuts, tol)
    h = bound_cell(resolution, bound_resolution)
    check_plain_grid(config, resolution, margin)
    check_relaxed_grid(config, h, margin)
    xs, ys, _ = grid_axes(config, resolution, margin)
    xx, yy = np.meshgrid(xs, ys)
    cells = np.column_stack([xx.ravel(), yy.ravel()])
    reach = np.hypot(*(cells - config.q0).T) + np.hypot(*(cells - config.qF).T)
    visited = np.flatnonzero(reach <= (config.N - 1) * config.D * (1 + 1e-9))
    final, _ = slot_points(config, np.array([config.qF], dtype=float))
    settings = np.zeros((len(cells), final.shape[1], config.K))  # (never-visited points: rate 0, unused)
    settings[visited] = slot_points(config, cells[visited])[0]
    if progress:
        print(f"[dp-miso-sdma] settings of {len(visited)} grid points: {time.perf_counter() - t0:.1f} s")

    def path_settings(traj: np.ndarray) -> np.ndarray:  # (N, J, K): the grid points', then qF's
        ix = np.rint((traj[:-1, 0] - xs[0]) / resolution).astype(int)
        iy = np.rint((traj[:-1, 1] - ys[0]) / resolution).astype(int)
        return np.concatenate([settings[iy * len(xs) + ix], final])

    candidates: dict[str, np.ndarray] = {}
    scores: dict[str, float] = {}
    cuts, records = [], []
    w, dual, lower = np.full(config.K, 1.0 / config.K), math.inf, -math.inf
    for it in range(max_cuts):
        value = (settings @ w).max(axis=1).reshape(xx.shape)
        try:
            traj, d_w = grid_path(config, value, float((final[0] @ w).max()), resolution, margin)
        except ValueError as exc:  # no grid path in time: the grid, not w, is at fault
            raise ValueError(f"dp-miso-sdma: {exc}") from None
        on_path = path_settings(traj)
        best = np.argmax(on_path @ w, axis=1)
        cuts.append(on_path[np.arange(len(on_path)), best].mean(axis=0))  # D(w') >= cut . w'
        dual = min(dual, d_w)
        if not any(np.array_equal(traj, q) for q in candidates.values()):
            candidates[f"dp{it}"] = traj
            scores[f"dp{it}"] = maxmin_regions(sdma_pricer(on_path), config.K, tol=1e-9).value
        records.append({"iteration": it, "weights": w.tolist(), "dp_value": d_w})
        w, lower = kelley_step(np.array(cuts))
        if progress:
            print(f"[dp-miso-sdma] it {it:2d}: D(w) {d_w:.6f}  min D {dual:.6f}  Kelley lower {lower:.6f}")
        if dual - lower <= tol * dual:
            break
    source = max(scores, key=lambda name: scores[name])
    best_w = np.array(records[int(np.argmin([r["dp_value"] for r in records]))]["weights"])
    ub, ub_w, ub_lower, ub_records = sdma_bound(config, h, margin, max_cuts=max_cuts, tol=tol,
                                                start_weights=best_w)  # fmt: skip
    info = {
        "upper_bound": ub,
        "bound_weights": ub_w.tolist(),
        "bound_lower": ub_lower,
        "bound_cuts": ub_records,
        "gap": ub / scores[source] - 1.0 if scores[source] > 0 else math.inf,
        "grid_dual": dual,
        "plan_source": source,
        "candidates": scores,
        "cuts": records,
        "grid_points": int(len(visited)),
        "resolution": float(resolution),
        "bound_resolution": float(h),
        "margin": float(margin),
    }
    seconds = time.perf_counter() - t0
    return Plan.from_trajectory("dp-miso-sdma", config, candidates[source], seconds, info=info)
