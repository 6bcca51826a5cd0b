"""The one scorer of a plan, for any number of ground nodes: whoever produced the plan (a
planner, an agent in an env, a trajectory file), its score is :func:`score_plan` of it.

A plan is a trajectory q (N, 2) and, for K > 1 nodes, optionally its own TDMA shares alpha
(K, N). Its scores:

- ``rate``: the plan's own objective value (bps/Hz). One node: eq. (9),
  :func:`~ios_uav_env.model.trajectory.average_rate`. K > 1 nodes: min_k R_k with the plan's
  own shares (:func:`~ios_uav_env.model.schedule.scheduled_rates`), or, for a plan given
  without shares, with the best schedule of its trajectory (``own_shares`` false);
- ``best_schedule_rate``: :func:`~ios_uav_env.model.schedule.maxmin_rate`, the best shares for
  the same flight (``rate`` itself for one node);
- ``report``: eq. (10), :func:`~ios_uav_env.model.trajectory.check_trajectory`.

The objective is the rate of the paper (the average rate, max-min for K > 1); a new objective
extends this function and :class:`PlanScore` (``docs/development.md``), so that every caller
scores it alike.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.schedule import Schedule, schedule, scheduled_rates
from ios_uav_env.model.trajectory import TrajectoryReport, check_trajectory


@dataclass(frozen=True)
class PlanScore:
    """The scores of one plan (see the module docstring)."""

    rate: float  # bps/Hz, the plan's own score
    best_schedule_rate: float  # bps/Hz, with the best shares of its trajectory (= rate for K = 1)
    own_shares: bool  # rate scored with the plan's own shares (always true for K = 1)
    report: TrajectoryReport  # eq. (10)
    best: Schedule | None  # the certified best schedule (None when it was not needed: K = 1)

    @property
    def feasible(self) -> bool:
        return bool(self.report.feasible)


def score_plan(
    config: ScenarioConfig,
    trajectory: np.ndarray,
    shares: np.ndarray | None = None,
    *,
    best_schedule: bool = True,
) -> PlanScore:
    """Score ``trajectory`` (and ``shares``, K > 1 only) on ``config`` (module docstring).

    ``best_schedule=False`` skips the best-schedule LP when the plan has its own shares
    (``best_schedule_rate`` is then NaN): for callers that report only the plan's own score.
    ``ValueError`` for shares on a single-node scenario or shares that are not a schedule.
    """
    q = np.asarray(trajectory, dtype=np.float64)
    report = check_trajectory(config, q)
    if config.K == 1:
        if shares is not None:
            raise ValueError("shares are for K > 1 ground nodes; this scenario has one")
        best = schedule(config, q)  # K = 1: average_rate exactly, no LP
        return PlanScore(best.value, best.value, True, report, None)
    if shares is None:
        best = schedule(config, q)
        return PlanScore(best.value, best.value, False, report, best)
    own = float(scheduled_rates(config, q, np.asarray(shares, dtype=np.float64)).min())
    if not best_schedule:
        return PlanScore(own, float("nan"), True, report, None)
    best = schedule(config, q)
    return PlanScore(own, best.value, True, report, best)
