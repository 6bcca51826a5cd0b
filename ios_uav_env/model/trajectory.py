"""Scoring and checking a trajectory: the one place where a plan's quality is decided.

Whoever produced a trajectory (the env, SCA, DP, an RL agent), it is scored by
:func:`average_rate` (eq. (9)) and checked by :func:`check_trajectory` (eq. (10)).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ios_uav_env.model.channel import as_positions, slot_rates
from ios_uav_env.model.config import FEASIBILITY_TOL, ScenarioConfig


def as_trajectory(config: ScenarioConfig, trajectory: np.ndarray) -> np.ndarray:
    """Validate an (N, 2) trajectory for ``config`` (N = config.N way-points)."""
    q = as_positions(trajectory, "trajectory")
    if len(q) != config.N:
        raise ValueError(f"trajectory must have N = {config.N} rows (T / dt way-points), got {len(q)}")
    return q


def average_rate(config: ScenarioConfig, trajectory: np.ndarray) -> float:
    """Average expected-gain rate (bps/Hz) of eq. (9): (1/N) sum_n r(q[n]), both ends included."""
    return float(np.mean(slot_rates(config, as_trajectory(config, trajectory))))


@dataclass(frozen=True)
class TrajectoryReport:
    """The constraints of eq. (10) for one trajectory; distances in metres."""

    start_error: float  # |q[1] - q0|
    end_error: float  # |q[N] - qF| (the terminal miss)
    max_step: float  # max_n |q[n] - q[n-1]|
    step_excess: float  # max(0, max_step - D)
    worst_violation: float  # max of start_error, end_error, step_excess
    feasible: bool  # worst_violation <= tol
    tol: float  # tolerance used (m)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def __str__(self) -> str:
        verdict = (
            "feasible" if self.feasible else f"INFEASIBLE (worst violation {self.worst_violation:.3g} m)"
        )
        return (
            f"{verdict}: start error {self.start_error:.3g} m, end error {self.end_error:.3g} m, "
            f"max step {self.max_step:.6g} m"
        )


def check_trajectory(
    config: ScenarioConfig, trajectory: np.ndarray, tol: float = FEASIBILITY_TOL
) -> TrajectoryReport:
    """Check eq. (10): q[1] = q0, q[N] = qF, |q[n] - q[n-1]| <= D; report the worst violation."""
    q = as_trajectory(config, trajectory)
    start = float(np.linalg.norm(q[0] - np.asarray(config.q0)))
    end = float(np.linalg.norm(q[-1] - np.asarray(config.qF)))
    steps = np.linalg.norm(np.diff(q, axis=0), axis=1)
    max_step = float(steps.max()) if steps.size else 0.0
    excess = max(0.0, max_step - config.D)
    worst = max(start, end, excess)
    return TrajectoryReport(start, end, max_step, excess, worst, worst <= tol, tol)
