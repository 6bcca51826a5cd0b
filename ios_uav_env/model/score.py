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
- ``report``: eq. (10), :func:`~ios_uav_env.model.trajectory.check_trajectory`, with the
  flight's propulsion energy E (J) and, when the scenario sets ``energy_budget_j``, the
  budget E <= E_max (``feasible`` then asks for both);
- ``energy_efficiency``: bits per joule, EE = B T R / E with R = ``rate``, B the bandwidth
  ``config.bandwidth_hz`` and T = N dt the mission time. For one node B T R = B dt sum_n r(q[n])
  (eq. (9): R is the mean of the N slot rates), the bits delivered; for K > 1 nodes R is
  min_k R_k, so EE is the worst node's bits per joule;
- ``objective_value``: the score of the scenario's ``objective``: ``rate`` for ``"rate"``
  (with or without a budget, which enters ``feasible``), ``energy_efficiency`` for
  ``"energy_efficiency"``.

Moving nodes: ``score_plan(config, q, shares, paths)`` scores the plan on the true node paths
(N, K, 2) (``docs/model.md``, "Node motion"), whatever the planner or agent knew of them.

A STAR surface serving both sides' nodes at once (``ScenarioConfig(surface="star",
star_access="noma")``, two static nodes, one on each side): ``rate`` and ``best_schedule_rate`` are
the flight's max-min with the best power splits and time sharing of its trajectory,
``ios_uav_env.model.star_regions.scenario_maxmin`` (certified to its tolerance; the plan gives no
shares). Under TDMA a STAR scenario is scored as every other surface's.

A multi-antenna UAV (``config.antennas`` = N_t > 1; ``docs/model.md``, "Multi-antenna UAV") serving
one node: eq. (9) with the slot rate log2(1 + G) of the phases and the beam at their closed-form
joint optimum (``channel.slot_rates``, ``model.miso``). Serving K in [2, 4] static nodes at once
(SDMA) on a surface of at most ``miso_sdma.MAX_ELEMENTS`` elements: ``rate`` and
``best_schedule_rate`` are the flight's max-min with time sharing of the per-slot settings of
``ios_uav_env.model.miso_sdma`` (the weighted-sum AO at the lattice weights and each node alone;
``sdma_maxmin``, exact over those settings; the plan gives no shares). Larger surfaces are
refused (the per-slot AO's cost).

A new objective extends this function and :class:`PlanScore` (``docs/development.md``), so
that every caller (planners, envs, the benchmark) scores it alike.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.miso_sdma import check_sdma_scenario, sdma_maxmin
from ios_uav_env.model.schedule import Schedule, schedule, scheduled_rates
from ios_uav_env.model.star_regions import scenario_maxmin
from ios_uav_env.model.trajectory import TrajectoryReport, check_trajectory


@dataclass(frozen=True)
class PlanScore:
    """The scores of one plan (see the module docstring)."""

    rate: float  # bps/Hz, the plan's own score
    best_schedule_rate: float  # bps/Hz, with the best shares of its trajectory (= rate for K = 1)
    own_shares: bool  # rate scored with the plan's own shares (always true for K = 1)
    report: TrajectoryReport  # eq. (10), the energy and the energy budget
    best: Schedule | None  # the certified best schedule (None when it was not needed: K = 1)
    energy_efficiency: float  # bits/J, B T rate / E
    objective_value: float  # the score of config.objective: rate (bps/Hz) or energy_efficiency (bits/J)

    @property
    def feasible(self) -> bool:
        """Eq. (10) holds (within ``report.tol``) and, with a budget, E <= E_max."""
        return bool(self.report.feasible)

    @property
    def energy(self) -> float:
        """Propulsion energy E of the flight (J): ``report.energy``."""
        return self.report.energy


def bits_per_joule(config: ScenarioConfig, rate: float, energy: float) -> float:
    """EE = B T R / E (bits/J) of a plan of rate R (bps/Hz) and energy E (J) on ``config``."""
    return config.bandwidth_hz * config.T * rate / energy


def _score(
    config: ScenarioConfig,
    rate: float,
    best_rate: float,
    own: bool,
    report: TrajectoryReport,
    best: Schedule | None,
) -> PlanScore:
    ee = bits_per_joule(config, rate, report.energy)
    value = ee if config.objective == "energy_efficiency" else rate
    return PlanScore(rate, best_rate, own, report, best, ee, value)


def score_plan(
    config: ScenarioConfig,
    trajectory: np.ndarray,
    shares: np.ndarray | None = None,
    paths: np.ndarray | None = None,
    *,
    best_schedule: bool = True,
) -> PlanScore:
    """Score ``trajectory`` (and ``shares``, K > 1 only) on ``config`` (module docstring).

    ``paths`` (N, K, 2) m: the true node positions of every slot (moving nodes,
    ``ios_uav_env.model.motion``); every rate is then r_k(q[n]; w_k[n]). None: the configured
    positions (static paths give the same scores bit for bit).

    ``best_schedule=False`` skips the best-schedule LP when the plan has its own shares
    (``best_schedule_rate`` is then NaN): for callers that report only the plan's own score.
    ``ValueError`` for shares on a single-node scenario or shares that are not a schedule.
    """
    q = np.asarray(trajectory, dtype=np.float64)
    report = check_trajectory(config, q)
    if (config.surface == "star" and config.star_access == "noma") or (config.antennas > 1 and config.K > 1):
        return _served_at_once(config, q, report, shares, paths)
    if config.K == 1:
        if shares is not None:
            raise ValueError("shares are for K > 1 ground nodes; this scenario has one")
        best = schedule(config, q, paths)  # K = 1: average_rate exactly (static), no LP
        return _score(config, best.value, best.value, True, report, None)
    if shares is None:
        best = schedule(config, q, paths)
        return _score(config, best.value, best.value, False, report, best)
    own = float(scheduled_rates(config, q, np.asarray(shares, dtype=np.float64), paths).min())
    if not best_schedule:
        return _score(config, own, float("nan"), True, report, None)
    best = schedule(config, q, paths)
    return _score(config, own, best.value, True, report, best)


def _served_at_once(
    config: ScenarioConfig,
    q: np.ndarray,
    report: TrajectoryReport,
    shares: np.ndarray | None,
    paths: np.ndarray | None,
) -> PlanScore:
    """The score of a scenario whose nodes are served at once in every slot (module docstring): a
    STAR surface under NOMA, or a multi-antenna UAV (SDMA); no TDMA shares, static nodes."""
    if config.surface == "star" and config.star_access == "noma":
        what = "a STAR scenario with star_access='noma'"
        how = "the best power splits and time sharing of its trajectory"
        how += " (ios_uav_env.model.star_regions.scenario_maxmin)"
    else:
        what = f"a multi-antenna UAV (antennas={config.antennas}) serving K = {config.K} nodes at once"
        how = "the best time sharing of its slots' settings (ios_uav_env.model.miso_sdma.sdma_maxmin)"
    if shares is not None:
        raise ValueError(f"shares are TDMA shares; {what} is scored with {how}: give none")
    if paths is not None:
        raise ValueError(f"paths: {what} is scored for static nodes only")
    if config.surface == "star" and config.star_access == "noma":
        if config.antennas > 1:
            raise ValueError(
                f"antennas={config.antennas}: a STAR scenario with star_access='noma' is scored for a "
                "single-antenna UAV (model.star_regions); use antennas=1, or star_access='tdma'"
            )
        best = scenario_maxmin(config, q).value
    else:
        check_sdma_scenario(config)
        best = sdma_maxmin(config, q).value
    return _score(config, best, best, False, report, None)


def energy_efficiency(
    config: ScenarioConfig, trajectory: np.ndarray, shares: np.ndarray | None = None
) -> float:
    """Energy efficiency (bits/J) of a plan: ``score_plan(config, trajectory, shares)``'s
    ``energy_efficiency``, B T R / E (module docstring). One node: B dt sum_n r(q[n]) / E; K > 1
    nodes: B T min_k R_k / E with the plan's ``shares``, or its best schedule without them."""
    return score_plan(config, trajectory, shares, best_schedule=False).energy_efficiency
