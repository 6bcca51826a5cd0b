"""Score plans given as trajectories (a plan file's, a planner's): one per scenario of a suite,
with its time to plan and, for K > 1 nodes, its shares, each scored by ``score_plan``
(:func:`score_trajectories`). Scoring a policy by rolling it out: :mod:`ios_uav_env.benchmark.scoring`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ios_uav_env.benchmark.metrics import metrics_of
from ios_uav_env.benchmark.results import Results, ScenarioResult
from ios_uav_env.benchmark.suite import Suite, suite_of
from ios_uav_env.benchmark.suite_registry import DEFAULT_SUITE
from ios_uav_env.benchmark.trajectories import check_plan_time
from ios_uav_env.model.score import score_plan


def score_trajectories(
    trajectories: Mapping[int, Any],
    suite: Suite | str = DEFAULT_SUITE,
    *,
    seconds: Mapping[int, float] | None = None,
    name: str = "trajectories",
    shares: Mapping[int, Any] | None = None,
) -> Results:
    """Score one trajectory per scenario (``{index: (N, 2) way-points in m, q0 first and qF last}``)
    with ``average_rate`` and ``check_trajectory``; ``seconds``: each plan's time, if known.

    Multi-node suites: ``shares`` (``{index: (K, N) TDMA shares}``, for every scenario or none)
    are the plans' own schedules, scored with ``scheduled_rates``; without them each trajectory
    is scored with its best schedule (``maxmin_rate``). A single-node suite takes no shares.

    The indices must be the suite's first n (0 .. n-1, n >= 1); ``ValueError`` naming the
    scenario for a missing or unknown index, a trajectory of the wrong shape or not finite, or
    a time to plan that is not a finite number of seconds >= 0 (NaN: unknown).
    """
    suite = suite_of(suite)
    if suite.star_control:
        raise ValueError(
            f"{suite.name} scores the surface's settings, not flights: the UAV's line is given; "
            "score a policy with evaluate"
        )
    if suite.fleets:  # U flights (U, N, 2) per scenario, scored by fleet_maxmin
        from ios_uav_env.benchmark.fleet_scoring import score_fleet_flights

        if shares:
            raise ValueError(f"shares are for multi-node suites; {suite.name} is a {suite.kind} suite")
        return score_fleet_flights(trajectories, suite, seconds=seconds, name=name)
    indices = sorted(int(i) for i in trajectories)
    if not indices:
        raise ValueError("no trajectories to score")
    unknown = [i for i in indices if not 0 <= i < len(suite)]
    if unknown:
        raise ValueError(f"scenarios {unknown} are not in suite {suite.name} (indices 0..{len(suite) - 1})")
    missing = sorted(set(range(indices[-1] + 1)) - set(indices))
    if missing:
        raise ValueError(f"the trajectories must cover scenarios 0..n-1 of {suite.name}; missing {missing}")
    if shares and not suite.schedules:
        raise ValueError(f"shares are for multi-node suites; {suite.name} is a {suite.kind} suite")
    scenarios, metrics = suite.subset(len(indices)), metrics_of(suite)
    times = {
        int(i): check_plan_time(t, f"scenario {int(i)}", unknown=True) for i, t in (seconds or {}).items()
    }
    shares = dict(shares or {})
    missing = [s.index for s in scenarios if s.index not in shares]
    if shares and missing:
        raise ValueError(f"shares are given for some scenarios but not for {missing}: give them for all "
                         "or none (without shares a plan is scored with its best schedule)")  # fmt: skip
    rows = []
    for s in scenarios:
        q = np.asarray(trajectories[s.index], dtype=np.float64)
        if q.shape != (s.config.N, 2):
            raise ValueError(
                f"scenario {s.index}: the trajectory must have shape (N, 2) = ({s.config.N}, 2) "
                f"(T = {s.config.T:g} s, dt = {s.config.dt:g} s; q0 first, qF last), got {q.shape}"
            )
        if not np.isfinite(q).all():
            raise ValueError(f"scenario {s.index}: the trajectory has NaN or infinite values")
        a = None if s.index not in shares else np.asarray(shares[s.index], dtype=np.float64)
        try:
            score = score_plan(s.config, q, a, s.paths())  # a mobile scenario: on its true path
        except ValueError as err:
            raise ValueError(f"scenario {s.index}: {err}") from None
        t = times.get(s.index, float("nan"))
        rows.append(ScenarioResult.of(s, metrics, score, t, q, a))
    return Results.of(suite, name, {}, rows, scenarios)
