r"""Several ground nodes: a certified upper bound on the max-min rate, and DP plans below it.

**The bound.** For any w in the simplex and any trajectory q, by weak duality
(``ios_uav_env.model.schedule``)

    V(q) <= (1/N) sum_n f_w(q[n]),   f_w(q) = max_k w_k r_k(q),

so UB(w) = max over *feasible continuous* trajectories of the right-hand side bounds every
trajectory's score, and so does min_w UB(w). UB(w) is convex in w (a maximum of linear
functions of w), so it is minimised by Kelley's cutting planes (below).

The relaxed DP that computes UB(w) over grid cells, and the rate bound over a rectangle it
rests on, are ``baselines.dp_relaxed`` (its docstring: why the relaxation bounds the continuous
problem).

**Minimising over w (Kelley).** The optimal relaxed path at w_i gives, per slot, the node
k_n maximising w_k Rbar_k and the linear minorant G_i . w' <= UB(w') (the same path with
the same choice of node). The next w minimises max_i G_i . w over the simplex (an LP),
whose value L is a lower bound of min_w UB(w): iterations stop when min_i UB(w_i) - L is
below ``tol`` (relative) or after ``max_cuts``. The start is the tour's dual weights.

**Below the bound** (plans): at every w_i, the plain grid DP (``baselines.grid.grid_path``:
moves <= D between grid points, rewards f_w at the grid points) gives a feasible
trajectory; each is scored by ``ios_uav_env.maxmin_rate``. These are good only when one
point serves all nodes, so the longest hovers of those paths, with the nodes' peaks, are
also given to the tour heuristic (routes mixing them), and the tour's own plan competes:
the plan returned is the best of all, ``info["plan_source"]`` says which.

**Moving nodes** (``paths`` (N, K, 2), the nodes' true paths known in advance: the
clairvoyant bound). Weak duality holds for any rate matrix, so with r_k[n] = r_k(q[n]; w_k[n])
V(q) <= (1/N) sum_n f_w^n(q[n]), f_w^n(q) = max_k w_k r_k(q; w_k[n]): the reward is a function
of the slot too. The relaxed DP is unchanged but for its rewards, which become per slot: the
cell bound of slot n is max_k w_k Rbar_k^n, Rbar_k^n >= sup of r_k(.; w_k[n]) over the cell
(:func:`region_rate_bound` on node k's single-node config at w_k[n], ``node_config_at``), the
same for O, and slots 1 and N keep their exact rates at w_k[1] and w_k[N]. Each step of the
argument above holds slot by slot (the image of a feasible trajectory is an allowed sequence
whose reward in slot n is no smaller than f_w^n(q[n])), so the relaxed optimum still bounds
every feasible trajectory's score on these paths, and no online policy, which knows less,
can exceed it; Kelley's cuts are built from the same per-slot rewards. Static paths give
the static tables exactly. The plans below the bound are the plain grid DP's with the
per-slot rewards f_w^n at the grid points (:func:`moving_dp_path` on the scorer's rates,
:func:`rate_maps`) at every w, and the clairvoyant tour (``baselines.tour.solve(config,
paths=...)``, or the caller's ``tour_plan``), all scored on the paths.

**Which side is loose.** Two things separate UB from the best plan: (i) the grid
relaxation, chiefly the move rule (two squares at most D apart may have centres up to
D + sqrt(2) h apart, so the relaxed path travels up to ~h/D faster per slot and hovers
longer); it shrinks about linearly with h; (ii) the duality gap of the non-convex problem
(min_w max_q >= max_q min_w): min_w max_q is the best point of the convex hull of the
per-node rate vectors single trajectories achieve, so it mixes hovering near different
nodes without paying the flight between them (the measured gaps: ``results/log.md``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

import ios_uav_env as ie
from baselines.dp_relaxed import (
    ZETA_SLACK,
    RelaxedDP,
    check_plain_grid,
    check_relaxed_grid,
    region_rate_bound,
    relaxed_offsets,
)
from baselines.grid import (
    DEFAULT_MARGIN,
    _best_move,
    disk_max,
    disk_offsets,
    grid_axes,
    grid_path,
    validate_grid_args,
)
from baselines.plan import Plan
from baselines.registry import check as check_planner
from ios_uav_env import ScenarioConfig
from ios_uav_env.model.channel import rates_at
from ios_uav_env.model.motion import check_paths

#: Default cap on Kelley iterations (relaxed DP solves) and their relative stopping gap.
MAX_CUTS = 25
CUT_TOL = 1e-4

__all__ = [
    "RelaxedDP", "ZETA_SLACK", "check_plain_grid", "check_relaxed_grid", "clairvoyant_bound",
    "kelley_minimise", "kelley_step", "node_maps", "rate_maps", "region_rate_bound", "relaxed_offsets",
    "solve_multinode",
]  # fmt: skip


def weighted_dp_path(
    config: ScenarioConfig, weights: np.ndarray, resolution: float = 5.0, margin: float = DEFAULT_MARGIN
) -> np.ndarray | None:
    """The plain grid DP's best path for the per-slot reward f_w = max_k w_k r_k (moves <= D
    between grid points; ``baselines.grid.grid_path``): a feasible trajectory, or None when no
    grid path reaches qF in time."""
    check_plain_grid(config, resolution, margin)
    w = np.asarray(weights, dtype=float)
    xs, ys, _ = grid_axes(config, resolution, margin)
    xx, yy = np.meshgrid(xs, ys)
    rates = ie.node_rates(config, np.column_stack([xx.ravel(), yy.ravel()])).reshape(config.K, *xx.shape)
    r_f = float(np.max(w * ie.node_rates(config, np.array([config.qF]))[:, 0]))
    try:
        return grid_path(config, np.max(w[:, None, None] * rates, axis=0), r_f, resolution, margin)[0]
    except ValueError:
        return None


def node_maps(config: ScenarioConfig, k: int, path: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """(n, ny, nx): r_k(grid point; path[i]) for each slot i of node k's ``path`` (n, 2) m."""
    xx, yy = np.meshgrid(xs, ys)
    points = np.column_stack([xx.ravel(), yy.ravel()])
    where, inverse = np.unique(path, axis=0, return_inverse=True)
    inverse = np.ravel(inverse)
    nodes, params = ie.path_kernels(config.node_config(k), where)
    out = np.empty((len(path), *xx.shape))
    for u in range(len(where)):
        rates = rates_at(points, np.ascontiguousarray(nodes[u]), params[u].copy())
        out[inverse == u] = rates.reshape(xx.shape)
    return out


def rate_maps(config: ScenarioConfig, paths: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """(n, K, ny, nx) bps/Hz: r_k(grid point; w_k[i]) for each slot i of ``paths`` (n, K, 2) m on
    the grid ``xs`` (nx,) x ``ys`` (ny,): the scorer's rates (``path_kernels``), one map computed
    per distinct position of a node."""
    w = np.asarray(paths, dtype=float)
    return np.stack([node_maps(config, k, w[:, k], xs, ys) for k in range(w.shape[1])], axis=1)


def moving_dp_path(
    config: ScenarioConfig, rewards: np.ndarray, resolution: float, margin: float = DEFAULT_MARGIN
) -> np.ndarray | None:
    """The best grid path for a reward map per slot, ``rewards`` (N, ny, nx) on the grid of
    ``baselines.grid.grid_axes`` (slot 1 at q0, slot N at qF; their rewards are fixed): the DP
    of ``baselines.grid.grid_path`` with layer n's reward taken from slot n. A feasible
    trajectory (N, 2) (moves <= D between grid points, the last one onto qF), or None when no
    grid path reaches qF in time."""
    n_slots, d_max = config.N, config.D
    xs, ys, (iy0, ix0) = grid_axes(config, resolution, margin)
    if rewards.shape != (n_slots, len(ys), len(xs)):
        raise ValueError(
            f"rewards must have shape (N, ny, nx) = {(n_slots, len(ys), len(xs))}, got {rewards.shape}"
        )
    q_f = np.asarray(config.qF, dtype=float)
    if n_slots == 2:
        return np.vstack([np.asarray(config.q0, dtype=float), q_f])
    offsets = disk_offsets(resolution, d_max)
    values = np.empty((n_slots - 2, len(ys), len(xs)))  # values[j]: layer of 0-based slot j + 1
    near_f = np.hypot(xs[None, :] - q_f[0], ys[:, None] - q_f[1]) <= d_max
    values[-1] = np.where(near_f, rewards[n_slots - 2], -np.inf)
    for j in range(n_slots - 4, -1, -1):
        values[j] = rewards[j + 1] + disk_max(values[j + 1], offsets)
    first = _best_move(values[0], (iy0, ix0), offsets)
    if first is None:
        return None
    path = [(iy0, ix0), first]
    for j in range(1, n_slots - 2):
        path.append(_best_move(values[j], path[-1], offsets))
    idx = np.array(path)
    return np.vstack([np.column_stack([xs[idx[:, 1]], ys[idx[:, 0]]]), q_f])


def hover_points(paths: list[np.ndarray], limit: int) -> list[tuple[str, tuple[float, float]]]:
    """The ``limit`` longest hovers (way-points repeated in consecutive slots) of the paths."""
    stays: dict[tuple[float, float], int] = {}
    for q in paths:
        same = np.all(np.diff(q, axis=0) == 0, axis=1)
        for n in np.flatnonzero(same):
            key = (float(q[n, 0]), float(q[n, 1]))
            stays[key] = stays.get(key, 0) + 1
    ranked = sorted(stays, key=lambda p: -stays[p])[:limit]
    return [(f"dp-hover({p[0]:g},{p[1]:g})", p) for p in ranked]


def kelley_step(slopes: np.ndarray, offsets: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """argmin and min over the simplex of max_i (G_i . w - c_i) (an LP): Kelley's next point
    for the cuts of slopes G_i (rows of ``slopes``) and offsets c_i (default 0)."""
    from scipy.optimize import linprog

    g = np.asarray(slopes, dtype=float)
    n, k = g.shape
    c = np.zeros(k + 1)
    c[-1] = 1.0
    a_ub = np.hstack([g, -np.ones((n, 1))])
    b_ub = np.zeros(n) if offsets is None else np.asarray(offsets, dtype=float)
    a_eq = np.hstack([np.ones((1, k)), np.zeros((1, 1))])
    res = linprog(c, A_ub=a_ub, b_ub=b_ub, A_eq=a_eq, b_eq=[1.0],
                  bounds=[(0, None)] * k + [(None, None)], method="highs")  # fmt: skip
    if res.status != 0:
        raise RuntimeError(f"Kelley LP failed: {res.message}")
    w = np.maximum(res.x[:k], 0.0)
    return w / w.sum(), float(res.fun)


def kelley_minimise(
    value: Callable[[np.ndarray], tuple[float, np.ndarray]],
    start: np.ndarray,
    *,
    max_cuts: int,
    tol: float,
    on_weights: Callable[[np.ndarray], Any] | None = None,
) -> tuple[float, np.ndarray, float, list[dict[str, Any]]]:
    """Kelley's cutting planes on a convex function of the weights over the simplex, given as
    ``value(w) -> (f(w), g)`` with the cut f(w') >= g . w' for every w': from ``start``, each
    iteration evaluates f, adds the cut and moves to :func:`kelley_step`'s point, until ``max_cuts``
    evaluations or the best value minus Kelley's lower value is at most ``tol`` times the best.
    (the best value, its w, Kelley's lower value, per-iteration records: weights, upper_bound);
    ``on_weights(w)`` is called at every w evaluated."""
    w = start
    cuts: list[np.ndarray] = []
    records: list[dict[str, Any]] = []
    best, best_w, lower = math.inf, w, -math.inf
    for it in range(max_cuts):
        ub, g = value(w)
        cuts.append(g)
        if ub < best:
            best, best_w = ub, w
        if on_weights is not None:
            on_weights(w)
        records.append({"iteration": it, "weights": w.tolist(), "upper_bound": ub})
        w, lower = kelley_step(np.array(cuts))
        if best - lower <= tol * best:
            break
    return best, best_w, lower, records


def solve_multinode(
    config: ScenarioConfig,
    *,
    resolution: float = 2.5,
    margin: float = DEFAULT_MARGIN,
    bound_resolution: float | None = None,
    max_cuts: int = MAX_CUTS,
    tol: float = CUT_TOL,
    start_weights: np.ndarray | None = None,
    progress: bool = False,
    paths: np.ndarray | None = None,
    tour_plan: Plan | None = None,
) -> Plan:
    """K > 1: the best DP plan found and the certified upper bound (module docstring).

    ``paths`` (N, K, 2) m: the nodes' true paths, known in advance (module docstring, "Moving
    nodes"): the clairvoyant bound, with the clairvoyant tour as the plan (scored on the paths).

    ``resolution``: grid of the plain DPs (the plans); ``bound_resolution``: cell side of
    the relaxed DP (default ``resolution``); ``max_cuts``, ``tol``: Kelley's iterations and
    relative stopping gap; ``start_weights``: the first w (default: the tour's dual weights);
    ``tour_plan``: the tour's plan of ``config`` (on ``paths``), ``baselines.tour.solve(config,
    paths=paths)``, when the caller has it (it is not solved again).
    ``info``: ``upper_bound`` (>= every feasible trajectory's max-min rate), ``weights`` (its
    w), ``kelley_lower`` (no w gives a bound below it on this grid), ``gap`` (upper_bound /
    mean_rate - 1; inf when the plan scores 0 below a positive bound), ``cuts`` (per iteration:
    w, UB(w), plan score), ``resolution``, ``bound_resolution``.
    """
    t0 = time.perf_counter()
    check_planner("dp-bound", config, paths)
    validate_grid_args(config, resolution, margin)
    if config.K < 2:
        raise ValueError(f"solve_multinode needs K >= 2 ground nodes, got K={config.K}")
    if not (isinstance(max_cuts, int) and max_cuts >= 1):
        raise ValueError(f"max_cuts must be an integer >= 1, got {max_cuts!r}")
    h = resolution if bound_resolution is None else bound_resolution
    if not (isinstance(h, (int, float)) and math.isfinite(h) and h > 0):
        raise ValueError(f"bound_resolution must be a finite number > 0 (m), got {h!r}")
    from baselines import tour

    moving = tour.moving_paths(config, paths)
    # every grid is sized before anything is computed: the plain DPs', the relaxed DP's, the tour's
    check_plain_grid(config, resolution, margin, moving is not None)
    check_relaxed_grid(config, h, margin, moving is not None)
    tour.check_candidate_grid(config)

    tour_plan = tour.tour_of(config, moving, tour_plan)
    if start_weights is None:
        start_weights = ie.schedule(config, tour_plan.trajectory, moving).weights
    w = np.asarray(start_weights, dtype=float)
    if w.shape != (config.K,) or not (np.all(w >= 0) and abs(w.sum() - 1) < 1e-9):
        raise ValueError(f"start_weights must be K={config.K} numbers >= 0 summing to 1, got {w!r}")
    relaxed = RelaxedDP(config, h, margin, moving)
    xs, ys, _ = grid_axes(config, resolution, margin)
    xx, yy = np.meshgrid(xs, ys)
    if moving is None:
        centre_rates = ie.node_rates(config, np.column_stack([xx.ravel(), yy.ravel()]))
        centre_rates = centre_rates.reshape(config.K, *xx.shape)
    else:  # (N, K, ny, nx): the grid's rate maps of every slot
        centre_rates = rate_maps(config, moving, xs, ys)
    rf = ie.node_rates(config, np.array([config.qF]))[:, 0]
    cuts: list[np.ndarray] = []
    records: list[dict[str, Any]] = []
    best_ub, best_w, lower = math.inf, w, -math.inf
    best_plan: tuple[float, np.ndarray, str] | None = None
    dp_paths: list[np.ndarray] = []
    for it in range(max_cuts):
        ub, g = relaxed.value(w)
        cuts.append(g)
        if ub < best_ub:
            best_ub, best_w = ub, w
        score, traj = None, None
        if moving is None:
            try:
                reward = np.max(w[:, None, None] * centre_rates, axis=0)
                traj, _ = grid_path(config, reward, float(np.max(w * rf)), resolution, margin)
            except ValueError:  # no grid path in time on this grid: the bound still holds
                traj = None
        else:  # the per-slot rewards f_w^n
            traj = moving_dp_path(
                config, np.max(w[None, :, None, None] * centre_rates, axis=1), resolution, margin
            )
        if traj is not None:
            dp_paths.append(traj)
            score = ie.maxmin_rate(config, traj, moving)
            if best_plan is None or score > best_plan[0]:
                best_plan = (score, traj, f"dp{it}")
        records.append({"iteration": it, "weights": w.tolist(), "upper_bound": ub, "plan_score": score})
        w, lower = kelley_step(np.array(cuts))
        if progress:
            print(f"[dp-bound] it {it:2d}: UB(w) {ub:.6f}  best UB {best_ub:.6f}  Kelley lower {lower:.6f}")
        if best_ub - lower <= tol * best_ub:
            break
    if best_plan is None and moving is None:  # (with moving nodes the tour's plan stands in)
        raise ValueError(f"no grid path reaches qF in time at resolution={resolution:g} m: use a finer grid")
    # the DP paths hover where some f_w peaks: routes through those points (and the nodes'
    # peaks) mix them; the tour heuristic's own plan competes too
    peaks = [(n, p) for n, p in tour_plan.info["candidates"].items() if n.startswith("peak")]
    routed = tour.solve(config, candidates=peaks + hover_points(dp_paths, config.K), paths=moving)
    if best_plan is None:  # moving nodes with no grid path in time: the tours' plans
        best_plan = (-math.inf, tour_plan.trajectory, "tour")
    for source, plan in (("tour", tour_plan), ("tour-dp-hovers", routed)):
        if plan.mean_rate > best_plan[0]:
            best_plan = (plan.mean_rate, plan.trajectory, source)
    info = {
        "upper_bound": best_ub,
        "weights": best_w.tolist(),
        "kelley_lower": lower,
        "cuts": records,
        "resolution": float(resolution),
        "bound_resolution": float(h),
        "margin": float(margin),
        "plan_source": best_plan[2],
    }
    plan = tour.plan_on_paths("dp", config, best_plan[1], time.perf_counter() - t0, moving, info)
    if plan.mean_rate > 0:
        plan.info["gap"] = best_ub / plan.mean_rate - 1.0
    else:  # a node no reachable point serves: the plan scores 0
        plan.info["gap"] = 0.0 if best_ub <= 0 else math.inf
    return plan


def clairvoyant_bound(
    config: ScenarioConfig,
    paths: np.ndarray | None,
    *,
    resolution: float = 2.5,
    margin: float = DEFAULT_MARGIN,
    **kwargs: Any,
) -> float:
    """The certified upper bound (bps/Hz) of the frame's score given the nodes' ``paths``
    (N, K, 2) m in advance (None: the configured positions): no flight, and so no online
    policy, scores more on those paths. K = 1: the relaxed DP at w = (1,) (the single node's
    average rate; module docstring, "Moving nodes"); K > 1: :func:`solve_multinode`'s
    ``upper_bound`` (``kwargs`` go to it)."""
    check_planner("dp-bound", config, paths)
    validate_grid_args(config, resolution, margin)
    if config.K == 1:
        if paths is not None:
            check_paths(config, paths)
        return RelaxedDP(config, resolution, margin, paths).value(np.ones(1))[0]
    return solve_multinode(config, resolution=resolution, margin=margin, paths=paths, **kwargs).info[
        "upper_bound"
    ]
