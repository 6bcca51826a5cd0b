"""Scoring and checking a trajectory: the one place where a plan's quality is decided.

Whoever produced a trajectory (the env, SCA, DP, an RL agent), it is scored by
:func:`average_rate` (eq. (9)) and checked by :func:`check_trajectory` (eq. (10), and the
energy budget when the scenario sets one). :func:`energy` is the flight's propulsion energy
(``model.propulsion``), which the report carries; its energy efficiency (bits/J) needs the
plan's rate and is :func:`ios_uav_env.energy_efficiency` (``model.score``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ios_uav_env.model.channel import as_positions, slot_rates
from ios_uav_env.model.config import ENERGY_RTOL, FEASIBILITY_TOL, ScenarioConfig
from ios_uav_env.model.propulsion import flight_energy


def as_trajectory(config: ScenarioConfig, trajectory: np.ndarray) -> np.ndarray:
    """Validate an (N, 2) trajectory for ``config`` (N = config.N way-points)."""
    q = as_positions(trajectory, "trajectory")
    if len(q) != config.N:
        raise ValueError(f"trajectory must have N = {config.N} rows (T / dt way-points), got {len(q)}")
    return q


def average_rate(config: ScenarioConfig, trajectory: np.ndarray) -> float:
    """Average expected-gain rate (bps/Hz) of eq. (9): (1/N) sum_n r(q[n]), both ends included."""
    return float(np.mean(slot_rates(config, as_trajectory(config, trajectory))))


def energy(config: ScenarioConfig, trajectory: np.ndarray) -> float:
    """Propulsion energy (J) of the flight: E = dt sum_{n=1}^{N-1} P(|q[n+1] - q[n]| / dt), each of
    the N - 1 moves flown at constant speed over one slot, P of ``config.propulsion``."""
    return flight_energy(as_trajectory(config, trajectory), config.dt, config.propulsion)


@dataclass(frozen=True)
class TrajectoryReport:
    """The constraints of eq. (10) for one trajectory (distances in metres), its energy and,
    when ``config.energy_budget_j`` is set, the budget E <= E_max (met within ENERGY_RTOL)."""

    start_error: float  # |q[1] - q0|
    end_error: float  # |q[N] - qF| (the terminal miss)
    max_step: float  # max_n |q[n] - q[n-1]|
    step_excess: float  # max(0, max_step - D)
    worst_violation: float  # max of start_error, end_error, step_excess
    feasible: bool  # worst_violation <= tol and the energy budget met
    tol: float  # tolerance used (m)
    energy: float  # J, propulsion energy E of the flight (:func:`energy`)
    energy_excess: float  # J, max(0, E - energy_budget_j) (0 without a budget)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def __str__(self) -> str:
        if self.feasible:
            verdict = "feasible"
        elif self.worst_violation > self.tol:
            verdict = f"INFEASIBLE (worst violation {self.worst_violation:.3g} m)"
        else:
            verdict = f"INFEASIBLE (energy budget exceeded by {self.energy_excess:.6g} J)"
        return (
            f"{verdict}: start error {self.start_error:.3g} m, end error {self.end_error:.3g} m, "
            f"max step {self.max_step:.6g} m"
        )


def check_trajectory(
    config: ScenarioConfig, trajectory: np.ndarray, tol: float = FEASIBILITY_TOL
) -> TrajectoryReport:
    """Check eq. (10): q[1] = q0, q[N] = qF, |q[n] - q[n-1]| <= D; report the worst violation,
    the flight's energy and, with ``config.energy_budget_j``, whether E <= E_max (1 + ENERGY_RTOL)."""
    q = as_trajectory(config, trajectory)
    start = float(np.linalg.norm(q[0] - np.asarray(config.q0)))
    end = float(np.linalg.norm(q[-1] - np.asarray(config.qF)))
    steps = np.linalg.norm(np.diff(q, axis=0), axis=1)
    max_step = float(steps.max()) if steps.size else 0.0
    excess = max(0.0, max_step - config.D)
    worst = max(start, end, excess)
    e = flight_energy(q, config.dt, config.propulsion)
    budget = config.energy_budget_j
    over = 0.0 if budget is None else max(0.0, e - budget)
    within = budget is None or e <= budget * (1.0 + ENERGY_RTOL)
    return TrajectoryReport(start, end, max_step, excess, worst, worst <= tol and within, tol, e, over)
