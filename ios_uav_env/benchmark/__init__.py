"""Benchmark suites: frozen held-out scenarios with reference values, and a scorer for any policy.

Papers report against fixed suites (D4RL's normalised scores, Procgen's test levels); this
package ships ours inside the wheel and scores any policy on them with numpy and Gymnasium
alone (no planner, no deep-learning library):

>>> from ios_uav_env.benchmark import evaluate
>>> results = evaluate(lambda obs: [0.0, 0.0], n=2)   # any obs -> action callable
>>> results.aggregate.n, results.aggregate.feasible   # the arrival guard brings it to qF
(2, 2)

- :mod:`~ios_uav_env.benchmark.suite`: the suites (:func:`load_suite`; a file that does not
  match its registered hash fails to load); :mod:`~ios_uav_env.benchmark.suite_registry`:
  :data:`SUITES`, the kinds and their references;
- :mod:`~ios_uav_env.benchmark.scoring`: :func:`evaluate` (a policy) and
  :mod:`~ios_uav_env.benchmark.trajectory_scoring`: :func:`score_trajectories` (one
  trajectory, and for K > 1 its shares, per scenario), for
  every suite, each plan scored by :func:`ios_uav_env.score_plan` (a policy that raises:
  :class:`PolicyError`, naming the suite, the scenario and the policy);
- :mod:`~ios_uav_env.benchmark.overrides`: which env arguments a run may add to a suite's
  (one the suite pins is refused, one that changes the task only with ``allow_task_change``,
  and the results then name the changed task);
- :mod:`~ios_uav_env.benchmark.results`: :class:`Results` (per scenario and aggregate; CSV,
  JSON, markdown, figures) for any K, with the suite kind's :class:`Metrics`
  (:mod:`~ios_uav_env.benchmark.metrics`; single-node:
  % of DP and of SCA; multi-node: the plan's own max-min rate as % of SCA and of the
  certified bound, and its best schedule's % of SCA);
- :mod:`~ios_uav_env.benchmark.heuristics`: :func:`fly` (a policy flown in the env on one
  scenario: the suites' policy rows) and :func:`hover_episode` (``HoverAt``'s);
- :mod:`~ios_uav_env.benchmark.trajectories`: trajectory files (``.npz`` or CSV; multi-node
  plans may carry their shares: :func:`read_plans`);
- :mod:`~ios_uav_env.benchmark.star_suite`: the STAR-control suites (the agent sets the surface;
  a policy bound to each scenario, scored by the env's reward sum as % of the per-slot optimum);
- :mod:`~ios_uav_env.benchmark.miso_suite`: the MISO-control suites (the agent sets a multi-antenna
  UAV's beams and the surface's phases; scored as the STAR-control suites, as % of the per-slot AO);
- ``python -m ios_uav_env.benchmark {list,show,evaluate}``: the command line
  (:mod:`~ios_uav_env.benchmark.cli`).
"""

from ios_uav_env.benchmark.heuristics import Flight, fly, hover_episode
from ios_uav_env.benchmark.metrics import METRICS, Metrics
from ios_uav_env.benchmark.policy_errors import PolicyError
from ios_uav_env.benchmark.results import Aggregate, Results, ScenarioResult, reference_results
from ios_uav_env.benchmark.scoring import action_function, evaluate, evaluate_scenarios
from ios_uav_env.benchmark.suite import Suite, SuiteScenario, list_suites, load_suite
from ios_uav_env.benchmark.suite_registry import DEFAULT_SUITE, SUITES
from ios_uav_env.benchmark.trajectories import read_plans, read_trajectories, write_trajectories
from ios_uav_env.benchmark.trajectory_scoring import score_trajectories

__all__ = [
    "DEFAULT_SUITE",
    "SUITES",
    "METRICS",
    "Aggregate",
    "Flight",
    "Metrics",
    "PolicyError",
    "Results",
    "ScenarioResult",
    "Suite",
    "SuiteScenario",
    "action_function",
    "evaluate",
    "evaluate_scenarios",
    "fly",
    "hover_episode",
    "list_suites",
    "load_suite",
    "read_plans",
    "read_trajectories",
    "reference_results",
    "score_trajectories",
    "write_trajectories",
]
