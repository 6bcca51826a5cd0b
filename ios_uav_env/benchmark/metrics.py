"""What a suite reports, by its kind: the :class:`Metrics` (the references its scores are
percentages of, the normaliser first; whether plans carry TDMA shares), :data:`METRICS` and
:func:`metrics_of`, and how each reference is named in summaries (:data:`LABELS`). The rows,
the aggregate and their outputs: :mod:`ios_uav_env.benchmark.results`.

By suite kind:

- ``single-node``: the rate of eq. (9) as % of the DP optimum (the normaliser) and of SCA;
- ``multi-node``: the max-min rate min_k R_k with the plan's own shares as % of SCA (the
  normaliser) and of the certified upper bound, and the best schedule's % of SCA;
- ``energy``: the energy efficiency EE = B T R / E (bits/J, ``score_plan``'s
  ``objective_value`` on the suite's ``"energy_efficiency"`` scenarios) as % of the energy DP's
  (the normaliser) and of the certified EE bound; each row also holds the plan's rate, its
  energy (J) and its EE;
- ``mobile``: the average rate on the node's true path (``score_plan(..., paths=...)``) as % of
  the clairvoyant bound (the normaliser) and of MPC(k=1), whose planning time the policy's is
  compared with; a mobile suite normalised by ``"optimum"`` (``mobile-v2``) as % of the
  clairvoyant optimum (``pct_optimum``, the DP on the true path) and of the bound;
- ``multi-node-mobile``: the max-min rate with the plan's own shares on the nodes' true paths as
  % of the clairvoyant optimum (the normaliser: the best plan clairvoyant planners found) and of
  the certified bound, and the best schedule's % of the optimum; planning time is compared with
  MPC-DP(k=1)'s;
- ``multi-uav``: the team's max-min rate of U flights (``fleet_maxmin``, the best time sharing of
  every slot) as % of the centralised planner's (the normaliser, ``baselines.fleet``) and of its
  certified bound; a plan is feasible when every flight is and the UAVs stay separated;
- ``star-control``: the mean slot value of the surface's settings (the env's reward sum / N) as %
  of the per-slot optimum (the normaliser, ``star_slot.slot_optimum``) and of its certified bound;
  every episode is feasible (the UAV's line is given), and a plan's time is the policy's own calls;
- ``miso-control``: the same of the beams' and phases' settings, the mean slot objective (sum or
  max-min rate) as % of the per-slot AO optimum (``miso_slot.slot_optimum``) and of its bound.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ios_uav_env.benchmark.suite import Suite
from ios_uav_env.benchmark.suite_registry import (
    ENERGY,
    MISO_CONTROL,
    MOBILE,
    MULTI_NODE,
    MULTI_NODE_MOBILE,
    MULTI_UAV,
    SCORED,
    SINGLE_NODE,
    STAR_CONTROL,
    TIMED,
)

#: How a reference is named in summaries and tables.
LABELS = {"dp": "DP", "sca": "SCA", "bound": "bound", "mpc_k1": "MPC(k=1)", "mpc_dp_k1": "MPC-DP(k=1)",
          "optimum": "optimum", "planner": "planner"}  # fmt: skip


@dataclass(frozen=True)
class Metrics:
    """What a suite reports: the references its scores are percentages of (the normaliser
    first) and whether plans carry TDMA shares (K > 1: the best schedule is reported too)."""

    scores: tuple[str, ...]  # e.g. ("dp", "sca"): pct_dp, pct_sca
    schedules: bool  # K > 1 nodes: own shares, the best schedule, K per row
    energy: bool = False  # scores of the energy efficiency (bits/J); rows hold energy and EE
    timed: str = "sca"  # the reference whose planning time a policy's is compared with (TIMED)

    @property
    def normaliser(self) -> str:
        return self.scores[0]

    def columns(self) -> tuple[str, ...]:
        """The fields of a row's dict and CSV, in order."""
        multi = ("K",) if self.schedules else ()
        best = ("best_schedule_rate",) if self.schedules else ()
        tail = (f"best_pct_{self.normaliser}",) if self.schedules else ()
        own = ("own_shares",) if self.schedules else ()
        pct = tuple(f"pct_{r}" for r in self.scores)
        energy = ("energy", "energy_efficiency") if self.energy else ()
        rates = ("rate", *best, *energy)
        return ("index", *multi, *rates, "feasible", "worst_violation", *pct, *tail, "seconds", *own)


#: The metrics of each suite kind.
METRICS = {
    SINGLE_NODE: Metrics(SCORED[SINGLE_NODE], False),
    MULTI_NODE: Metrics(SCORED[MULTI_NODE], True),
    ENERGY: Metrics(SCORED[ENERGY], False, energy=True),
    MOBILE: Metrics(SCORED[MOBILE], False, timed=TIMED[MOBILE]),
    MULTI_NODE_MOBILE: Metrics(SCORED[MULTI_NODE_MOBILE], True, timed=TIMED[MULTI_NODE_MOBILE]),
    MULTI_UAV: Metrics(SCORED[MULTI_UAV], False, timed=TIMED[MULTI_UAV]),
    STAR_CONTROL: Metrics(SCORED[STAR_CONTROL], False, timed=TIMED[STAR_CONTROL]),
    MISO_CONTROL: Metrics(SCORED[MISO_CONTROL], False, timed=TIMED[MISO_CONTROL]),
}


def metrics_of(suite: Suite) -> Metrics:
    """The :class:`Metrics` of ``suite``: its kind's, scored against the references of the suite's
    normaliser (``suite.scores``: ``ValueError`` for a normaliser its kind has not)."""
    metrics = METRICS[suite.kind]
    try:
        scores = suite.scores
    except ValueError as err:
        raise ValueError(f"suite {suite.name}: {err}") from None
    return metrics if scores == metrics.scores else dataclasses.replace(metrics, scores=scores)
