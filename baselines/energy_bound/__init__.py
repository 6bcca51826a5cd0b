r"""A certified upper bound on the energy efficiency (bits/J) of any feasible plan, one ground node.

**Dinkelbach on a relaxation.** For lambda >= 0 (bits/J) and a feasible trajectory q let
G_lambda(q) = B dt sum_{n=1}^{N} r(q[n]) - lambda E(q), with E(q) = sum_{n=1}^{N-1} f(m_n) the
propulsion energy (``ios_uav_env.energy``), m_n = q[n+1] - q[n] and f(m) = dt P(|m| / dt).

*Claim.* If U(mu) >= G_lambda(q) / (B dt) for every feasible q, with mu = lambda / (B dt), and
U(mu) <= 0, then EE(q) <= lambda for every feasible q.

*Proof.* E(q) > 0 (P > 0), so G_lambda(q) = E(q) (EE(q) - lambda) <= B dt U(mu) <= 0 gives
EE(q) <= lambda.

U below is a maximum over *relaxed paths* p of sum Rbar(p) - mu L(p), where every feasible q
maps to some p with sum_n r(q[n]) <= sum Rbar(p) and E(q) >= L(p); so U(mu) >= G_lambda(q) /
(B dt). Its least root is the best ratio sum Rbar / L of a relaxed path, and Dinkelbach's
iteration finds it: from mu_0 (a plan's EE / (B dt), or 0) take a best relaxed path p_k at mu_k
and set mu_{k+1} = (sum Rbar(p_k) / L(p_k)) (1 + ``BOUND_SLACK``). While U(mu_k) > 0,
U(mu_k) = L(p_k) (sum Rbar / L - mu_k) shows that the ratio exceeds mu_k, so mu increases, each
step to above the ratio of the path just found; the paths being finitely many, some mu_k has
U(mu_k) <= 0, and B dt mu_k is returned. *The certificate is that last DP*: U <= 0 there,
whatever the iteration did before.

**The package**, by concern:

- ``baselines.energy_bound.lower_bounds``: the propulsion model's terms (:func:`check_terms`)
  and the lower bounds of the power and of the move costs (:func:`move_cost_lower_bound`);
- ``baselines.energy_bound.relaxation``: the cells, the energy L(p) of a relaxed path (its move
  costs and slot penalties) and the multipliers b (:func:`multipliers`);
- ``baselines.energy_bound.dinkelbach``: U(mu) as a DP over relaxed paths
  (:class:`EnergyRelaxation`), Dinkelbach's iteration and :func:`solve` over the multiplier
  variants (:class:`EnergyBound`).

**Tightness.** The bound converges to the optimum as h -> 0 (every relaxation vanishes). With
b = 0 and cells refined by an odd factor that keeps k h (each square a union of finer ones, the
same coarse cells), each finer relaxed path maps to a coarser one with no smaller reward and no
larger cost, so the bound does not increase as the cells shrink (up to the branch and bound's
tolerances).
"""

from baselines.energy_bound.dinkelbach import (
    BOUND_SLACK,  # noqa: F401 (re-exported)
    DEFAULT_RESOLUTION,
    DEFAULT_VARIANTS,
    MAX_ITERS,  # noqa: F401 (re-exported)
    EnergyBound,
    EnergyRelaxation,
    solve,
)
from baselines.energy_bound.lower_bounds import (
    COST_SLACK,  # noqa: F401 (re-exported)
    SPEED_TOL,  # noqa: F401 (re-exported)
    check_terms,
    convex_from,
    induced_ratio,
    move_cost_lower_bound,
    power_slope,
    propulsion_coefficients,
    terms_power,
    tilted_power_lower_bound,
)
from baselines.energy_bound.relaxation import (
    DEFAULT_WINDOW,
    INTERFACE_SPLIT,  # noqa: F401 (re-exported)
    MULTIPLIER_STEP,  # noqa: F401 (re-exported)
    CellRelaxation,  # noqa: F401 (re-exported)
    coarse_factor,
    multipliers,
)

# the names marked re-exported: the modules' constants and the cells' base class, beside __all__
__all__ = [
    "DEFAULT_RESOLUTION", "DEFAULT_VARIANTS", "DEFAULT_WINDOW", "EnergyBound", "EnergyRelaxation",
    "check_terms", "coarse_factor", "convex_from", "induced_ratio", "move_cost_lower_bound", "multipliers",
    "power_slope", "propulsion_coefficients", "solve", "terms_power", "tilted_power_lower_bound",
]  # fmt: skip
