r"""A tour heuristic for several ground nodes: fly to good hover points in the best order,
hover there as long as one LP says, and serve the nodes with the LP's shares.

**Hover points** (:func:`hover_candidates`, ``baselines.tour_candidates``): each node's best
reachable point (``ios_uav_env.rate_peak`` on its single-node config ``config.node_config(k)``),
and compromise points: for each pair of nodes (and all nodes when K > 2) the reachable point of a
``resolution`` grid that maximises min_k r_k(q) / r_k^* (r_k^* the node's best grid rate; the
ratio is 1 for a node with r_k^* = 0, which no reachable point serves). The grid is that of
``baselines.grid.grid_box``, clipped to what the UAV can reach, and is sized before it is built
(:func:`check_candidate_grid`).

**A route** visits an ordered list of hover points P_1..P_m: q0 -> P_1 -> ... -> P_m -> qF
on the legs of ``baselines.fixed`` (full steps of D, the last one shorter), which take
L - 1 moves; the H = N - L slots left are spent hovering. The route is infeasible when H < 0.

**One LP per route** decides the hover slots and the shares (continuous relaxation):

    max t  s.t.  (1/N) [sum_{n in legs} a_k[n] r_k(q[n]) + sum_i y_ik r_k(P_i)] >= t  (all k)
                 sum_k a_k[n] <= 1,  sum_k y_ik <= x_i,  sum_i x_i = H,  a, x, y >= 0

(x_i hover slots at P_i, y_ik of them given to node k; the L path points, P_i included
once, are the legs). The hover slots are rounded to integers summing to H (largest
remainders; on the best rounded route, then one-slot moves between hover points while the
exact score improves), the trajectory is built (feasible by construction) and scored by
``ios_uav_env.maxmin_rate``,
which re-optimises the shares: the score of a route is that of its trajectory, whoever
proposed it.

**Orders.** For every subset of at most ``max_points`` candidates, the ``orders`` orders
with the fewest travel moves (then the shortest length) are solved; the ``keep`` best LP
values are rounded and scored exactly, and the best trajectory wins. A route is skipped
without its LP when the weak-duality bound :func:`route_bound` at the best route's dual
weights of the best routes so far is not above the ``keep``-th best LP value (it could not
enter the best ``keep``).

**On node paths** (``solve(config, paths=...)``, moving nodes known in advance: the
clairvoyant tour). The route LP needs one rate per hover point, which a moving node does not
have, so the candidates and the LPs are those of a static *proxy* scenario: every node at
the mean of its path, and, as a second proxy, every node at its first position (the
configured one); every rounded route, the polish and the plan are scored exactly on the paths
(``ios_uav_env.maxmin_rate(config, q, paths)``), and the better proxy's plan is returned
(``info["proxy"]``). A heuristic, as the static tour is; the bound is ``baselines.dp_bound``'s.
Static paths give the static tour exactly.
"""

from __future__ import annotations

import itertools
import time
from typing import Any

import numpy as np

import ios_uav_env as ie
from baselines.fixed import _leg
from baselines.plan import Plan
from baselines.registry import check as check_planner
from baselines.tour_candidates import (  # noqa: F401 (the hover points, re-exported)
    CANDIDATE_RESOLUTION,
    check_candidate_grid,
    hover_candidates,
    node_rate_maps,
)
from ios_uav_env import ScenarioConfig, moves_needed
from ios_uav_env.model.lp import solve_lp
from ios_uav_env.model.motion import check_paths, is_static

__all__ = [
    "check_candidate_grid",
    "hover_candidates",
    "node_rate_maps",
    "plan_on_paths",
    "proxy_config",
    "round_slots",
    "route_legs",
    "route_lp",
    "route_trajectory",
    "solve",
    "tour_of",
]


def route_legs(config: ScenarioConfig, points: np.ndarray) -> tuple[np.ndarray, list[int]] | None:
    """The route's path without hovering (L, 2) and the index of each hover point in it;
    None when it needs more than N - 1 moves."""
    stops = [np.asarray(config.q0, float), *points, np.asarray(config.qF, float)]
    path, where = [stops[0][None, :]], []
    count = 1
    for a, b in itertools.pairwise(stops):
        leg = _leg(a, b, config.D, moves_needed(float(np.linalg.norm(b - a)), config.D))
        path.append(leg)
        count += len(leg)
        where.append(count - 1)
    if count > config.N:
        return None
    path_arr = np.vstack(path)
    path_arr[-1] = config.qF
    return path_arr, where[:-1]


def route_trajectory(config: ScenarioConfig, points: np.ndarray, hover_slots: np.ndarray) -> np.ndarray:
    """The (N, 2) trajectory of a route: its legs with ``hover_slots[i]`` extra slots at P_i.

    ``hover_slots`` are integers >= 0 summing to N - L (``ValueError`` otherwise)."""
    legs = route_legs(config, np.asarray(points, float).reshape(-1, 2))
    if legs is None:
        raise ValueError("the route needs more than N - 1 moves")
    path, where = legs
    h = np.asarray(hover_slots)
    if h.shape != (len(where),) or np.any(h < 0) or int(h.sum()) != config.N - len(path):
        raise ValueError(f"hover_slots must be {len(where)} integers >= 0 summing to {config.N - len(path)}")
    repeats = np.ones(len(path), dtype=int)
    np.add.at(repeats, where, h.astype(int))  # two stops may share a way-point (a leg of 0 moves)
    return np.repeat(path, repeats, axis=0)


def route_lp(config: ScenarioConfig, points: np.ndarray) -> tuple[float, np.ndarray] | None:
    """The route LP (module doc): (LP value, hover slots x (m,), continuous), or None when the
    route is infeasible."""
    points = np.asarray(points, float).reshape(-1, 2)
    legs = route_legs(config, points)
    if legs is None:
        return None
    path, where = legs
    solved = _solve_route(config, ie.node_rates(config, path), where)
    return None if solved is None else solved[:2]


def _solve_route(
    config: ScenarioConfig, r_path: np.ndarray, where: list[int]
) -> tuple[float, np.ndarray, np.ndarray] | None:
    """The route LP on the path's rates (K, L): (value, hover slots x, dual weights w).

    ``sum_i x_i = H`` is the equality row (``ios_uav_env.model.lp.solve_lp``: HiGHS)."""
    k_nodes, n_path, m = r_path.shape[0], r_path.shape[1], len(where)
    spare = config.N - n_path
    r_hover = r_path[:, where]  # (K, m)
    # variables: a (K * L, k-major), y (m * K, i-major), x (m), t
    n_a, n_y = k_nodes * n_path, m * k_nodes
    n_var = n_a + n_y + m + 1
    a_ub = np.zeros((k_nodes + n_path + m, n_var))
    for k in range(k_nodes):
        a_ub[k, k * n_path : (k + 1) * n_path] = -r_path[k] / config.N
        a_ub[k, n_a + np.arange(m) * k_nodes + k] = -r_hover[k] / config.N
        a_ub[k, -1] = 1.0
    for n in range(n_path):
        a_ub[k_nodes + n, np.arange(k_nodes) * n_path + n] = 1.0
    for i in range(m):
        a_ub[k_nodes + n_path + i, n_a + i * k_nodes : n_a + (i + 1) * k_nodes] = 1.0
        a_ub[k_nodes + n_path + i, n_a + n_y + i] = -1.0
    b_ub = np.concatenate([np.zeros(k_nodes), np.ones(n_path), np.zeros(m)])
    a_eq = np.zeros((1, n_var))
    a_eq[0, n_a + n_y : n_a + n_y + m] = 1.0
    c = np.zeros(n_var)
    c[-1] = -1.0
    upper = np.concatenate([np.ones(n_a), np.full(n_y + m + 1, np.inf)])
    res = solve_lp(c, a_ub, b_ub, upper, a_eq=a_eq, b_eq=np.array([spare]))
    if not res.optimal:
        return None
    w = np.maximum(-res.ub_duals[:k_nodes], 0.0)
    w = w / w.sum() if w.sum() > 0 else np.full(k_nodes, 1.0 / k_nodes)
    return -res.value, np.maximum(res.x[n_a + n_y : n_a + n_y + m], 0.0), w


def route_bound(config: ScenarioConfig, r_path: np.ndarray, where: list[int], weights: np.ndarray) -> float:
    """An upper bound of the route LP: for every w in the simplex (weak duality, as in
    ``ios_uav_env.model.schedule``) (1/N) [sum_n max_k w_k r_k[n] + H max_i max_k w_k r_k(P_i)]
    bounds it (H = N - L the hover slots); the minimum over the rows w of ``weights`` (J, K).
    Used to skip routes that cannot enter the best ``keep``."""
    per_slot = np.max(np.asarray(weights)[:, :, None] * r_path[None], axis=1)  # (J, L)
    values = per_slot.sum(axis=1) + (config.N - r_path.shape[1]) * per_slot[:, where].max(axis=1)
    return float(values.min() / config.N)


def round_slots(x: np.ndarray, total: int) -> np.ndarray:
    """Integers >= 0 summing to ``total``, by largest remainders of ``x`` scaled to ``total``."""
    x = x * (total / x.sum()) if x.sum() > 0 else np.full(len(x), total / len(x))
    base = np.floor(x + 1e-9).astype(int)
    for i in np.argsort(-(x - base))[: total - int(base.sum())]:
        base[i] += 1
    return base


def moving_paths(config: ScenarioConfig, paths: np.ndarray | None) -> np.ndarray | None:
    """``paths`` checked as (N, K, 2) m, or None when absent or static (the static planner)."""
    if paths is None:
        return None
    w = check_paths(config, paths)
    return None if is_static(config, w) else w


def proxy_config(config: ScenarioConfig, paths: np.ndarray) -> ScenarioConfig:
    """The static scenario with every node at the mean of its path (module doc, "On node paths")."""
    mean = [tuple(float(v) for v in p) for p in np.asarray(paths, dtype=float).mean(axis=0)]
    if config.K == 1:
        return config.replace(ground_node=mean[0], motion=None)
    return config.replace(ground_nodes=mean, motion=None)


def plan_on_paths(
    scheme: str,
    config: ScenarioConfig,
    trajectory: np.ndarray,
    seconds: float,
    paths: np.ndarray | None,
    info: dict[str, Any] | None = None,
) -> Plan:
    """``Plan.from_trajectory`` scored on the node ``paths`` (N, K, 2) by the one scorer
    (``ios_uav_env.score_plan(config, q, paths=paths)``); ``Plan.from_trajectory`` itself for
    None. ``info`` gets the best schedule's ``shares`` and ``node_rates`` (K > 1) and
    ``clairvoyant`` (true: scored on the given paths)."""
    if paths is None:
        return Plan.from_trajectory(scheme, config, trajectory, seconds, info=info)
    q = np.asarray(trajectory, dtype=float)
    scored = ie.score_plan(config, q, paths=paths)
    out = dict(info or {}, clairvoyant=True)
    if scored.best is not None:
        out.update(shares=scored.best.shares.tolist(), node_rates=scored.best.node_rates.tolist())
    return Plan(
        scheme=scheme, config=config, trajectory=q, mean_rate=scored.rate, feasible=scored.feasible,
        report=scored.report, energy=scored.energy, energy_efficiency=scored.energy_efficiency,
        objective_value=scored.objective_value, seconds=float(seconds), info=out,
    )  # fmt: skip


def _polish(
    config: ScenarioConfig, points: np.ndarray, slots: np.ndarray, paths: np.ndarray | None = None
) -> tuple[np.ndarray, float]:
    """One-slot moves between hover points while the exact max-min score (on ``paths``) improves."""
    best = ie.maxmin_rate(config, route_trajectory(config, points, slots), paths)
    improved = True
    while improved:
        improved = False
        for i, j in itertools.permutations(range(len(slots)), 2):
            if slots[i] == 0:
                continue
            trial = slots.copy()
            trial[i] -= 1
            trial[j] += 1
            value = ie.maxmin_rate(config, route_trajectory(config, points, trial), paths)
            if value > best + 1e-12:
                slots, best, improved = trial, value, True
    return slots, best


def solve(
    config: ScenarioConfig,
    *,
    max_points: int | None = None,
    orders: int = 2,
    keep: int = 5,
    candidates: list[tuple[str, tuple[float, float]]] | None = None,
    paths: np.ndarray | None = None,
) -> Plan:
    """The best tour found (module doc): a feasible trajectory scored by ``maxmin_rate``.

    ``paths`` (N, K, 2) m: the nodes' true paths, known in advance (module doc, "On node
    paths"); the plan is scored on them.

    ``max_points``: most hover points per route (default min(K + 1, 4)); ``orders``: orders
    solved per subset (fewest moves first); ``keep``: LP winners scored exactly;
    ``candidates``: hover points (default :func:`hover_candidates`). ``info`` holds the
    winning ``route`` (names), its ``hover_points``, ``hover_slots`` and ``lp_value``, and
    ``n_routes`` (LPs solved).
    """
    t0 = time.perf_counter()
    check_planner("tour", config, paths)
    max_points = min(config.K + 1, 4) if max_points is None else max_points
    for name, value in (("max_points", max_points), ("orders", orders), ("keep", keep)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    truth, moving = config, moving_paths(config, paths)
    if moving is None:
        traj, info = _route(truth, truth, None, max_points, orders, keep, candidates)
    else:  # routes chosen on two static proxies, scored on the paths (module doc)
        best: tuple[float, np.ndarray, dict[str, Any]] | None = None
        for name, proxy in (("mean", proxy_config(truth, moving)), ("start", truth.replace(motion=None))):
            q, found = _route(truth, proxy, moving, max_points, orders, keep, candidates)
            score = ie.maxmin_rate(truth, q, moving)
            if best is None or score > best[0]:
                best = (score, q, dict(found, proxy=name))
        assert best is not None
        _, traj, info = best
    return plan_on_paths("tour", truth, traj, time.perf_counter() - t0, moving, info)


def tour_of(config: ScenarioConfig, paths: np.ndarray | None, plan: Plan | None = None) -> Plan:
    """The tour's plan of ``config`` on ``paths`` (:func:`solve`): ``plan`` when the caller has it
    (``ValueError`` if it is not a plan of this config), else solved here."""
    if plan is None:
        return solve(config, paths=paths)
    if plan.config != config or np.shape(plan.trajectory) != (config.N, 2):
        raise ValueError("tour_plan must be the tour's plan of this config (tour.solve(config, paths=paths))")
    return plan


def _route(
    truth: ScenarioConfig,
    config: ScenarioConfig,
    moving: np.ndarray | None,
    max_points: int,
    orders: int,
    keep: int,
    candidates: list[tuple[str, tuple[float, float]]] | None,
) -> tuple[np.ndarray, dict[str, Any]]:
    """The body of :func:`solve`: routes and their LPs on the static ``config`` (``truth``
    itself, or a proxy of it with moving nodes), every rounded route scored exactly on
    ``truth`` (and the node paths ``moving``); (trajectory, info)."""
    cands = hover_candidates(config) if candidates is None else list(candidates)
    if not cands:
        raise ValueError("candidates must hold at least one (name, (x, y)) hover point")
    results: list[tuple[float, tuple[int, ...], np.ndarray]] = []
    n_routes = n_pruned = 0
    pts = np.array([p for _, p in cands], dtype=float)
    stops = [np.asarray(config.q0, float), *pts, np.asarray(config.qF, float)]  # q0 = 0, qF = -1
    leg_rates: dict[tuple[int, int], np.ndarray] = {}

    def path_rates(order: tuple[int, ...]) -> tuple[np.ndarray, list[int]]:
        """Rates (K, L) along the route's legs (cached per leg) and the hover points' indices."""
        seq = [0, *(i + 1 for i in order), len(stops) - 1]
        parts, where, count = [ends_rates[:, :1]], [], 1
        for a, b in itertools.pairwise(seq):
            if (a, b) not in leg_rates:
                d = float(np.linalg.norm(stops[b] - stops[a]))
                leg = _leg(stops[a], stops[b], config.D, moves_needed(d, config.D))
                leg_rates[a, b] = ie.node_rates(config, leg) if len(leg) else np.empty((config.K, 0))
            parts.append(leg_rates[a, b])
            count += leg_rates[a, b].shape[1]
            where.append(count - 1)
        return np.hstack(parts), where[:-1]

    ends_rates = ie.node_rates(config, np.array([config.q0]))
    hop_dist = {
        (a, b): float(np.linalg.norm(stops[b] - stops[a]))
        for a in range(len(stops))
        for b in range(len(stops))
    }
    hop_moves = {h: moves_needed(d, config.D) for h, d in hop_dist.items()}
    duals: list[np.ndarray] = []  # dual weights of the routes that entered the best ``keep``
    for size in range(1, min(max_points, len(cands)) + 1):
        for subset in itertools.combinations(range(len(cands)), size):
            perms = []
            for order in itertools.permutations(subset):
                seq = [0, *(i + 1 for i in order), len(stops) - 1]
                hops = list(itertools.pairwise(seq))
                perms.append((sum(hop_moves[h] for h in hops), sum(hop_dist[h] for h in hops), order))
            perms.sort()
            for moves, _, order in perms[:orders]:
                if moves > config.N - 1:
                    break
                r_path, where = path_rates(order)
                threshold = sorted(r[0] for r in results)[-keep] if len(results) >= keep else -np.inf
                if duals and route_bound(config, r_path, where, np.array(duals)) <= threshold:
                    n_pruned += 1
                    continue
                solved = _solve_route(config, r_path, where)
                n_routes += 1
                if solved is not None:
                    if solved[0] > threshold:
                        duals = [solved[2], *duals][:32]
                    results.append((solved[0], order, solved[1]))
    if not results:  # cannot happen: a route through a reachable point is feasible
        raise RuntimeError("no feasible tour: no candidate hover point is reachable")
    results.sort(key=lambda r: -r[0])
    best: tuple[float, tuple[int, ...], np.ndarray, float] | None = None
    for lp_value, order, x in results[:keep]:
        route = pts[list(order)]
        spare = config.N - len(route_legs(config, route)[0])  # type: ignore[index]
        slots = round_slots(x, spare)
        value = ie.maxmin_rate(truth, route_trajectory(config, route, slots), moving)
        if best is None or value > best[3]:
            best = (lp_value, order, slots, value)
    assert best is not None
    lp_value, order, slots, _ = best
    slots, _ = _polish(truth, pts[list(order)], slots, moving)  # the best rounded route only
    traj = route_trajectory(config, pts[list(order)], slots)
    info: dict[str, Any] = {
        "route": [cands[i][0] for i in order],
        "hover_points": pts[list(order)].tolist(),
        "hover_slots": [int(s) for s in slots],
        "lp_value": lp_value,
        "n_routes": n_routes,
        "n_pruned": n_pruned,
        "candidates": {name: list(p) for name, p in cands},
    }
    return traj, info
