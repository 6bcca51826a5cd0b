r"""The clairvoyant optimum on a grid: the DP on the exact time-varying rate maps.

**The problem** (``docs/model.md``, "Moving nodes"): the nodes' true paths w_k[n] (N, K, 2) m are
known in advance, and a flight q is scored by ``ios_uav_env.score_plan(config, q, paths=...)``,
whose slot n counts r_k(q[n]; w_k[n]). For one node that is problem (10) with a reward map per
slot,

    max (1/N) sum_n r(q[n]; w[n])   s.t.  q[1] = q0, q[N] = qF, |q[n] - q[n-1]| <= D.

On the grid of ``baselines.grid.grid_axes`` (anchored at q0, spacing ``resolution``; moves to the
grid offsets inside the disk of radius D; the last move onto qF exactly) it is a longest path
through N layers, solved exactly by the backward recursion of ``baselines.dp`` with layer n's
reward taken from slot n's map (``baselines.dp_bound.moving_dp_path``). The plan is the best grid
path, the grid optimum; the plan's ``info["dp_objective"]``, the rewards read back along it, equals
its score (checked to 1e-9).

**The maps** (:func:`rate_maps`): r_k(grid point; w_k[n]) for every slot, one map per distinct
position of a node, computed with the scorer's own per-slot kernels
(``ios_uav_env.path_kernels``), so the rewards at the grid points are the rates ``score_plan``
counts on the paths.

**Refinement** (``refine`` levels, :func:`refine_plan`): the grid's moves are grid offsets, shorter
than D in most directions, so a grid path flies its legs a little slower than a straight line at
v_max and arrives (or leaves) up to a slot late. Each level j = 1..``refine`` runs corridor DPs
(:func:`refine_path`): way-point n may move to any of the (2 ``REFINE_CELLS`` + 1)^2 points of
spacing resolution / 2^j centred on the current q[n], moves <= D, q0 and qF fixed, the same
per-slot rewards; repeated while the path changes (at most ``REFINE_SWEEPS`` times). The current
path is a candidate, so the score never decreases; the result is the best path of the last
corridor, a local refinement of the grid optimum (``info["grid_objective"]``), not a global
optimum of a finer grid. ``refine=0`` returns the grid optimum itself.

**The gap to the bound**: ``info["upper_bound"]`` is ``dp_bound.clairvoyant_bound`` on the same
paths (the relaxed DP at cell side ``bound_resolution``): no flight on the paths, so no online
policy, scores more; ``info["gap"]`` = upper_bound / mean_rate - 1 bounds how far the plan can be
from the continuous optimum.

**Several nodes** (K > 1): the max-min rate over TDMA shares is not a sum over slots, so no DP is
exact. The plan and bound are ``dp_bound.solve_multinode(paths=...)``'s: at each of Kelley's dual
weights w the DP on the per-slot rewards max_k w_k r_k(.; w_k[n]) (``dp_bound.moving_dp_path``:
:func:`grid_plan` with ``weights``), the clairvoyant tour and tours through the DP paths' hovers,
the best of them scored on the paths, under the certified bound; ``refine`` does not apply.

**Static nodes** (``motion`` None, or paths that stand still): every slot has the same map, and
with ``refine=0`` the plan is ``baselines.dp.solve``'s (the same grid and recursion; its score to
the kernels' rounding); the refinement only adds to it.

The receding-horizon planner ``baselines.mpc.MPC(planner="dp")`` calls :func:`grid_plan` on the
Kalman filter's predicted paths.
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any

import numpy as np

import ios_uav_env as ie
from baselines.dp_bound import (
    check_plain_grid,
    clairvoyant_bound,
    moving_dp_path,
    node_maps,
    rate_maps,
    solve_multinode,
)
from baselines.grid import DEFAULT_MARGIN, corridor_path, disk_offsets, grid_axes, validate_grid_args
from baselines.plan import Plan
from baselines.registry import check as check_planner
from ios_uav_env import ScenarioConfig
from ios_uav_env.model.channel import rates_at
from ios_uav_env.model.motion import check_paths, static_paths

#: The plans' scheme and the registry name.
SCHEME = "dp-clairvoyant"
#: Corridor refinements (module docstring, "Refinement"): the levels (spacing resolution / 2^j,
#: j = 1..levels), the window's half-width in points, the sweeps per level at most.
REFINE_LEVELS = 5
REFINE_CELLS = 2
REFINE_SWEEPS = 25

__all__ = ["REFINE_LEVELS", "SCHEME", "grid_plan", "rate_maps", "refine_path", "refine_plan", "solve"]


def grid_plan(
    config: ScenarioConfig,
    paths: np.ndarray,
    resolution: float,
    margin: float = DEFAULT_MARGIN,
    weights: np.ndarray | None = None,
) -> tuple[np.ndarray, float] | None:
    """The best grid path for the per-slot rewards f^n(q) = max_k w_k r_k(q; w_k[n]) on the node
    ``paths`` (N, K, 2) m (module docstring; ``weights`` w on the simplex, default (1,) for one
    node): (trajectory (N, 2) m, its mean reward (1/N) sum_n f^n(q[n]) from the maps), or None
    when no grid path reaches qF in N - 1 moves. The arrays are sized first
    (``dp_bound.check_plain_grid``: ``ValueError`` naming ``resolution``)."""
    validate_grid_args(config, resolution, margin)
    w_paths = check_paths(config, paths)
    if weights is None:
        if config.K != 1:
            raise ValueError(f"weights must be given for K = {config.K} nodes (K numbers >= 0 summing to 1)")
        w = np.ones(1)
    else:
        w = np.asarray(weights, dtype=float)
        if w.shape != (config.K,) or not (np.all(w >= 0) and abs(w.sum() - 1.0) < 1e-9):
            raise ValueError(f"weights must be K={config.K} numbers >= 0 summing to 1, got {weights!r}")
    check_plain_grid(config, resolution, margin, moving=True)
    xs, ys, _ = grid_axes(config, resolution, margin)
    rewards = node_maps(config, 0, w_paths[:, 0], xs, ys)  # (N, ny, nx); slot N's layer is not read
    if config.K > 1:  # max_k w_k r_k, one node's maps at a time
        rewards *= w[0]
        for k in range(1, config.K):
            np.maximum(rewards, w[k] * node_maps(config, k, w_paths[:, k], xs, ys), out=rewards)
    traj = moving_dp_path(config, rewards, resolution, margin)
    if traj is None:
        return None
    iy = np.rint((traj[:-1, 1] - ys[0]) / resolution).astype(int)
    ix = np.rint((traj[:-1, 0] - xs[0]) / resolution).astype(int)
    last = float(np.max(w * ie.node_rates(config, traj[-1:], w_paths[-1:])[:, 0]))
    total = float(np.sum(rewards[np.arange(config.N - 1), iy, ix])) + last
    return traj, total / config.N


def _slot_rewards(config: ScenarioConfig, paths: np.ndarray, points: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(n, P): max_k w_k r_k(points[i, p]; paths[i, k]) for slots i of ``points`` (n, P, 2)."""
    out = np.full(points.shape[:2], -np.inf)
    for k in range(config.K):
        nodes, params = ie.path_kernels(config.node_config(k), paths[:, k])
        for i in range(len(points)):
            r = rates_at(np.ascontiguousarray(points[i]), np.ascontiguousarray(nodes[i]), params[i].copy())
            np.maximum(out[i], w[k] * r, out=out[i])
    return out


def refine_path(
    config: ScenarioConfig,
    paths: np.ndarray,
    trajectory: np.ndarray,
    spacing: float,
    cells: int = REFINE_CELLS,
    weights: np.ndarray | None = None,
) -> tuple[np.ndarray, float]:
    """One corridor DP (module docstring, "Refinement"): the best path whose way-point n is one of
    the (2 ``cells`` + 1)^2 points q[n] + ``spacing`` (i, j), |i|, |j| <= ``cells``, around the
    feasible ``trajectory`` q (N, 2) m, for the rewards of :func:`grid_plan` on ``paths``:
    (trajectory (N, 2) m, its mean reward). q itself is a candidate (offset 0 first in the ties),
    so the value never decreases and an unimproved path is returned unchanged."""
    q = np.asarray(trajectory, dtype=float)
    w = np.ones(1) if weights is None else np.asarray(weights, dtype=float)
    ends = _slot_rewards(config, paths[[0, -1]], q[[0, -1], None], w)[:, 0]
    return corridor_path(
        config, q, spacing, lambda cand: _slot_rewards(config, paths[1:-1], cand, w), ends, cells
    )


def refine_plan(
    config: ScenarioConfig,
    paths: np.ndarray,
    traj: np.ndarray,
    objective: float,
    resolution: float,
    levels: int,
    weights: np.ndarray | None = None,
) -> tuple[np.ndarray, float, int]:
    """``levels`` corridor refinements of the grid plan ``traj`` (N, 2) m of mean reward
    ``objective`` on ``paths`` (module docstring, "Refinement"; level j at spacing
    ``resolution`` / 2^j, each repeated until the path stays, at most ``REFINE_SWEEPS`` times):
    (trajectory, its mean reward, corridor DPs solved)."""
    sweeps = 0
    for level in range(1, levels + 1):
        for _ in range(REFINE_SWEEPS):
            new, value = refine_path(config, paths, traj, resolution / 2**level, weights=weights)
            sweeps += 1
            if np.array_equal(new, traj):
                break
            traj, objective = new, value
    return traj, objective, sweeps


def solve(
    config: ScenarioConfig,
    paths: np.ndarray | None = None,
    resolution: float = 2.5,
    margin: float = DEFAULT_MARGIN,
    *,
    refine: int | None = None,
    bound: bool = True,
    bound_resolution: float | None = None,
    **kwargs: Any,
) -> Plan:
    """The clairvoyant grid optimum on the node ``paths`` (N, K, 2) m (module docstring), scored
    by ``score_plan(config, q, paths=paths)``.

    ``paths``: the nodes' true paths, required when the config moves (None: the configured
    positions). ``resolution``: grid spacing in (0, D] m; ``margin``: the grid box's widening (m).
    ``refine``: K = 1, corridor refinement levels (module docstring, "Refinement"; 0: the grid
    optimum; None: :data:`REFINE_LEVELS`); a ``ValueError`` for K > 1, where it does not apply.
    ``bound``: K = 1, also compute ``dp_bound.clairvoyant_bound`` at cell side
    ``bound_resolution`` (default ``resolution``) into ``info["upper_bound"]`` and ``info["gap"]``
    (K > 1 always has them, the plan and the bound being one computation: ``kwargs`` go to
    ``dp_bound.solve_multinode``). ``info`` also holds
    ``dp_objective`` and ``grid_objective`` (K = 1: the plan's and the grid optimum's mean
    reward), ``sweeps`` (corridor DPs solved), ``resolution``, ``margin``, ``grid_shape`` and
    ``clairvoyant`` (true when scored on moving paths).

    ``ValueError``: bad arguments, a grid above ``MAX_TABLE_BYTES``, or no grid path reaching qF
    in time (refine the grid).
    """
    t0 = time.perf_counter()
    check_planner(SCHEME, config, paths)
    validate_grid_args(config, resolution, margin)
    from baselines import tour

    if config.K > 1:
        if refine is not None:
            raise ValueError(f"refine applies to one node (K = 1), got refine={refine!r} with K={config.K}")
        plan = solve_multinode(
            config,
            resolution=resolution,
            margin=margin,
            bound_resolution=bound_resolution,
            paths=paths,
            **kwargs,
        )
        return dataclasses.replace(plan, scheme=SCHEME, seconds=time.perf_counter() - t0)
    if kwargs:
        raise TypeError(f"unexpected arguments for one node: {', '.join(sorted(kwargs))}")
    refine = REFINE_LEVELS if refine is None else refine
    if isinstance(refine, bool) or not isinstance(refine, (int, np.integer)) or refine < 0:
        raise ValueError(f"refine must be an integer >= 0 (corridor levels), got {refine!r}")
    moving = tour.moving_paths(config, paths)
    walk = static_paths(config) if moving is None else moving
    found = grid_plan(config, walk, resolution, margin)
    if found is None:
        step = config.D / math.ceil(config.D / resolution)
        raise ValueError(
            f"no grid path reaches qF in N - 1 = {config.N - 1} moves at resolution={resolution:g} m: use a "
            f"finer resolution (one that divides D={config.D:g} m, e.g. {step:g} m) or a larger T"
        )
    traj, grid_objective = found
    traj, objective, sweeps = refine_plan(config, walk, traj, grid_objective, resolution, refine)
    xs, ys, _ = grid_axes(config, resolution, margin)
    info: dict[str, Any] = {
        "dp_objective": objective, "grid_objective": grid_objective, "refine": refine, "sweeps": sweeps,
        "resolution": float(resolution), "margin": float(margin), "grid_shape": [len(ys), len(xs)],
        "n_offsets": len(disk_offsets(resolution, config.D)),
    }  # fmt: skip
    plan = tour.plan_on_paths(SCHEME, config, traj, 0.0, moving, info)
    if abs(plan.mean_rate - objective) > 1e-9 * max(1.0, abs(plan.mean_rate)):
        raise RuntimeError(f"DP objective {objective!r} != the plan's score {plan.mean_rate!r}")
    if bound:
        h = resolution if bound_resolution is None else bound_resolution
        ub = clairvoyant_bound(config, moving, resolution=h, margin=margin)
        plan.info.update(upper_bound=ub, bound_resolution=float(h))
        plan.info["gap"] = ub / plan.mean_rate - 1.0 if plan.mean_rate > 0 else (0.0 if ub <= 0 else math.inf)
    plan.seconds = time.perf_counter() - t0
    return plan
