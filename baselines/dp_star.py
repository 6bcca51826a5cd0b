r"""A STAR surface serving a user on each side at once (NOMA): DP plans and a certified bound.

The scenario is ``ScenarioConfig(surface="star", star_access="noma")`` with two static ground
nodes, one on each side of the surface plane (energy splitting, independent continuous phases:
the only NOMA case the config admits). Its score is the flight's max-min over the two users with
the best surface setting, power split and time sharing in every slot,

    V(q) = max { min_k R_k :  R = (1/N) sum_n R[n],  R[n] in conv(C(q[n])) },

``ios_uav_env.score_plan`` (``model.star_regions.scenario_maxmin``), and this module plans flights
for it (:func:`solve`) and bounds max_q V(q) over every feasible continuous flight.

**The dual.** For w = (w_0, w_1) on the simplex, min_k R_k <= w . R, and the maximum of w . R over
the slot's region is the weighted-sum slot optimum f_w(q) (``model.regions``, "Dual"), so for every
trajectory V(q) <= (1/N) sum_n f_w(q[n]); maximising over flights, max_q V(q) <= min_w max_q (1/N)
sum_n f_w(q[n]). Any w gives a valid bound.

**Plans** (below the bound). For a w, the grid DP (``baselines.grid.grid_path``: moves <= D
between grid points, the last onto qF) maximises (1/N) sum_n f_w(q[n]) over grid paths, with f_w
at each grid point from ``model.star_maps`` (the ES frontier of every grid point is computed once
and each w's map is read from it: the caching across w is exact, the frontier does not depend on
w). The grid DP's value D(w) is convex in w (a maximum over paths and settings of linear functions
of w), and the path of w with its per-slot rate pairs R^n gives the cut D(w') >= G . w',
G = (1/N) sum_n R^n; Kelley's cutting planes (``dp_bound.kelley_step``) minimise D over w, the
grid's dual. Every w's path is a candidate, and so is the TDMA plan of the same scenario
(``dp_bound.solve_multinode`` on ``star_access="tdma"``: the ``dp-sta`` plan); each is scored by
``score_plan`` on the NOMA scenario and the best is returned. NOMA's slot region contains TDMA's
vertices (each user alone with the whole surface and all the power), so the TDMA plan's NOMA score
is at least its TDMA score, and the plan returned is never below either.

**Refinement** (``refine`` levels, ``refine_rounds`` rounds; :func:`refine_plan`): alternating
optimisation of the best candidate between the schedule's dual weights and the trajectory. A round
takes the weights w* of the flight's certified max-min (``scenario_maxmin``'s ``dual_weights``:
the weights at which the flight's own dual bound is least), then moves the way-points to maximise
(1/N) sum_n f_{w*}(q[n]) by corridor DPs (``grid.corridor_path``: each way-point among the 5 x 5
points of spacing ``resolution`` / 2^j around it, j = 1..``refine``, moves <= D, repeated while
the path changes), and keeps the new flight only if ``score_plan`` scores it higher; the rounds
stop at the first that does not gain. The plan therefore never scores below the best candidate.
It is a local search on the grid's refinement, not SCA: a flight between grid points is reached,
the surface setting and the power split of every slot stay the scorer's own optimum
(``baselines.ao_star`` polishes the plan further with a trust-region SCA step off the lattices).

**The certified bound.** Over a cell, f_w needs an upper bound the relaxed DP
(``baselines.dp_relaxed``) can use. Let c_k(q) = log2(1 + g_k(q)), g_k = eta (a_D^k + sum_m
a_m^k)^2, be user k's rate with the whole surface on its side and all the power (the ``dp-sta``
node rate: ``node_rates`` of the STAR config), and NOMA(g_0, g_1) the two-user NOMA rate region of
SNRs (g_0, g_1) (superposition with SIC at the stronger user: ``star.noma_rates``), convex (the
degraded broadcast channel's capacity region). Then:

1. *Any setting's SNRs are below the full ones.* With aligned or any other phases and ES
   amplitudes u_m^k <= 1, |h_k| = |a_D^k + sum_m u_m^k a_m^k e^{j(...)}| <= a_D^k + sum_m a_m^k, so
   eta |h_k|^2 <= g_k(q).
2. *The region grows with either SNR.* NOMA(g) is contained in NOMA(g') for g <= g' componentwise.
   Raise one SNR at a time, say g_0 to g_0' with g_1 fixed, on the boundary points of the strong
   user's power fraction x (``star.noma_rates``). If user 0 stays the strong one, R_0 =
   log2(1 + x g_0) grows and R_1 = log2((1 + g_1) / (1 + x g_1)) does not move; if it stays the
   weak one, R_0 = log2(1 + (1 - x) g_0 / (1 + x g_0)) grows (g / (1 + x g) is increasing) and
   R_1 = log2(1 + x g_1) does not move; if it passes g_1, go through g_0 = g_1, where both
   parametrisations trace the same segment R_0 + R_1 = log2(1 + g_1). Every region is
   comprehensive (a lower rate is reached by a lower power), so the boundary's moves carry the
   region.
3. Hence the slot's region, every setting's region and their convex hull (time sharing) lie in
   NOMA(g_0(q), g_1(q)), and f_w(q) <= F_w(g_0(q), g_1(q)) = max over NOMA(g(q)) of w . R
   (``regions.weighted_noma_array``), nondecreasing in both SNRs by 2.
4. Over a cell S, ``dp_relaxed.region_rate_bound`` gives Rbar_k >= sup_S c_k (it bounds the
   single-node rate of ``config.node_config(k)``, whose surface is the STAR surface with side
   factor 1: the same c_k), so gbar_k = 2^Rbar_k - 1 >= sup_S g_k and, by 2,
   F_w(gbar_0, gbar_1) >= sup_S f_w. The state O (outside the grid) is bounded alike, and the end
   slots q0, qF take F_w(g(q0)) and F_w(g(qF)).

With these rewards the relaxed DP's argument holds unchanged (every feasible continuous
trajectory maps to an allowed state sequence with no smaller reward), so its value UB(w) >=
max_q (1/N) sum_n f_w(q[n]) >= max_q V(q). UB is convex in w (a maximum over state sequences and
splits of linear functions of w) with the cut of the best sequence's rate pairs at the maximising
splits (``NomaRelaxedDP.point``: w' . R <= F_{w'}), so Kelley's cuts minimise it too; the bound
returned is the least UB(w) met, certified whatever Kelley's stopping point.

F_w(gbar) <= w_0 cbar_0 + w_1 cbar_1 (each R_k <= c_k): the bound is at least as tight as giving
each user its single-user rate. What it gives up: the energy split (it lets both users have the
whole surface at once) and the grid relaxation's move rule (``dp_bound``, "Which side is loose").
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from baselines.dp_bound import CUT_TOL, kelley_minimise, kelley_step
from baselines.dp_relaxed import RelaxedDP, check_plain_grid, check_relaxed_grid
from baselines.grid import DEFAULT_MARGIN, corridor_path, grid_axes, grid_path, validate_grid_args
from baselines.plan import Plan
from baselines.registry import check as check_planner
from ios_uav_env import ScenarioConfig, score_plan
from ios_uav_env.model.regions import weighted_noma_array
from ios_uav_env.model.star_maps import FRONTIER_POINTS, frontier_maps
from ios_uav_env.model.star_regions import scenario_maxmin

#: Default cap on Kelley iterations (of the grid DP's dual and of the bound, each).
MAX_CUTS = 15
#: Default refinement: corridor levels (spacing resolution / 2^j) and alternating rounds.
REFINE_LEVELS = 3
REFINE_ROUNDS = 3
_REFINE_SWEEPS = 10  # corridor DPs per level at most (repeated while the path changes)

__all__ = [
    "MAX_CUTS",
    "bound_cell",
    "checked_start_weights",
    "minimise_relaxed",
    "REFINE_LEVELS",
    "REFINE_ROUNDS",
    "NomaRelaxedDP",
    "noma_bound",
    "refine_plan",
    "solve",
]


class NomaRelaxedDP(RelaxedDP):
    """``dp_relaxed.RelaxedDP`` with the NOMA rewards of the module docstring: a state whose rate
    bounds are (Rbar_0, Rbar_1) is worth F_w(2^Rbar_0 - 1, 2^Rbar_1 - 1)."""

    def reward(self, w: np.ndarray, bounds: np.ndarray) -> np.ndarray:
        return weighted_noma_array(np.exp2(bounds[0]) - 1, np.exp2(bounds[1]) - 1, w[0])[0]

    def point(self, w: np.ndarray, bounds: np.ndarray) -> np.ndarray:
        _, r_0, r_1 = weighted_noma_array(np.exp2(bounds[0]) - 1, np.exp2(bounds[1]) - 1, w[0])
        return np.array([float(r_0), float(r_1)])


def _check_scenario(config: ScenarioConfig) -> None:
    x_c = config.ios_center[0]
    side = [(x - x_c) for x, _ in config.nodes]
    if side[0] * side[1] >= 0:
        raise ValueError(
            f"ground_nodes must lie on opposite sides of the surface plane x = {x_c:g} m (off it), got x = "
            f"{config.nodes[0][0]:g} and {config.nodes[1][0]:g} m"
        )


def _check_cuts(max_cuts: int, tol: float) -> None:
    if isinstance(max_cuts, bool) or not (isinstance(max_cuts, int) and max_cuts >= 1):
        raise ValueError(f"max_cuts must be an integer >= 1, got {max_cuts!r}")
    if not (isinstance(tol, (int, float)) and 0 < tol < 1):
        raise ValueError(f"tol must be a number in (0, 1), got {tol!r}")


def noma_bound(
    config: ScenarioConfig,
    resolution: float = 5.0,
    margin: float = DEFAULT_MARGIN,
    *,
    max_cuts: int = MAX_CUTS,
    tol: float = CUT_TOL,
    start_weights: np.ndarray | None = None,
) -> tuple[float, np.ndarray, float, list[dict[str, Any]]]:
    """(upper bound >= every feasible flight's max-min, its w, Kelley's lower value, per-iteration
    records): min over w of the relaxed DP's UB(w) at cell side ``resolution`` (module docstring)."""
    check_planner("dp-star", config)
    validate_grid_args(config, resolution, margin)
    _check_scenario(config)
    _check_cuts(max_cuts, tol)
    check_relaxed_grid(config, resolution, margin)
    return minimise_relaxed(NomaRelaxedDP(config, resolution, margin), start_weights, max_cuts, tol)


def minimise_relaxed(
    relaxed: RelaxedDP, start_weights: np.ndarray | None, max_cuts: int, tol: float
) -> tuple[float, np.ndarray, float, list[dict[str, Any]]]:
    """Kelley's minimisation over two users' weights of ``relaxed``'s UB(w) from ``start_weights``
    (default (1/2, 1/2)): :func:`noma_bound`'s answer, for any two-user relaxed DP."""
    return kelley_minimise(relaxed.value, checked_start_weights(start_weights, 2), max_cuts=max_cuts, tol=tol)


def checked_start_weights(start_weights: np.ndarray | None, k: int) -> np.ndarray:
    """Kelley's start over ``k`` users' weights: ``start_weights`` as k finite numbers >= 0 summing to
    1 (``ValueError`` naming the field otherwise), by default 1/k each."""
    if start_weights is None:
        return np.full(k, 1.0 / k)
    try:
        w = np.asarray(start_weights, dtype=float)
    except (TypeError, ValueError):
        w = np.full(0, np.nan)
    if w.shape != (k,) or not np.all(np.isfinite(w)) or np.any(w < 0) or abs(w.sum() - 1) > 1e-9:
        raise ValueError(
            f"start_weights must be K = {k} finite numbers >= 0 summing to 1, got {start_weights!r}"
        )
    return w


def bound_cell(resolution: float, bound_resolution: float | None) -> float:
    """The relaxed DP's cell side: ``bound_resolution``, by default ``resolution`` / 2 (checked)."""
    h = resolution / 2 if bound_resolution is None else bound_resolution
    if isinstance(h, bool) or not (isinstance(h, (int, float)) and math.isfinite(h) and h > 0):
        raise ValueError(f"bound_resolution must be a finite number > 0 (m), got {h!r}")
    return h


def refine_plan(
    config: ScenarioConfig,
    trajectory: np.ndarray,
    score: float,
    resolution: float,
    levels: int = REFINE_LEVELS,
    rounds: int = REFINE_ROUNDS,
    frontier_points: int = FRONTIER_POINTS,
) -> tuple[np.ndarray, float, list[dict[str, Any]]]:
    """The feasible flight ``trajectory`` (N, 2) m of ``score_plan`` rate ``score``, refined by
    ``rounds`` alternating rounds of ``levels`` corridor levels (module docstring, "Refinement"):
    (trajectory, its score, one record per round tried: weights, score)."""
    users = np.asarray(config.nodes, dtype=float)
    q = np.asarray(trajectory, dtype=float)
    records: list[dict[str, Any]] = []
    for _ in range(rounds):
        w = scenario_maxmin(config, q).dual_weights

        def rewards_of(cand: np.ndarray, w: np.ndarray = w) -> np.ndarray:
            maps = frontier_maps(config, cand.reshape(-1, 2), users, frontier_points)
            return maps.weighted_sum(w)[0].reshape(cand.shape[:2])

        ends = frontier_maps(config, q[[0, -1]], users, frontier_points).weighted_sum(w)[0]
        new = q
        for level in range(1, levels + 1):
            for _ in range(_REFINE_SWEEPS):
                moved, _ = corridor_path(config, new, resolution / 2**level, rewards_of, ends)
                if np.array_equal(moved, new):
                    break
                new = moved
        if np.array_equal(new, q):
            break
        new_score = score_plan(config, new).rate
        records.append({"weights": w.tolist(), "score": new_score})
        if new_score <= score:
            break
        q, score = new, new_score
    return q, score, records


def solve(
    config: ScenarioConfig,
    resolution: float = 5.0,
    margin: float = DEFAULT_MARGIN,
    *,
    bound_resolution: float | None = None,
    frontier_points: int = FRONTIER_POINTS,
    max_cuts: int = MAX_CUTS,
    tol: float = CUT_TOL,
    tdma_plan: bool = True,
    refine: int = REFINE_LEVELS,
    refine_rounds: int = REFINE_ROUNDS,
    progress: bool = False,
) -> Plan:
    """The best plan found for a NOMA STAR scenario and its certified bound (module docstring).

    ``resolution``: the plain DPs' grid (m, in (0, D]); ``bound_resolution``: the relaxed DP's cell
    side (default ``resolution`` / 2: the grid relaxation is the looser side); ``frontier_points``:
    the ES frontier's angles per grid point (``model.star_maps``); ``max_cuts``, ``tol``: each
    Kelley run's iterations and relative stopping gap; ``tdma_plan``: also score the TDMA
    scenario's DP plan (``dp-sta``) as a candidate; ``refine``, ``refine_rounds``: the best
    candidate's refinement (module docstring; 0 skips it).

    ``info``: ``upper_bound`` (>= every feasible flight's max-min), ``bound_weights``,
    ``bound_lower`` (no w gives a bound below it at this cell side), ``gap`` (upper_bound /
    mean_rate - 1), ``grid_dual`` (min over the w tried of the grid DP's value D(w): no grid path
    scores more, to the frontier maps' accuracy, about 1e-5 relative), ``plan_source``
    (``"dp<i>"``: the i-th w's path; ``"tdma"``), ``candidates`` (each's score), ``cuts`` (per w:
    weights, D(w)), ``tdma_rate`` (the TDMA plan's TDMA
    score), ``candidate_rate`` (the best candidate's score before the refinement), ``refine``
    (a record per round), ``resolution``, ``bound_resolution``, ``margin``, ``frontier_points``.
    """
    t0 = time.perf_counter()
    check_planner("dp-star", config)
    validate_grid_args(config, resolution, margin)
    _check_scenario(config)
    _check_cuts(max_cuts, tol)
    for name, value in (("refine", refine), ("refine_rounds", refine_rounds)):
        if isinstance(value, bool) or not (isinstance(value, int) and value >= 0):
            raise ValueError(f"{name} must be an integer >= 0, got {value!r}")
    h = bound_cell(resolution, bound_resolution)
    check_plain_grid(config, resolution, margin)
    check_relaxed_grid(config, h, margin)
    users = np.asarray(config.nodes, dtype=float)
    xs, ys, _ = grid_axes(config, resolution, margin)
    xx, yy = np.meshgrid(xs, ys)
    maps = frontier_maps(config, np.column_stack([xx.ravel(), yy.ravel()]), users, frontier_points)
    final = frontier_maps(config, np.array([config.qF], dtype=float), users, frontier_points)

    candidates: dict[str, np.ndarray] = {}
    cuts, records = [], []
    w, dual, lower = np.full(2, 0.5), math.inf, -math.inf
    for it in range(max_cuts):
        value, _, _ = maps.weighted_sum(w)
        try:
            traj, d_w = grid_path(config, value.reshape(xx.shape), float(final.weighted_sum(w)[0][0]),
                                  resolution, margin)  # fmt: skip
        except ValueError as exc:  # no grid path in time: the grid, not w, is at fault
            raise ValueError(f"dp-star: {exc}") from None
        rates = frontier_maps(config, traj, users, frontier_points).weighted_sum(w)[2]
        cuts.append(rates.mean(axis=1))  # D(w') >= cut . w' (module docstring)
        dual = min(dual, d_w)
        if not any(np.array_equal(traj, q) for q in candidates.values()):
            candidates[f"dp{it}"] = traj
        records.append({"iteration": it, "weights": w.tolist(), "dp_value": d_w})
        w, lower = kelley_step(np.array(cuts))
        if progress:
            print(f"[dp-star] it {it:2d}: D(w) {d_w:.6f}  min D {dual:.6f}  Kelley lower {lower:.6f}")
        if dual - lower <= tol * dual:
            break
    tdma_rate = None
    if tdma_plan:
        from baselines.dp_bound import solve_multinode

        tdma = solve_multinode(config.replace(star_access="tdma"), resolution=resolution, margin=margin)
        candidates["tdma"], tdma_rate = tdma.trajectory, tdma.mean_rate
    scores = {name: score_plan(config, q).rate for name, q in candidates.items()}
    source = max(scores, key=lambda name: scores[name])
    best_w = np.array(records[int(np.argmin([r["dp_value"] for r in records]))]["weights"])
    ub, ub_w, ub_lower, ub_records = noma_bound(config, h, margin, max_cuts=max_cuts, tol=tol,
                                                start_weights=best_w)  # fmt: skip
    candidate_rate = scores[source]
    best, score, refined = candidates[source], candidate_rate, []
    if refine > 0 and refine_rounds > 0:
        best, score, refined = refine_plan(
            config, best, score, resolution, refine, refine_rounds, frontier_points
        )
    info = {
        "upper_bound": ub,
        "bound_weights": ub_w.tolist(),
        "bound_lower": ub_lower,
        "bound_cuts": ub_records,
        "gap": ub / score - 1.0 if score > 0 else math.inf,
        "grid_dual": dual,
        "plan_source": source,
        "candidates": scores,
        "cuts": records,
        "tdma_rate": tdma_rate,
        "candidate_rate": candidate_rate,
        "refine": refined,
        "resolution": float(resolution),
        "bound_resolution": float(h),
        "margin": float(margin),
        "frontier_points": int(frontier_points),
    }
    return Plan.from_trajectory("dp-star", config, best, time.perf_counter() - t0, info=info)
