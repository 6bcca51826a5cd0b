"""The convex surrogate (20) of SCA, built once per scenario with cvxpy and re-solved.

The derivation is in docs/planners.md ("How SCA works"). This module holds the numerics: the
linearisation of problem (15) at an iterate (:meth:`Surrogate.linearise`, numpy, using the
model's :func:`ios_uav_env.model.channel.surface_terms` on the tiled config) and the cvxpy problem
(:meth:`Surrogate.solve`). With ``dpp=True`` (default) every linearisation point and
coefficient is a :class:`cvxpy.Parameter`: the problem is canonicalised once and each
iteration only rewrites the parameter values; ``dpp=False`` rebuilds the problem with
constants at every iteration (kept to measure the difference).

Units seen by the solver: lengths in ``LENGTH_SCALE`` = 100 m; the slacks are offsets from
their values at the linearisation point (s' = s - s^l, u' = u - u^l, v' = v - v^l, all 0
there); the objective coefficients are dimensionless derivatives of the rate (<= 2 / ln 2
per slot, divided by N). No raw amplitude (~1e-5), eta (1e10) or |x|^3 (1e8 m^3) reaches
the solver.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass
from typing import Any

import cvxpy as cp
import numpy as np

import ios_uav_env as ie
from ios_uav_env import ScenarioConfig
from ios_uav_env.model import channel as ch
from ios_uav_env.model import surface as surf

#: Length unit (m) of the solver's variables.
LENGTH_SCALE = 100.0
#: Slots with |x - x_c| below this (m) drop their (tiny) surface term for the iteration.
PLANE_TOL = 0.1
#: Inward margin (m) on the step constraint |q[n] - q[n-1]| <= D - STEP_MARGIN (or the
#: current step, if longer: see ``Surrogate.linearise``).
STEP_MARGIN = 1e-6
#: Bounds on the slack offsets: s' >= -SLACK_BOUND, v' >= -SLACK_BOUND, u' <= U_BOUND (see _assemble).
SLACK_BOUND = 10.0
U_BOUND = 10.0
#: Solver statuses whose solution is used (it is still checked for feasibility).
OK_STATUSES = ("optimal", "optimal_inaccurate")
#: A plan's scheme name by surface: the paper's IA, RA and CUC, and "sta" (a STAR surface).
SCHEME_NAMES = {"ios": "ia", "ris": "ra", "none": "cuc", "star": "sta"}


def tiled_config(config: ScenarioConfig, tiles: int) -> ScenarioConfig:
    """``config`` with exactly ``tiles`` x ``tiles`` surface nodes (no accuracy floor): the
    coarse model of the surrogate's curvature (its value is anchored to the exact model)."""
    return config.replace(quadrature_nodes=tiles, quadrature_tol=math.inf)


@dataclass
class Linearisation:
    """Problem (20) at one iterate q^l: its parameter values and the surrogate's constant."""

    values: dict[str, np.ndarray]  # parameter name -> value (scaled units)
    constant: float  # (1/N) sum_n f_n(q^l): the surrogate's value at q^l
    active: np.ndarray  # (N - 2,) bool: interior slots whose surface term is modelled
    anchor: np.ndarray  # (N - 2,) exact / tiled surface amplitude at q^l (1 where inactive)


class Surrogate:
    """Problem (20) for one scenario and tile count: linearise at q^l, solve, return q^(l+1)."""

    def __init__(
        self,
        config: ScenarioConfig,
        tiles: int,
        solver: str,
        dpp: bool = True,
        solver_options: dict[str, Any] | None = None,
    ):
        self.config = config
        self.tiled = tiled_config(config, tiles)
        self.solver = solver
        self.dpp = dpp
        self.warm_start = False  # see solve(): cvxpy's in-place Clarabel update can fail
        self.solver_options = dict(solver_options or {})
        self.has_surface = config.surface != "none"
        nodes = surf.surface_nodes(self.tiled)
        if self.has_surface and not np.all(nodes.weight > 0):
            # c_k > 0 is what makes (15a) a convex (log-sum-exp) function of (s, u, v)
            raise ValueError(f"tiles={tiles} gives non-positive node weights; use another tile count")
        self.node_y, self.node_z = nodes.y, nodes.z
        self.n_tiles = nodes.weight.size if self.has_surface else 0
        self.m = config.N - 2  # interior slots: q[1] = q0 and q[N] = qF are constants
        self.compiled = False  # DPP: canonicalised (at the first solve)
        self.compile_seconds = 0.0  # DPP: build + canonicalisation time paid at the first solve
        self._params: dict[str, cp.Parameter] = {}
        self._problem: cp.Problem | None = None
        if dpp and self.m > 0:
            t0 = time.perf_counter()
            self._params = self._make_parameters()
            self._problem, self._vars = self._assemble(self._params)
            self.compile_seconds = time.perf_counter() - t0

    # --- the problem ------------------------------------------------------------------
    def _shapes(self) -> dict[str, tuple[int, ...]]:
        m, k = self.m, self.n_tiles
        shapes: dict[str, tuple[int, ...]] = {"gl2": (m,), "cd": (m,), "dmax": (m + 1,)}
        if self.has_surface:
            shapes.update({"sg": (m,), "sh": (m,), "dl2": (m, k), "cb": (m,), "cc": (m, k)})
        return shapes

    def _make_parameters(self) -> dict[str, cp.Parameter]:
        return {name: cp.Parameter(shape, name=name) for name, shape in self._shapes().items()}

    def _assemble(self, p: dict[str, Any]) -> tuple[cp.Problem, dict[str, cp.Variable]]:
        """Problem (20) in scaled units with parameters (or constants) ``p``.

        Coordinates are relative to the IOS centre, in LENGTH_SCALE: xi = (x - x_c) / L,
        psi = (y - y_c) / L. Every squared distance of (18)-(19) is affine in
        (xi, psi, X2, Y2) with the epigraph variables X2 >= xi^2, Y2 >= psi^2 (exact: the
        distances only appear on the small side of <= constraints), so the cone count is two
        per slot whatever the number of tiles.
        """
        cfg, scale, m = self.config, LENGTH_SCALE, self.m
        xc, yc = cfg.ios_center[0], cfg.ios_center[1]
        xi, psi = cp.Variable(m, name="xi"), cp.Variable(m, name="psi")
        x2, y2 = cp.Variable(m, name="X2"), cp.Variable(m, name="Y2")
        v = cp.Variable(m, name="v")  # v' = v - v^l, e^v <= d_UG^(-alpha/2)
        (x0, y0), (xf, yf) = (np.asarray(cfg.q0) - (xc, yc)) / scale, (np.asarray(cfg.qF) - (xc, yc)) / scale
        xs = cp.hstack([np.array([x0]), xi, np.array([xf])])  # q[1] = q0, q[N] = qF exactly
        ys = cp.hstack([np.array([y0]), psi, np.array([yf])])
        cons = [
            cp.norm(cp.vstack([cp.diff(xs), cp.diff(ys)]), 2, axis=0) <= p["dmax"],  # (10b)
            cp.square(xi) <= x2,
            cp.square(psi) <= y2,
        ]
        xg, yg = (np.asarray(cfg.ground_node) - (xc, yc)) / scale
        zu = cfg.uav_altitude / scale
        # (19): d_UG^2 <= e^{-4 v^l/alpha} (1 - (4/alpha)(v - v^l)), e^{-4 v^l/alpha} = d_UG(q^l)^2
        d_ug2 = x2 - 2 * xg * xi + y2 - 2 * yg * psi + (xg**2 + yg**2 + zu**2)
        cons.append(d_ug2 <= p["gl2"] - (4.0 / cfg.alpha) * cp.multiply(p["gl2"], v))
        cons.append(v >= -SLACK_BOUND)
        objective = p["cd"] @ v
        variables = {"xi": xi, "psi": psi, "v": v}
        if self.has_surface:
            k = self.n_tiles
            s = cp.Variable(m, name="s")  # s' = s - s^l, e^s <= |x - x_c|^3
            u = cp.Variable((m, k), name="u")  # u'_k = u_k - u_k^l, e^{u_k} >= d_k^4
            # (17): e^{s'} <= 3 (x - x_c) / (x^l - x_c) - 2  (sg = 3 / xi^l, sh = -2)
            cons.append(s <= cp.log(cp.multiply(p["sg"], xi) + p["sh"]))
            # (18): d_k^2 <= e^{u_k^l / 2} (1 + u'_k / 2), e^{u_k^l / 2} = d_k(q^l)^2
            yk = (self.node_y - yc) / scale
            const_k = yk**2 + ((cfg.uav_altitude - self.node_z) / scale) ** 2
            col = np.ones((1, k))
            d_k2 = (
                cp.reshape(x2 + y2, (m, 1), order="C") @ col
                - cp.reshape(psi, (m, 1), order="C") @ (2 * yk)[None, :]
                + np.ones((m, 1)) @ const_k[None, :]
            )
            cons.append(d_k2 <= p["dl2"] + 0.5 * cp.multiply(p["dl2"], u))
            cons += [s >= -SLACK_BOUND, u <= U_BOUND]
            objective = objective + p["cb"] @ s + cp.sum(cp.multiply(p["cc"], u))
            variables.update({"s": s, "u": u})
        return cp.Problem(cp.Maximize(objective), cons), variables

    # --- one iteration ------------------------------------------------------------------
    def linearise(self, q: np.ndarray) -> Linearisation:
        """Coefficients of (16)-(19) at the iterate ``q`` (N, 2), from the model's functions.

        The tiled per-node terms are anchored per slot to the exact surface amplitude
        (multiplied by exact / tiled at q^l), so the surrogate equals the exact rate at q^l.
        """
        cfg, scale = self.config, LENGTH_SCALE
        qi = q[1:-1]
        a_d = ch.direct_amplitude(cfg, qi)
        dx = qi[:, 0] - cfg.ios_center[0]
        gl2 = (((qi - np.asarray(cfg.ground_node)) ** 2).sum(axis=1) + cfg.uav_altitude**2) / scale**2
        # (10b) with an inward margin, loosened to the current step where that is longer (a
        # start at exactly D per move, on a tight horizon), so q^l stays feasible for (20)
        steps = np.minimum(np.linalg.norm(np.diff(q, axis=0), axis=1), cfg.D)
        values: dict[str, np.ndarray] = {"gl2": gl2, "dmax": np.maximum(cfg.D - STEP_MARGIN, steps) / scale}
        if self.has_surface:
            terms = ch.surface_terms(self.tiled, qi)  # (m, K): J s(q) |dx|^3 w_k / d_k^4
            tiled = terms.sum(axis=1)
            active = (np.abs(dx) >= PLANE_TOL) & (tiled > 0)
            exact = ch.surface_amplitude(cfg, qi)
            anchor = np.where(active, exact / np.where(active, tiled, 1.0), 1.0)
            t = np.where(active[:, None], terms * anchor[:, None], 0.0)
        else:
            active = np.zeros(self.m, dtype=bool)
            anchor = np.ones(self.m)
            t = np.zeros((self.m, 0))
        s_sum = t.sum(axis=1)
        g = s_sum + a_d  # zeta of the surrogate at q^l
        big_a = 1.0 + cfg.eta * g * g  # A^(l)
        common = 2.0 * cfg.eta * g / (big_a * math.log(2.0)) / cfg.N  # d rate / d log(zeta), / N
        values["cd"] = common * a_d  # D^(l) / (A^(l) ln 2) / N
        if self.has_surface:
            x_l = dx / scale
            values["sg"] = np.where(active, 3.0 / np.where(active, x_l, 1.0), 0.0)
            values["sh"] = np.where(active, -2.0, 1.0)
            d2 = (qi[:, 1:2] - self.node_y) ** 2 + (cfg.uav_altitude - self.node_z) ** 2 + (dx * dx)[:, None]
            values["dl2"] = d2 / scale**2
            values["cb"] = common * s_sum  # B^(l) / (A^(l) ln 2) / N
            values["cc"] = -common[:, None] * t  # C_k^(l) / (A^(l) ln 2) / N
        ends = ie.slot_rates(cfg, q[[0, -1]]).sum()
        constant = float((np.log2(big_a).sum() + ends) / cfg.N)
        return Linearisation(values, constant, active, anchor)

    def solve(self, lin: Linearisation, verbose: bool = False) -> tuple[np.ndarray | None, float, str, float]:
        """Solve (20) at ``lin``: (trajectory or None, surrogate value, status, solver seconds).

        The surrogate value is the first-order expansion (16) at the optimum, constants
        included, i.e. a lower bound of the (anchored, tiled) mean rate there. Exceptions of
        the solver propagate (the caller records them).
        """
        cfg = self.config
        if self.m == 0:
            return np.array([cfg.q0, cfg.qF], dtype=float), lin.constant, "optimal", 0.0
        if self.dpp:
            for name, value in lin.values.items():
                self._params[name].value = value
            problem, var = self._problem, self._vars
        else:
            problem, var = self._assemble(lin.values)
        t0 = time.perf_counter()
        with warnings.catch_warnings():  # the status is returned and recorded by the caller
            warnings.simplefilter("ignore", UserWarning)
            # warm_start=False: cvxpy's default re-uses the Clarabel object through an in-place
            # data update, which we saw fail spuriously (RA, second start); a fresh instance
            # per solve costs nothing measurable.
            problem.solve(
                solver=self.solver, verbose=verbose, warm_start=self.warm_start, **self.solver_options
            )
        elapsed = time.perf_counter() - t0
        status = str(problem.status)
        stats = problem.solver_stats
        solver_seconds = float(stats.solve_time) if stats is not None and stats.solve_time else 0.0
        if self.dpp and not self.compiled:
            self.compiled = True
            self.compile_seconds += max(0.0, elapsed - solver_seconds)
        if status not in OK_STATUSES or var["xi"].value is None or var["psi"].value is None:
            return None, float("nan"), status, solver_seconds
        interior = np.column_stack([var["xi"].value, var["psi"].value]) * LENGTH_SCALE + cfg.ios_center[:2]
        q = np.vstack([np.asarray(cfg.q0, float), interior, np.asarray(cfg.qF, float)])
        return q, lin.constant + float(problem.value), status, solver_seconds
