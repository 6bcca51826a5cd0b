r"""The paper's SCA for several ground nodes, inside block-coordinate descent (BCD).

Problem: max over (Q, alpha) of min_k R_k, R_k = (1/N) sum_n alpha_k[n] r_k(q[n])
(``ios_uav_env.model.schedule``). Two blocks, alternated:

1. **Shares** for a fixed trajectory: the LP ``ios_uav_env.best_schedule`` (exact optimum).
2. **Trajectory** for fixed shares: one SCA step of the paper (``baselines.sca``) on

       max t  s.t.  (1/N) sum_n alpha_k[n] f_k(q[n]) >= t  for every node k,  (10b)-(10c)

   with f_k node k's rate, replaced by its surrogate (16) at the iterate q^l: the linear
   lower bound of ``baselines.sca_problem.Surrogate.linearise`` on node k's single-node
   config (the paper's (16)-(19), anchored to the exact model at q^l). One set of slacks
   per slot: s (e^s <= |x - x_c|^3) and the tile slacks u_j (e^{u_j} >= d_j^4) do not
   depend on the node (|x - x_c| and the UAV-tile distances do not); v_k (the direct link
   to node k, (19)), the side factor and the tile weights are per node. Since alpha >= 0,
   sum_n alpha_k[n] (16)_k lower-bounds sum_n alpha_k[n] f_k, so every constraint is a convex
   restriction and the solver's value is a lower bound of min_k R_k(alpha) at its solution.

**Monotone.** At q^l the zero offsets are feasible; a slot whose surface term is modelled
for no node drops it for the iteration (as in the single-node code), so the surrogate can
be below the exact value there. The exact score ``maxmin_rate`` (which is also block 1:
the best shares of the new trajectory) is therefore checked: an iterate is accepted only if
it is feasible (``check_trajectory``) and its exact score does not decrease; otherwise the
start stops (``"decrease"`` beyond 1e-9 relative, else ``"converged"``), keeping the last
accepted iterate. The history records the exact score of every solve.

**Multi-start.** The tour heuristic's plan (``baselines.tour``), a DP-derived plan (the
tour through the hover points of the grid DP's path for the dual reward f_w at the tour's
dual weights, ``baselines.dp_bound.weighted_dp_path``), a fly-hover-fly over the tour's
all-node compromise point, and any ``init`` trajectories (e.g. the plan of
``baselines.dp.solve``); the best exact score wins. (The straight line was dropped: from
it SCA needed the whole iteration budget and ended below the tour.)

A slot's side of the surface is kept within an iteration (constraint (17), as in the
single-node code), so the slot at which the UAV crosses the plane comes from the start.

**On node paths** (``solve(config, paths=...)``: moving nodes known in advance, the
clairvoyant SCA). Node k's rate in slot n is that of its single-node config at w_k[n]
(``node_config_at``), so the per-node, per-slot pieces of the surrogate are those of that
config: the direct link's centre in (19) becomes a parameter per slot (g_k[n], with its
constant |g_k[n]|^2 + z_U^2), and the coefficients of (16) and (19) at slot n come from the
linearisation of the surrogate of node k at w_k[n] (one per distinct position). The tile
geometry (the Chebyshev nodes on the surface) does not depend on the node, so (17)-(18) are
unchanged. Every exact score (the acceptance test, block 1, the plan) is on the paths; the
starts are the clairvoyant tour's plan (``baselines.tour.solve(config, paths=...)``) and the
fly-hover-fly flights over its compromise points. Static paths give the static SCA exactly.
"""

from __future__ import annotations

import math
import time
import warnings
from typing import Any

import cvxpy as cp
import numpy as np

import ios_uav_env as ie
from baselines.plan import Plan
from baselines.registry import check as check_planner
from baselines.sca_problem import (
    LENGTH_SCALE,
    OK_STATUSES,
    SCHEME_NAMES,
    SLACK_BOUND,
    U_BOUND,
    Surrogate,
)
from ios_uav_env import ScenarioConfig
from ios_uav_env.model import channel as ch
from ios_uav_env.model.motion import node_config_at

#: An exact-score decrease beyond this (relative) stops a start with ``"decrease"``.
DECREASE_TOL = 1e-9

__all__ = ["MultiSurrogate", "solve"]


class MultiSurrogate:
    """The trajectory block for K nodes: linearise every node's surrogate at q^l, solve."""

    def __init__(
        self, config: ScenarioConfig, tiles: int, solver: str = "CLARABEL", paths: np.ndarray | None = None
    ):
        self.config, self.solver, self.tiles, self.paths = config, solver, tiles, paths
        self.nodes = [Surrogate(config.node_config(k), tiles, solver, dpp=False) for k in range(config.K)]
        self._at: dict[ScenarioConfig, Surrogate] = {}  # moving nodes: the surrogate at each position
        self.has_surface = config.surface != "none"
        self.n_tiles = self.nodes[0].n_tiles
        self.m = config.N - 2
        self._params = self._make_parameters()
        self._problem, self._vars = self._assemble()

    def _make_parameters(self) -> dict[str, cp.Parameter]:
        m, j = self.m, self.n_tiles
        p = {"dmax": cp.Parameter(m + 1, name="dmax")}
        if self.has_surface:
            p.update(sg=cp.Parameter(m, name="sg"), sh=cp.Parameter(m, name="sh"), dl2=cp.Parameter((m, j)))
        for k in range(self.config.K):
            if self.paths is not None:  # node k's position in each interior slot (scaled units)
                p[f"gx_{k}"] = cp.Parameter(m, name=f"gx_{k}")
                p[f"gy_{k}"] = cp.Parameter(m, name=f"gy_{k}")
                p[f"g0_{k}"] = cp.Parameter(m, name=f"g0_{k}")
            p[f"gl2_{k}"] = cp.Parameter(m, name=f"gl2_{k}")
            p[f"cd_{k}"] = cp.Parameter(m, name=f"cd_{k}")
            p[f"c0_{k}"] = cp.Parameter(name=f"c0_{k}")
            if self.has_surface:
                p[f"cb_{k}"] = cp.Parameter(m, name=f"cb_{k}")
                p[f"cc_{k}"] = cp.Parameter((m, j), name=f"cc_{k}")
        return p

    def _assemble(self) -> tuple[cp.Problem, dict[str, cp.Variable]]:
        """Problem (20) with one rate constraint per node, in the units of ``sca_problem``."""
        cfg, p, scale, m = self.config, self._params, LENGTH_SCALE, self.m
        xc, yc = cfg.ios_center[0], cfg.ios_center[1]
        xi, psi = cp.Variable(m), cp.Variable(m)
        x2, y2 = cp.Variable(m), cp.Variable(m)
        v = cp.Variable((m, cfg.K))
        t = cp.Variable()
        (x0, y0), (xf, yf) = (np.asarray(cfg.q0) - (xc, yc)) / scale, (np.asarray(cfg.qF) - (xc, yc)) / scale
        xs = cp.hstack([np.array([x0]), xi, np.array([xf])])
        ys = cp.hstack([np.array([y0]), psi, np.array([yf])])
        cons = [
            cp.norm(cp.vstack([cp.diff(xs), cp.diff(ys)]), 2, axis=0) <= p["dmax"],
            cp.square(xi) <= x2,
            cp.square(psi) <= y2,
            v >= -SLACK_BOUND,
        ]
        zu = cfg.uav_altitude / scale
        s = u = None
        if self.has_surface:
            s, u = cp.Variable(m), cp.Variable((m, self.n_tiles))
            cons.append(s <= cp.log(cp.multiply(p["sg"], xi) + p["sh"]))  # (17)
            node = self.nodes[0]
            yk = (node.node_y - yc) / scale
            const_j = yk**2 + ((cfg.uav_altitude - node.node_z) / scale) ** 2
            col = np.ones((1, self.n_tiles))
            d_j2 = (
                cp.reshape(x2 + y2, (m, 1), order="C") @ col
                - cp.reshape(psi, (m, 1), order="C") @ (2 * yk)[None, :]
                + np.ones((m, 1)) @ const_j[None, :]
            )
            cons += [
                d_j2 <= p["dl2"] + 0.5 * cp.multiply(p["dl2"], u),
                s >= -SLACK_BOUND,
                u <= U_BOUND,
            ]  # (18)
        for k, (gx, gy) in enumerate(cfg.nodes):
            if self.paths is None:
                xg, yg = (gx - xc) / scale, (gy - yc) / scale
                d_ug2 = x2 - 2 * xg * xi + y2 - 2 * yg * psi + (xg**2 + yg**2 + zu**2)
            else:  # the node's centre moves with the slot
                d_ug2 = (
                    x2
                    - 2 * cp.multiply(p[f"gx_{k}"], xi)
                    + y2
                    - 2 * cp.multiply(p[f"gy_{k}"], psi)
                    + p[f"g0_{k}"]
                )
            gl2 = p[f"gl2_{k}"]
            cons.append(d_ug2 <= gl2 - (4.0 / cfg.alpha) * cp.multiply(gl2, v[:, k]))  # (19) for node k
            rate = p[f"c0_{k}"] + p[f"cd_{k}"] @ v[:, k]
            if self.has_surface:
                rate = rate + p[f"cb_{k}"] @ s + cp.sum(cp.multiply(p[f"cc_{k}"], u))
            cons.append(rate >= t)
        return cp.Problem(cp.Maximize(t), cons), {"xi": xi, "psi": psi, "t": t}

    def _linearise(self, k: int, q: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray]:
        """Node k's per-slot surrogate values at q (its ``linearise``), and ``active``; with
        moving nodes each interior slot's columns from the surrogate at w_k[n] (module doc)."""
        if self.paths is None:
            lin = self.nodes[k].linearise(q)
            return lin.values, lin.active
        inner = self.paths[1:-1, k]
        values: dict[str, np.ndarray] = {}
        active = np.zeros(self.m, dtype=bool)
        where, index = np.unique(inner, axis=0, return_inverse=True)
        index = np.asarray(index).reshape(-1)
        for j, position in enumerate(where):
            c = node_config_at(self.config, k, position)
            if c not in self._at:
                self._at[c] = Surrogate(c, self.tiles, self.solver, dpp=False)
            lin = self._at[c].linearise(q)
            slots = np.flatnonzero(index == j)
            for name, value in lin.values.items():
                if name not in values:
                    values[name] = np.array(value, dtype=float, copy=True)
                if name != "dmax":  # per interior slot (dmax, per move, does not depend on the node)
                    values[name][slots] = value[slots]
            active[slots] = lin.active[slots]
        return values, active

    def _node_rates(self, k: int, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(exact rate, direct-link amplitude) of node k at each of the positions ``q`` of the
        interior slots."""
        if self.paths is None:
            node = self.config.node_config(k)
            return ie.slot_rates(node, q), ch.direct_amplitude(node, q)
        exact, direct = np.empty(len(q)), np.empty(len(q))
        for n in range(len(q)):
            node = node_config_at(self.config, k, self.paths[n + 1, k])
            exact[n] = ie.slot_rates(node, q[n : n + 1])[0]
            direct[n] = ch.direct_amplitude(node, q[n : n + 1])[0]
        return exact, direct

    def set_point(self, q: np.ndarray, shares: np.ndarray) -> None:
        """Parameter values of the problem at q^l with the shares alpha (K, N)."""
        cfg, scale = self.config, LENGTH_SCALE
        lins = [_Lin(*self._linearise(k, q)) for k in range(cfg.K)]
        p = self._params
        p["dmax"].value = lins[0].values["dmax"]
        qi = q[1:-1]
        active = np.any([lin.active for lin in lins], axis=0)
        if self.has_surface:
            x_l = (qi[:, 0] - cfg.ios_center[0]) / scale
            p["sg"].value = np.where(active, 3.0 / np.where(active, x_l, 1.0), 0.0)
            p["sh"].value = np.where(active, -2.0, 1.0)
            p["dl2"].value = lins[0].values["dl2"]
        ends = ie.node_rates(cfg, q[[0, -1]], None if self.paths is None else self.paths[[0, -1]])
        for k, lin in enumerate(lins):
            a = shares[k, 1:-1]
            if self.paths is not None:
                g = (self.paths[1:-1, k] - np.asarray(cfg.ios_center[:2])) / scale
                p[f"gx_{k}"].value, p[f"gy_{k}"].value = g[:, 0], g[:, 1]
                p[f"g0_{k}"].value = (g * g).sum(axis=1) + (cfg.uav_altitude / scale) ** 2
            p[f"gl2_{k}"].value = lin.values["gl2"]
            p[f"cd_{k}"].value = a * lin.values["cd"]
            # per-slot value of the surrogate at q^l: the exact rate where the surface term is
            # modelled (anchoring), the direct-link rate where it is dropped
            exact, direct = self._node_rates(k, qi)
            value = np.where(lin.active, exact, np.log2(1.0 + cfg.eta * direct * direct))
            p[f"c0_{k}"].value = float((a @ value + shares[k, [0, -1]] @ ends[k]) / cfg.N)
            if self.has_surface:
                p[f"cb_{k}"].value = a * lin.values["cb"]
                p[f"cc_{k}"].value = a[:, None] * lin.values["cc"]

    def solve(self) -> tuple[np.ndarray | None, float, str]:
        """Solve at the current point: (trajectory or None, surrogate value, status)."""
        cfg = self.config
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            self._problem.solve(solver=self.solver, warm_start=False)
        status = str(self._problem.status)
        xi, psi = self._vars["xi"].value, self._vars["psi"].value
        if status not in OK_STATUSES or xi is None or psi is None:
            return None, float("nan"), status
        interior = np.column_stack([xi, psi]) * LENGTH_SCALE + cfg.ios_center[:2]
        q = np.vstack([np.asarray(cfg.q0, float), interior, np.asarray(cfg.qF, float)])
        return q, float(self._problem.value), status


class _Lin:
    """A node's surrogate values and active slots at q^l (``Surrogate.linearise``'s fields)."""

    def __init__(self, values: dict[str, np.ndarray], active: np.ndarray):
        self.values, self.active = values, active


def _step(
    surrogate: MultiSurrogate, q: np.ndarray, shares: np.ndarray
) -> tuple[np.ndarray | None, float, str]:
    """One trajectory step for fixed shares (the surrogate problem at q)."""
    surrogate.set_point(q, shares)
    return surrogate.solve()


def _run(
    surrogate: MultiSurrogate, q: np.ndarray, start: str, max_iters: int, tol: float, history: list[dict]
) -> tuple[np.ndarray, float, np.ndarray, int, str]:
    """BCD from one start: (best trajectory, its score, its shares, solves, stop reason)."""
    config, paths = surrogate.config, surrogate.paths
    best = ie.schedule(config, q, paths)
    history.append({"start": start, "iteration": 0, "score": best.value, "surrogate": None,
                    "status": "init", "accepted": True})  # fmt: skip
    stop, n = "max_iters", 0
    for it in range(1, max_iters + 1):
        n = it
        try:
            q_new, value, status = _step(surrogate, q, best.shares)
        except Exception as exc:  # a solver failure keeps the last iterate
            q_new, value, status = None, float("nan"), f"solver_error: {type(exc).__name__}: {exc}"
        record: dict[str, Any] = {"start": start, "iteration": it, "score": None, "surrogate": value,
                                  "status": status, "accepted": False}  # fmt: skip
        history.append(record)
        if q_new is None:
            stop = "solver_error"
            break
        if not ie.check_trajectory(config, q_new).feasible:
            record["status"] = f"infeasible_iterate ({status})"
            stop = "infeasible_iterate"
            break
        new = ie.schedule(config, q_new, paths)  # block 1: the best shares of the new trajectory
        record["score"] = new.value
        rel = (new.value - best.value) / max(abs(best.value), 1e-300)
        if rel < 0:  # the monotonicity check: never accept a lower exact score
            stop = "decrease" if rel < -DECREASE_TOL else "converged"
            break
        record["accepted"] = True
        q, best = q_new, new
        if rel < tol:
            stop = "converged"
            break
    return q, best.value, best.shares, n, stop


def default_starts(
    config: ScenarioConfig, paths: np.ndarray | None = None, tour_plan: Plan | None = None
) -> list[tuple[str, np.ndarray]]:
    """The tour's plan; a DP-derived plan (the tour through the hover points of the grid DP's
    path for f_w at the tour's dual weights, and the nodes' peaks); fly-hover-fly over the
    tour's all-node compromise point(s). Starts equal to an earlier one are dropped. With
    moving nodes' ``paths``: the clairvoyant tour and the fly-hover-fly flights (module doc).
    ``tour_plan``: the tour's plan (``baselines.tour.solve(config, paths=paths)``) when the caller
    has it (it is not solved again)."""
    from baselines.dp_bound import hover_points, weighted_dp_path
    from baselines.fixed import fly_hover_fly_path
    from baselines.tour import solve as tour_solve
    from baselines.tour import tour_of

    plan = tour_of(config, paths, tour_plan)
    starts = [("tour", plan.trajectory)]
    path = (
        None if paths is not None else weighted_dp_path(config, ie.schedule(config, plan.trajectory).weights)
    )
    if path is not None:
        peaks = [(n, p) for n, p in plan.info["candidates"].items() if n.startswith("peak")]
        routed = tour_solve(config, candidates=peaks + hover_points([path], config.K)).trajectory
        if not np.array_equal(routed, plan.trajectory):
            starts.append(("tour-dp-hovers", routed))
    mids = [
        name for name in plan.info["candidates"] if name.count("-") == config.K - 1 and name.startswith("mid")
    ]
    for name in mids:
        starts.append((f"fhf-{name}", fly_hover_fly_path(config, plan.info["candidates"][name])[0]))
    return starts


def solve(
    config: ScenarioConfig,
    *,
    tiles: int = 2,
    init: Any = None,
    max_iters: int = 30,
    tol: float = 1e-4,
    solver: str = "CLARABEL",
    progress: bool = False,
    paths: np.ndarray | None = None,
    tour_plan: Plan | None = None,
) -> Plan:
    """Max-min trajectory and shares for K >= 2 nodes by BCD with the paper's SCA (module doc).

    ``paths`` (N, K, 2) m: the nodes' true paths, known in advance (module doc, "On node
    paths"); every score, and the plan's, is on them. ``tour_plan``: the tour's plan of
    ``config`` on them (``baselines.tour.solve(config, paths=paths)``) when the caller has it:
    the starts are built from it instead of solving the tour again.

    ``init``: extra feasible (N, 2) trajectories or Plans to start from (added to
    :func:`default_starts`). Returns a :class:`Plan` (scheme "ia"/"ra"/"cuc" by surface) with
    ``info["shares"]`` (the winning schedule), ``info["starts"]`` (per-start summaries) and
    ``history`` (every solve's exact score; accepted scores never decrease within a start).
    """
    t_start = time.perf_counter()
    check_planner("sca-multi", config, paths)
    if isinstance(tiles, bool) or not isinstance(tiles, int) or not 1 <= tiles <= 64:
        raise ValueError(f"tiles must be an integer in [1, 64] (nodes per axis), got {tiles!r}")
    if isinstance(max_iters, bool) or not isinstance(max_iters, int) or max_iters < 1:
        raise ValueError(f"max_iters must be an integer >= 1, got {max_iters!r}")
    if not (isinstance(tol, (int, float)) and math.isfinite(tol) and tol > 0):
        raise ValueError(f"tol must be a finite number > 0, got {tol!r}")
    if init is None:
        extra = []
    else:
        extra = [init] if (hasattr(init, "trajectory") or np.ndim(init) == 2) else list(init)
    given = []
    for i, item in enumerate(extra):
        q = np.asarray(getattr(item, "trajectory", item), dtype=float)
        if q.shape != (config.N, 2) or not ie.check_trajectory(config, q).feasible:
            raise ValueError(f"init[{i}] must be a feasible (N={config.N}, 2) trajectory")
        given.append((f"init{i}", q))
    from baselines.tour import moving_paths, plan_on_paths

    moving = moving_paths(config, paths)
    starts = default_starts(config, moving, tour_plan) + given
    surrogate = MultiSurrogate(config, tiles, solver.upper(), moving)
    history: list[dict[str, Any]] = []
    summaries = []
    best: tuple[float, np.ndarray, np.ndarray, str] | None = None
    for name, q0 in starts:
        t0 = time.perf_counter()
        init_score = ie.maxmin_rate(config, q0, moving)
        q, score, shares, n, stop = _run(surrogate, q0, name, max_iters, tol, history)
        summaries.append({"start": name, "init_score": init_score, "score": score, "iters": n, "stop": stop,
                          "seconds": time.perf_counter() - t0})  # fmt: skip
        if progress:
            print(f"[sca-multi] {name:<16} {init_score:.6f} -> {score:.6f}  {n:3d} it  {stop}", flush=True)
        if best is None or score > best[0]:
            best = (score, q, shares, name)
    assert best is not None
    info = {"start": best[3], "starts": summaries, "tiles": tiles, "solver": solver.upper()}
    scheme = SCHEME_NAMES[config.surface]
    if moving is None:
        return Plan.from_trajectory(
            scheme, config, best[1], time.perf_counter() - t_start, history=history, info=info
        )
    plan = plan_on_paths(scheme, config, best[1], time.perf_counter() - t_start, moving, info)
    plan.history = history
    return plan
