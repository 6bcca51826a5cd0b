"""Energy-aware trajectories on the DP grid: the best energy efficiency (Dinkelbach) and the best
average rate under an energy budget (Lagrangian), one ground node.

Both are built on one parametric problem over the grid paths of :mod:`baselines.dp` (the same
grid anchored at q0, the same box, the moves the grid offsets within D, the last move onto qF
exactly):

    F(lam) = max_q  B dt sum_{n=1}^{N} r(q[n])  -  lam E(q),   E(q) = dt sum_n P(|q[n+1] - q[n]| / dt)

(bits minus lam joules; P the scenario's propulsion power, ``ios_uav_env.propulsion_power``).
The energy of a move depends only on its length, so the backward recursion of the rate DP gains a
cost per offset:

    V_{N-1}(c) = w(c) + w(qF) - lam dt P(|qF - c| / dt)       if |c - qF| <= D, else -inf
    V_n(c)     = w(c) + max_o [ V_{n+1}(c + o) - lam dt P(|o| / dt) ],    w(c) = B dt r(c)

and F(lam) = w(q0) + max_o [V_2(q0 + o) - lam dt P(|o| / dt)], exact over the grid paths. The
running-maximum trick of the rate DP needs a cost-free disk, so here the maximum is taken ring by
ring: the offsets of one length share one cost, each ring's maximum of shifted copies is taken
cost-free and the ring's cost subtracted once. Ties go to the first offset in the rate DP's order
(shortest, then smallest (dy, dx)).

**Energy efficiency (Dinkelbach).** EE(q) = bits(q) / E(q). Starting from lam_0 = the EE of a
feasible plan (the better of the straight line and the fly-hover-fly over G), each step solves
F(lam_k) with plan q_k and sets lam_{k+1} = EE(q_k). Monotone convergence: F is a maximum of affine
functions of lam with slopes -E(q) < 0, so it is convex and strictly decreasing, and its root is
lam* = the best EE over the grid paths. Since q_{k-1} itself gives bits - lam_k E = 0, F(lam_k) >= 0,
and lam_{k+1} = lam_k + F(lam_k) / E(q_k) >= lam_k, with equality only when F(lam_k) = 0, i.e. at
lam*; every lam_k is the EE of a grid path, so lam_k <= lam*. The sequence therefore increases
monotonically to lam* (superlinearly, Dinkelbach 1967, Schaible 1976) and, the grid paths being
finitely many, ends. Certificate: every path has bits(q) - lam_k E(q) <= F(lam_k) and E(q) >= E_least
(``ScenarioConfig.least_energy``), so lam* <= lam_k + F(lam_k) / E_least. The loop stops when
F(lam_k) <= tol lam_k E_least, i.e. when this certified relative gap to the grid optimum is <= tol
(``info["ee_gap"]``); the plan returned is the last one, of EE >= lam_k.

**Budget (Lagrangian).** max bits(q) s.t. E(q) <= E_max: for mu >= 0 the plan of F(mu) maximises
bits - mu E. If mu = 0 (the rate DP) meets the budget, it is optimal. Otherwise mu is bracketed,
[mu_lo, mu_hi] with the plan at mu_lo over the budget and the one at mu_hi within it, and the
bracket is cut (a bisection whose cut is where the two plans' Lagrangians cross,
mu_x = (bits_lo - bits_hi) / (E_lo - E_hi), not the midpoint): a new plan replaces the end on
its side of the budget, and when F(mu_x) exceeds the two lines' common value by no more than
``tol`` bits the two plans are neighbouring vertices of the upper convex hull of the grid paths'
(E, bits) points, mu_x minimises the dual and the search ends (finitely). The plan returned is the
feasible one, the best point of the hull within the budget. The dual gives a certified bound on
every grid path within the budget, min_mu (F(mu) + mu E_max) / (B T) bps/Hz (``info["dual_bound"]``);
the gap to the plan (``info["dual_gap"]``) is the price of the Lagrangian: a grid path between
two hull vertices (using the budget better) may exist, and the Lagrangian cannot see it.

**Move set and grid step.** With an energy cost the best plan loiters near the rate peak at about
the minimum-power speed V_mp (``ios_uav_env.min_power_speed``, 10.2 m/s for the Table I constants)
instead of hovering (P(0) = 168 W > P(V_mp) = 126 W): with no cost for turning, going back and
forth between two cells about V_mp dt apart across the peak is as good as any circle. The grid
must therefore offer moves of about V_mp dt: the offsets have lengths resolution x sqrt(a^2 + b^2),
and at the default 2.5 m there are moves of 10 m and 10.31 m (a^2 + b^2 = 16, 17), about 2 % and
1 % from V_mp dt. A coarser grid (5 m: 10 m, 11.18 m) still has a move near V_mp dt but places the
loiter points farther from the peak and the legs on coarser headings, so its EE is lower; the value
converges to the continuous optimum as the step goes to 0 (and ``margin`` grows), as for the rate
DP. The box and its ``margin`` are the rate DP's.

**Several nodes.** K = 1 only here: the per-slot reward of the max-min rate is not a sum over
slots. ``baselines.dp_energy_multi`` runs this parametric DP on the dual of the schedule (per-cell
bits B dt max_k w_k r_k) for the EE of K > 1 nodes.

**Parity.** Each plan is scored by ``ios_uav_env.score_plan`` (``Plan.from_trajectory``), and
the DP's own bits - lam E of the returned plan is checked against the score (1e-9).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from baselines.fixed import fly_hover_fly_path, straight_line_path
from baselines.grid import (
    DEFAULT_MARGIN,
    check_grid_bytes,
    disk_offsets,
    grid_axes,
    rate_map,
    validate_grid_args,
)
from baselines.plan import Plan
from baselines.registry import check as check_planner
from ios_uav_env import ScenarioConfig, energy, propulsion_power, score_plan, slot_rates

__all__ = ["Grid", "parametric_path", "solve", "solve_budget", "solve_ee"]


def _bits(config: ScenarioConfig, q: np.ndarray) -> float:
    """B dt sum_n r(q[n]) (bits) of a trajectory, by the one scorer (B T mean rate)."""
    return config.bandwidth_hz * config.T * score_plan(config, q).rate


def _rings(resolution: float, radius: float) -> list[tuple[float, np.ndarray]]:
    """The disk's offsets grouped by length: [(length m, offsets (k, 2)), ...], shortest first."""
    off = disk_offsets(resolution, radius)
    sq = off[:, 0] ** 2 + off[:, 1] ** 2
    return [(resolution * math.sqrt(s), off[sq == s]) for s in np.unique(sq)]


def _shifted_max(
    values: np.ndarray, rings: Sequence[tuple[float, np.ndarray]], costs: np.ndarray
) -> np.ndarray:
    """out[y, x] = max over offsets o of values[(y, x) + o] - cost(|o|) (-inf outside the grid)."""
    ny, nx = values.shape
    out = np.full_like(values, -np.inf)
    ring = np.empty_like(values)
    for (_, offsets), cost in zip(rings, costs, strict=True):
        ring.fill(-np.inf)
        for dy, dx in offsets:
            dst = (slice(max(0, -dy), ny - max(0, dy)), slice(max(0, -dx), nx - max(0, dx)))
            src = (slice(max(0, dy), ny - max(0, -dy)), slice(max(0, dx), nx - max(0, -dx)))
            np.maximum(ring[dst], values[src], out=ring[dst])
        ring -= cost
        np.maximum(out, ring, out=out)
    return out


def _best_move(layer: np.ndarray, cell: tuple[int, int], offsets: np.ndarray, costs: np.ndarray):
    """First (in offset order) argmax over o of layer[cell + o] - cost[o]; None if all -inf."""
    cand = offsets + np.asarray(cell)
    ok = (cand[:, 0] >= 0) & (cand[:, 0] < layer.shape[0]) & (cand[:, 1] >= 0) & (cand[:, 1] < layer.shape[1])
    cand, cost = cand[ok], costs[ok]
    vals = layer[cand[:, 0], cand[:, 1]] - cost
    i = int(np.argmax(vals))
    return None if not np.isfinite(vals[i]) else (int(cand[i, 0]), int(cand[i, 1]))


class Grid:
    """The grid, its per-cell bits and the move lengths of one scenario, built once per solve.

    ``bits`` (ny, nx) and ``bits_f``: the per-cell and final bits of the parametric problem
    (default: one node's, B dt r(c) and B dt r(qF)); ``baselines.dp_energy_multi`` gives its
    weighted f_w instead."""

    def __init__(
        self,
        config: ScenarioConfig,
        resolution: float,
        margin: float,
        bits: np.ndarray | None = None,
        bits_f: float | None = None,
    ) -> None:
        if bits is None:
            config.require_single_node("the energy DP")
        validate_grid_args(config, resolution, margin)
        if config.N < 3:
            raise ValueError(f"the energy DP needs N >= 3 slots (a free way-point), got N={config.N}")
        check_grid_bytes(
            config,
            resolution,
            margin,
            8 * (config.N - 2),
            "value table (N - 2 float64 layers)",
            largest=config.D,
        )
        self.config, self.resolution, self.margin = config, float(resolution), float(margin)
        self.xs, self.ys, self.start = grid_axes(config, resolution, margin)
        scale = config.bandwidth_hz * config.dt
        q_f = np.asarray(config.qF, dtype=float)
        if bits is None:
            bits = scale * rate_map(config, resolution, margin)[2]  # w(c) = B dt r(c)
            bits_f = scale * float(slot_rates(config, q_f)[0])
        if bits.shape != (len(self.ys), len(self.xs)) or bits_f is None:
            raise ValueError(f"bits must have the grid's shape {(len(self.ys), len(self.xs))} with bits_f")
        self.bits, self.bits_f = bits, float(bits_f)
        self.rings = _rings(resolution, config.D)
        self.offsets = disk_offsets(resolution, config.D)  # the forward pass's order
        lengths = resolution * np.hypot(self.offsets[:, 0], self.offsets[:, 1])
        self.move_energy = config.dt * propulsion_power(lengths / config.dt, config.propulsion)
        self.ring_energy = config.dt * propulsion_power(
            np.array([r for r, _ in self.rings]) / config.dt, config.propulsion
        )
        to_f = np.hypot(self.xs[None, :] - q_f[0], self.ys[:, None] - q_f[1])
        self.near_f = to_f <= config.D
        self.last_energy = config.dt * propulsion_power(
            np.where(self.near_f, to_f, 0.0) / config.dt, config.propulsion
        )


def parametric_path(grid: Grid, lam: float) -> tuple[np.ndarray, float]:
    """The grid path maximising bits - ``lam`` E (bits/J) and that value (module docstring)."""
    config = grid.config
    n = config.N
    values = np.empty((n - 2, *grid.bits.shape))
    values[-1] = np.where(grid.near_f, grid.bits + grid.bits_f - lam * grid.last_energy, -np.inf)
    ring_costs = lam * grid.ring_energy
    for k in range(n - 4, -1, -1):
        values[k] = grid.bits + _shifted_max(values[k + 1], grid.rings, ring_costs)
    costs = lam * grid.move_energy
    cell = _best_move(values[0], grid.start, grid.offsets, costs)
    if cell is None:
        d = config.D
        raise ValueError(
            f"no grid path reaches qF={config.qF} from q0={config.q0} in N - 1 = {n - 1} moves at "
            f"resolution={grid.resolution:g} m: use a finer resolution (one that divides D={d:g} m, e.g. "
            f"{d / math.ceil(d / grid.resolution):g} m) or a larger T"
        )
    d_first = grid.resolution * math.hypot(cell[0] - grid.start[0], cell[1] - grid.start[1])
    first_cost = lam * config.dt * propulsion_power(d_first / config.dt, config.propulsion)
    total = float(grid.bits[grid.start] + values[0][cell] - first_cost)
    path = [grid.start, cell]
    for k in range(1, n - 2):
        path.append(_best_move(values[k], path[-1], grid.offsets, costs))
    idx = np.array(path)
    traj = np.vstack(
        [np.column_stack([grid.xs[idx[:, 1]], grid.ys[idx[:, 0]]]), np.asarray(config.qF, float)]
    )
    return traj, total


def _check_parity(config: ScenarioConfig, traj: np.ndarray, lam: float, value: float) -> None:
    own = _bits(config, traj) - lam * energy(config, traj)
    if abs(own - value) > 1e-9 * max(1.0, abs(own), lam * energy(config, traj)):
        raise RuntimeError(f"energy DP value {value!r} != the scorer's bits - lam E {own!r}")


def _start_lambda(config: ScenarioConfig) -> float:
    plans = (straight_line_path(config), fly_hover_fly_path(config)[0])
    return max(score_plan(config, q).energy_efficiency for q in plans)


def solve_ee(
    config: ScenarioConfig,
    resolution: float = 2.5,
    margin: float = DEFAULT_MARGIN,
    tol: float = 1e-9,
    max_iter: int = 50,
) -> Plan:
    """The grid path of the best energy efficiency (bits/J), by Dinkelbach's method (module
    docstring); K = 1 only.

    ``resolution``, ``margin``: the rate DP's grid (m). ``tol``: the certified relative gap
    to the grid optimum at which the iteration stops, F(lam) <= tol lam E_least. Returns the
    plan as scheme ``"dp-ee"``; ``info`` holds ``lambda`` (bits/J, the last lam_k),
    ``ee_gap`` (the certified relative gap), ``iterations``, ``history`` (lam_k and F(lam_k) per
    step), ``resolution``, ``margin``, ``grid_shape``. ``ValueError`` for K > 1, bad grid
    arguments or a tolerance outside (0, 1); ``RuntimeError`` if ``max_iter`` steps do not reach it.
    """
    t0 = time.perf_counter()
    if not (isinstance(tol, (int, float)) and 0 < tol < 1):
        raise ValueError(f"tol must be a number in (0, 1), got {tol!r}")
    check_planner("dp-ee", config)
    grid = Grid(config, resolution, margin)
    e_least = config.least_energy()
    lam, history = _start_lambda(config), []
    for k in range(1, max_iter + 1):
        traj, value = parametric_path(grid, lam)
        _check_parity(config, traj, lam, value)
        gap = max(value, 0.0) / (lam * e_least)
        history.append({"iteration": k, "lambda": lam, "F": value, "ee_gap": gap})
        if gap <= tol:
            break
        lam = score_plan(config, traj).energy_efficiency
    else:
        raise RuntimeError(
            f"Dinkelbach did not reach tol={tol:g} in max_iter={max_iter} steps (gap {gap:.3g})"
        )
    info = {
        "lambda": lam, "ee_gap": gap, "iterations": k, "resolution": float(resolution),
        "margin": float(margin), "grid_shape": list(grid.bits.shape),
    }  # fmt: skip
    return Plan.from_trajectory("dp-ee", config, traj, time.perf_counter() - t0, history=history, info=info)


def solve_budget(
    config: ScenarioConfig,
    budget: float | None = None,
    resolution: float = 2.5,
    margin: float = DEFAULT_MARGIN,
    tol: float = 1e-9,
    max_iter: int = 60,
) -> Plan:
    """The best average rate within an energy budget (J) on the grid, by the Lagrangian of the
    module docstring; K = 1 only.

    ``budget``: E_max in J (default ``config.energy_budget_j``; one of the two must be set; the
    plan is scored on ``config`` with ``energy_budget_j = budget``). ``tol``: how far F(mu_x) may
    exceed the bracketing plans' common value, relative to the feasible plan's bits, when the
    search ends (``max_iter`` DP solves at most; the plan returned is always within the budget).
    Returns scheme ``"dp-budget"``; ``info`` holds ``mu`` (bits/J), ``dual_bound`` (bps/Hz, no
    grid path within the budget beats it), ``dual_gap`` (dual_bound / mean_rate - 1),
    ``iterations``, ``budget_active``.
    ``ValueError`` when no grid path meets the budget (the least-energy grid path is named).
    """
    t0 = time.perf_counter()
    if budget is not None:  # else config.energy_budget_j, which the registry requires to be set
        config = config.replace(energy_budget_j=float(budget))
    check_planner("dp-budget", config)
    budget = config.energy_budget_j
    if not (isinstance(tol, (int, float)) and 0 < tol < 1):
        raise ValueError(f"tol must be a number in (0, 1), got {tol!r}")
    grid = Grid(config, resolution, margin)
    scale = config.bandwidth_hz * config.T

    def at(mu: float) -> dict[str, Any]:
        traj, value = parametric_path(grid, mu)
        _check_parity(config, traj, mu, value)
        return {"mu": mu, "traj": traj, "F": value, "bits": _bits(config, traj), "E": energy(config, traj)}

    evaluated = [at(0.0)]
    lo = hi = None
    if evaluated[0]["E"] <= budget:
        hi = evaluated[0]
    else:  # bracket: raise mu by 4x until a plan meets the budget (up to 4^12 x the EE scale)
        lo = evaluated[0]
        mu = lo["bits"] / lo["E"]
        for _ in range(13):
            point = at(mu)
            evaluated.append(point)
            if point["E"] <= budget:
                hi = point
                break
            lo, mu = point, 4.0 * mu
        if hi is None:
            raise ValueError(
                f"energy_budget_j={budget:.10g} J: no grid path of resolution={resolution:g} m meets it (the "
                f"least energy found is {lo['E']:.10g} J, at mu={lo['mu']:.3g} bits/J): refine the grid or "
                "raise the budget"
            )
        while len(evaluated) < max_iter:
            mu_x = (lo["bits"] - hi["bits"]) / (lo["E"] - hi["E"])
            point = at(mu_x)
            evaluated.append(point)
            if (
                point["F"] <= lo["bits"] - mu_x * lo["E"] + tol * hi["bits"]
            ):  # no plan above both: a hull edge
                break
            if point["E"] <= budget:
                hi = point
            else:
                lo = point
    dual = min(p["F"] + p["mu"] * budget for p in evaluated) / scale
    info = {
        "mu": hi["mu"], "dual_bound": dual, "dual_gap": dual / (hi["bits"] / scale) - 1.0,
        "iterations": len(evaluated), "budget": float(budget), "budget_active": lo is not None,
        "resolution": float(resolution), "margin": float(margin),
    }  # fmt: skip
    history = [{k: p[k] for k in ("mu", "F", "bits", "E")} for p in evaluated]
    return Plan.from_trajectory(
        "dp-budget", config, hi["traj"], time.perf_counter() - t0, history=history, info=info
    )


def solve(
    config: ScenarioConfig, resolution: float = 2.5, margin: float = DEFAULT_MARGIN, **kwargs: Any
) -> Plan:
    """The energy DP of ``config``'s problem: :func:`solve_budget` when it sets
    ``energy_budget_j`` (the best rate within the budget), else :func:`solve_ee` (the best
    energy efficiency); ``kwargs`` go to that function. A rate config without a budget, or an
    energy-efficiency config with one, is refused (``baselines.registry``)."""
    check_planner("dp-budget" if config.energy_budget_j is not None else "dp-ee", config)
    if config.energy_budget_j is not None:
        return solve_budget(config, resolution=resolution, margin=margin, **kwargs)
    return solve_ee(config, resolution=resolution, margin=margin, **kwargs)
