r"""Several ground nodes, energy efficiency: the best plan the grid DP finds and a certified bound.

The problem (``ios_uav_env.score_plan`` with ``objective="energy_efficiency"`` and K > 1):

    EE(q) = B T V(q) / E(q),   V(q) = min_k R_k (the best TDMA schedule's max-min rate, bps/Hz)

(bits/J; E the flight's propulsion energy). It joins the two machineries the single-objective
planners use: Dinkelbach's parametric problem of ``baselines.dp_energy`` and the dual of the
max-min schedule of ``baselines.dp_bound``.

**Duality, slot by slot.** For a fixed trajectory the schedule is an LP whose dual gives
(``ios_uav_env.model.schedule``), for every w in the simplex,

    B T V(q) <= B dt sum_{n=1}^{N} f_w(q[n]),   f_w(q) = max_k w_k r_k(q)     (T = N dt)

with equality at the schedule's optimal w. So for any lam >= 0 and any w

    B T V(q) - lam E(q) <= G(lam, w) = max_q' [ B dt sum_n f_w(q'[n]) - lam E(q') ]

and the right-hand side is exactly the single-node parametric DP of ``baselines.dp_energy``
(:func:`baselines.dp_energy.parametric_path`) with the per-cell bits B dt f_w(c) in place of
B dt r(c): exact over the grid paths (moves within D between grid points, the last one onto qF).

**Certificate.** Every feasible flight has E(q) >= E_least (``ScenarioConfig.least_energy``),
so for every grid path q, every lam and every w

    EE(q) <= lam + max(G(lam, w), 0) / E_least,

an upper bound on the best EE over the grid paths (``info["ee_upper_bound"]``, the least over
every (lam, w) visited). Unlike the single node's, it need not close: min_w max_q >= max_q
min_w (the max-min problem is not convex), so the gap left (``info["ee_gap"]``) is the price
of the dual as for the max-min rate's bound, plus the grid's.

**Plans.** G(lam, .) is convex in w (a maximum of functions linear in w); its minimum is sought
by Kelley's cutting planes: the DP's path q at w, with node k_n maximising w_k r_k(q[n]) in slot
n, gives the affine minorant G(lam, w') >= a . w' - lam E(q), a_k = B dt sum_{n: k_n = k}
r_k(q[n]), and the next w minimises the largest minorant over the simplex (an LP). Every path
found is a feasible plan, scored by the one scorer (its own best schedule); lam then moves to
the best EE found (Dinkelbach's update, which never decreases: each plan found at lam has
bits - lam E <= its G, and the best plan so far has EE = lam; the first lam is the EE of the
straight flight, which only sets the start). The iteration stops when the
certified relative gap is at most ``tol``, when a Dinkelbach step finds no better plan, or after
``max_iter`` steps; the plan returned is the best one found.

**Plans off the grid.** The weighted DP's path at one w serves the nodes that w favours; at the
w that balances them, several paths tie and the DP keeps one, so its plans can be far from the
best max-min flight. The tour heuristic (``baselines.tour``: hover points routed with an LP
schedule; the plan of the rate objective) competes, and so does each candidate with its hovers
turned into loiters (:func:`loiter_hovers`: hovering costs P(0), a back-and-forth at the
minimum-power speed V_mp costs P(V_mp) < P(0)). Every candidate is scored by ``score_plan``
and the best EE returned (``info["plan_source"]``). The certificate above covers the grid paths;
a plan off the grid is compared with it as information (``ee_gap``), not as a bound.

**Parity.** Each path's DP value is checked against B dt sum_n f_w(q[n]) - lam E(q) recomputed
from the model's node rates and energy (1e-9 relative).
"""

from __future__ import annotations

import copy
import math
import time
from typing import Any

import numpy as np

import ios_uav_env as ie
from baselines.dp_bound import kelley_step
from baselines.dp_energy import Grid, parametric_path
from baselines.fixed import straight_line_path
from baselines.grid import DEFAULT_MARGIN, check_grid_bytes, grid_axes, validate_grid_args
from baselines.plan import Plan
from baselines.registry import check as check_planner
from ios_uav_env import ScenarioConfig

__all__ = ["solve"]


class _Nodes:
    """The node rate maps of one scenario on the DP grid, and the weighted grids built from them."""

    def __init__(self, config: ScenarioConfig, resolution: float, margin: float) -> None:
        xs, ys, _ = grid_axes(config, resolution, margin)
        xx, yy = np.meshgrid(xs, ys)
        points = np.column_stack([xx.ravel(), yy.ravel()])
        self.scale = config.bandwidth_hz * config.dt
        self.maps = self.scale * ie.node_rates(config, points).reshape(config.K, *xx.shape)
        self.final = self.scale * ie.node_rates(config, np.array([config.qF], dtype=float))[:, 0]
        self.grid = Grid(config, resolution, margin, bits=self.maps[0], bits_f=float(self.final[0]))

    def weighted(self, w: np.ndarray) -> Grid:
        """The grid whose per-cell bits are B dt f_w(c)."""
        grid = copy.copy(self.grid)
        grid.bits = np.max(w[:, None, None] * self.maps, axis=0)
        grid.bits_f = float(np.max(w * self.final))
        return grid


def _cut(
    config: ScenarioConfig, traj: np.ndarray, w: np.ndarray, lam: float, value: float
) -> tuple[np.ndarray, float]:
    """The minorant of the path at w (module docstring): its slope a and its offset lam E(q),
    after checking the DP's value against them."""
    bits = config.bandwidth_hz * config.dt * ie.node_rates(config, traj)  # (K, N)
    choice = np.argmax(w[:, None] * bits, axis=0)
    offset = lam * ie.energy(config, traj)
    own = float(np.sum(bits[choice, np.arange(config.N)] * w[choice])) - offset
    if abs(own - value) > 1e-9 * max(1.0, abs(own), offset):
        raise RuntimeError(
            f"multi-node energy DP value {value!r} != the model's B dt sum f_w - lam E {own!r}"
        )
    return np.bincount(choice, weights=bits[choice, np.arange(config.N)], minlength=config.K), offset


def loiter_hovers(config: ScenarioConfig, traj: np.ndarray, direction: float) -> np.ndarray:
    """``traj`` with every hover (a run of equal way-points) flown as a back-and-forth between the
    hover point p and p + V_mp dt (cos, sin)(``direction``), ending at p: each move of the run then
    costs P(V_mp) instead of P(0) and stays within D; the moves into and out of the run are kept.
    An odd run keeps one hover slot. Returns a new (N, 2) array (the same when nothing hovers)."""
    q = np.array(traj, dtype=float)
    step = min(ie.min_power_speed(config.propulsion) * config.dt, config.D)
    u = step * np.array([math.cos(direction), math.sin(direction)])
    still = np.all(np.diff(q, axis=0) == 0.0, axis=1)  # move n (slot n -> n + 1) is a hover
    n = 0
    while n < len(still):
        if not still[n]:
            n += 1
            continue
        end = n
        while end < len(still) and still[end]:
            end += 1
        # slots n .. end sit at p; the interior slots n + 1 .. end - 1 alternate, slot end is p again
        for j in range(n + 1, end - (end - n) % 2, 2):
            q[j] = q[n] + u
        n = end
    return q


def _candidates(config: ScenarioConfig) -> list[tuple[str, np.ndarray]]:
    """The tour heuristic's plan of the rate objective (``baselines.tour``)."""
    from baselines import tour

    return [("tour", tour.solve(config.replace(objective="rate")).trajectory)]


def solve(
    config: ScenarioConfig,
    resolution: float = 5.0,
    margin: float = DEFAULT_MARGIN,
    tol: float = 1e-4,
    max_iter: int = 20,
    max_cuts: int = 12,
) -> Plan:
    """K >= 2, objective ``"energy_efficiency"``: the best plan found on the DP grid and a certified
    upper bound of the best EE over the grid paths (module docstring).

    ``resolution``, ``margin``: the DP grid (m; ``baselines.dp_energy``'s). ``tol``: the relative
    certified gap at which to stop. ``max_iter``: Dinkelbach steps; ``max_cuts``: Kelley cuts per
    step. Returns scheme ``"dp-ee-multi"``; ``info``: ``ee_upper_bound`` (bits/J), ``ee_gap``
    (ee_upper_bound / EE - 1), ``lambda`` (the last lam), ``weights`` (the w of the best bound),
    ``history`` (per step: lam, the least G found, Kelley's lower value, the step's best EE).
    """
    t0 = time.perf_counter()
    check_planner("dp-ee-multi", config)
    if not (isinstance(tol, (int, float)) and 0 < tol < 1):
        raise ValueError(f"tol must be a number in (0, 1), got {tol!r}")
    for name, value in (("max_iter", max_iter), ("max_cuts", max_cuts)):
        if not (isinstance(value, int) and value >= 1):
            raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    validate_grid_args(config, resolution, margin)
    if config.N < 3:
        raise ValueError(f"the energy DP needs N >= 3 slots (a free way-point), got N={config.N}")
    per_cell = 8 * (config.N - 2 + config.K + 1)  # the value table, the K node maps and f_w
    check_grid_bytes(config, resolution, margin, per_cell, "value table and node maps", largest=config.D)
    nodes = _Nodes(config, resolution, margin)
    e_least = config.least_energy()
    # lam starts at a feasible flight's EE (the straight line, off the grid in general: it only
    # sets the start, so every plan returned, and every plan the bound covers, is a grid path)
    lam = ie.score_plan(config, straight_line_path(config)).energy_efficiency
    best_traj, best_ee, w = None, -math.inf, np.full(config.K, 1.0 / config.K)
    upper, upper_w, history = math.inf, w, []
    for _ in range(max_iter):
        slopes, costs, least_g, lower, step_best = [], [], math.inf, -math.inf, -math.inf
        for _ in range(max_cuts):
            traj, value = parametric_path(nodes.weighted(w), lam)
            slope, offset = _cut(config, traj, w, lam, value)
            slopes.append(slope)
            costs.append(offset)
            ee = ie.score_plan(config, traj).energy_efficiency
            step_best = max(step_best, ee)
            if ee > best_ee:
                best_ee, best_traj = ee, traj
            if value < least_g:
                least_g, g_w = value, w
            w_next, lower = kelley_step(np.array(slopes), np.array(costs))
            if least_g - lower <= tol * lam * e_least:
                break
            w = w_next
        bound = lam + max(least_g, 0.0) / e_least
        if bound < upper:
            upper, upper_w = bound, g_w
        history.append({"lambda": lam, "G": least_g, "kelley_lower": lower, "best_ee": step_best})
        if upper <= best_ee * (1 + tol) or best_ee <= lam:
            break
        lam, w = best_ee, g_w
    source = "dp"
    found = [("dp", best_traj)] if best_traj is not None else []
    for name, traj in found + _candidates(config):
        for label, plan in [(name, traj)] + [
            (f"{name}-loiter{i}", loiter_hovers(config, traj, i * math.pi / 4)) for i in range(8)
        ]:
            ee = ie.score_plan(config, plan).energy_efficiency
            if ee > best_ee:
                best_ee, best_traj, source = ee, plan, label
    info: dict[str, Any] = {
        "plan_source": source,
        "ee_upper_bound": upper, "ee_gap": upper / best_ee - 1.0 if best_ee > 0 else math.inf,
        "lambda": lam, "weights": upper_w.tolist(), "iterations": len(history),
        "resolution": float(resolution), "margin": float(margin),
    }  # fmt: skip
    return Plan.from_trajectory(
        "dp-ee-multi", config, best_traj, time.perf_counter() - t0, history=history, info=info
    )
