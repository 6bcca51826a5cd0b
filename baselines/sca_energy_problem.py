"""The convex problem of the energy-efficiency SCA (``baselines.sca_energy``), built once per
scenario with cvxpy and re-solved.

:class:`EnergySurrogate` is the rate SCA's problem (20) (:class:`baselines.sca_problem.Surrogate`)
with the energy term of ``baselines.sca_energy``'s module docstring ("SCA (inside)"): the
propulsion power's convex terms kept exact, its induced term bounded through the slack y_n and
the first-order expansion at the iterate, weighted by w = lambda P_ref / (B N).
:meth:`EnergySurrogate.linearise_energy` gives the parameter values at (q^l, lambda).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from baselines.energy_bound import check_terms, induced_ratio
from baselines.sca_problem import LENGTH_SCALE, Linearisation, Surrogate
from ios_uav_env import ScenarioConfig


class EnergySurrogate(Surrogate):
    """Problem (20) of the rate SCA with the energy term of ``baselines.sca_energy``'s module docstring.

    :meth:`linearise_energy` gives the parameter values at (q^l, lambda); the inherited
    :meth:`Surrogate.solve` solves and returns (trajectory, surrogate of G_lambda / (B dt N)
    at the optimum, status, solver seconds)."""

    def __init__(
        self,
        config: ScenarioConfig,
        tiles: int,
        solver: str,
        dpp: bool = True,
        solver_options: dict[str, Any] | None = None,
    ):
        self.coef = check_terms(config)  # the model's constants, term by term (checked)
        self.p_ref = self.coef["p0"] + self.coef["pi"]
        super().__init__(config, tiles, solver, dpp=dpp, solver_options=solver_options)

    def _shapes(self) -> dict[str, tuple[int, ...]]:
        shapes = super()._shapes()
        moves = self.m + 1
        shapes.update({"mx": (moves,), "my": (moves,), "yl": (moves,), "yc": (moves,), "w": ()})
        return shapes

    def _make_parameters(self) -> dict[str, Any]:
        import cvxpy as cp

        params = super()._make_parameters()
        params["w"] = cp.Parameter(nonneg=True, name="w")  # w >= 0: w * (convex) stays convex (DPP)
        return params

    def _assemble(self, p: dict[str, Any]) -> tuple[Any, dict[str, Any]]:
        import cvxpy as cp

        problem, variables = super()._assemble(p)
        cfg, scale, k = self.config, LENGTH_SCALE, self.coef
        xc, yc = cfg.ios_center[0], cfg.ios_center[1]
        x0, y0 = (cfg.q0[0] - xc) / scale, (cfg.q0[1] - yc) / scale
        xf, yf = (cfg.qF[0] - xc) / scale, (cfg.qF[1] - yc) / scale
        xs = cp.hstack([np.array([x0]), variables["xi"], np.array([xf])])
        ys = cp.hstack([np.array([y0]), variables["psi"], np.array([yf])])
        mx, my = cp.diff(xs), cp.diff(ys)  # moves, in LENGTH_SCALE
        speed_unit = scale / cfg.dt  # V = speed_unit * |m|
        y = cp.Variable(self.m + 1, name="y")  # y_n >= y(V_n), the induced velocity ratio
        v2 = speed_unit**2 * (cp.square(mx) + cp.square(my))
        v3 = speed_unit**3 * cp.power(cp.norm(cp.vstack([mx, my]), 2, axis=0), 3)
        power = k["p0"] * (1.0 + 3.0 * v2 / k["u_tip"] ** 2) + k["c3"] * v3 + k["pi"] * y
        energy = cp.sum(power) / self.p_ref  # E / (P_ref dt) at the surrogate's y
        # y^-2 <= y^l (2 y - y^l) + (2 m^l . m - |m^l|^2) / (dt^2 v0^2); yc = -(y^l)^2 - |m^l|^2 (..)
        lin = speed_unit**2 / k["v0"] ** 2
        rhs = 2.0 * cp.multiply(p["yl"], y) + 2.0 * lin * (
            cp.multiply(p["mx"], mx) + cp.multiply(p["my"], my)
        )
        cons = [*problem.constraints, cp.power(y, -2) <= rhs + p["yc"]]
        objective = problem.objective.args[0] - p["w"] * energy
        variables = {**variables, "y": y}
        return cp.Problem(cp.Maximize(objective), cons), variables

    def linearise_energy(self, q: np.ndarray, lam: float) -> Linearisation:
        """The rate surrogate's linearisation at ``q`` plus the energy term's, for Dinkelbach's
        ``lam`` (bits/J): w = lam P_ref / (B N); the constant becomes
        mean rate - w E(q) / (P_ref dt) at q (the surrogate's value there)."""
        cfg = self.config
        lin = self.linearise(q)
        moves = np.diff(np.asarray(q, dtype=float), axis=0) / LENGTH_SCALE
        speed = np.linalg.norm(moves, axis=1) * LENGTH_SCALE / cfg.dt
        y_l = induced_ratio(speed, self.coef["v0"])
        lin_coef = (LENGTH_SCALE / cfg.dt) ** 2 / self.coef["v0"] ** 2
        w = float(lam) * self.p_ref / (cfg.bandwidth_hz * cfg.N)
        lin.values.update(
            mx=moves[:, 0],
            my=moves[:, 1],
            yl=y_l,
            yc=-(y_l**2) - lin_coef * (moves**2).sum(axis=1),
            w=np.asarray(w),
        )
        return lin
