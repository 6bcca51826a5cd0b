"""Suites of several UAVs (kind ``"multi-uav"``, ``multi-uav-v1``): each scenario's fleet, the one
scorer of its flights, and a policy's episodes in ``ios_uav_env.parallel_env``.

A scenario holds its ``ScenarioConfig`` (K static nodes, the rate objective) and its ``fleet``:
``parallel_env``'s arguments :data:`FLEET_FIELDS` (``uavs``, ``starts``, ``finals``, ``speeds``,
``access``, ``min_separation``, ``horizons``), checked at load by ``ios_uav_env.model.fleet.fleet_setup``, the
check the env and the planner share. A plan is U flights (U, N, 2) m:

- **Rate**: the team's max-min rate with the best time sharing in every slot,
  ``ios_uav_env.model.fleet.fleet_maxmin(config, flights, access=...)``: the one scorer of a
  fleet, whoever flew it (the planner's references were scored by it too);
- **Feasible**: every UAV's flight meets eq. (10) with its own start, final point and speed
  (``check_trajectory``) and every two UAVs keep ``min_separation`` at every way-point
  (``model.separation.flights_separated``). An infeasible plan scores 0.

A policy is scored by rolling it out in the parallel env made on the scenario with the suite's
``env_kwargs`` (``max_nodes``, so that every scenario's observations and actions have the same
node blocks) and ``best_schedule=False`` (the flights are scored once, here): either one policy
shared by every agent (a callable, an SB3 model: :func:`~ios_uav_env.benchmark.scoring.action_function`,
applied to each agent's own observation, as parameter-shared IPPO acts), or a team policy that
says ``team = True`` and maps the dict of the live agents' observations to a dict of their
actions. A policy with a ``bind`` method (one that reads features by name, as
:class:`~ios_uav_env.benchmark.fleet_policies.NearestWorstNode`) is bound to each scenario's
``observation_names`` first. An agent's observation has 2 (U - 1) columns for the other UAVs,
so its width depends on the scenario's U. A plan's time is its episode's wall time, after an
unscored warm-up episode. Rolling policies out needs the ``marl`` extra (PettingZoo); loading a
suite and scoring flights do not.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.fleet import fleet_maxmin, fleet_setup
from ios_uav_env.model.fleet_horizons import flights_feasibility, horizon_slots
from ios_uav_env.model.separation import flights_separated

__all__ = ["FLEET_FIELDS", "check_fleet", "fleet_configs", "fleet_episode", "score_flights"]

#: A several-UAV scenario's fleet: ``parallel_env``'s arguments that the scenario fixes.
FLEET_FIELDS = ("uavs", "starts", "finals", "speeds", "access", "min_separation", "horizons")
#: Most steps of one episode before it is declared stuck.
MAX_STEPS = 100_000


def check_fleet(config: ScenarioConfig, fleet: Any, where: str) -> dict[str, Any]:
    """``fleet`` as stored (plain lists and numbers), checked: exactly the keys
    :data:`FLEET_FIELDS`, valid for ``config`` (``fleet_setup``), with several UAVs
    (``ValueError`` naming ``where`` and the field otherwise)."""
    if not isinstance(fleet, Mapping):
        raise ValueError(f"{where}: fleet must be an object of {list(FLEET_FIELDS)}, got {fleet!r}")
    if set(fleet) != set(FLEET_FIELDS):
        raise ValueError(
            f"{where}: fleet must have exactly the fields {list(FLEET_FIELDS)}, got {sorted(map(str, fleet))}"
        )
    if config.motion is not None or config.objective != "rate":
        raise ValueError(
            f"{where}: a fleet serves static nodes with the rate objective (motion None, objective "
            f"'rate'), got motion={config.motion!r}, objective={config.objective!r}"
        )
    if isinstance(fleet["uavs"], bool) or not isinstance(fleet["uavs"], int) or fleet["uavs"] < 2:
        raise ValueError(f"{where}: fleet.uavs must be an integer >= 2 (a fleet), got {fleet['uavs']!r}")
    try:
        fleet_configs(config, fleet)
    except ValueError as err:
        raise ValueError(f"{where}: fleet: {err}") from None
    return {name: fleet[name] for name in FLEET_FIELDS}


def fleet_configs(config: ScenarioConfig, fleet: Mapping[str, Any]) -> list[ScenarioConfig]:
    """Each UAV's scenario (its start, final point and speed limit): ``fleet_setup``'s."""
    return fleet_setup(
        config,
        fleet["uavs"],
        fleet["starts"],
        fleet["finals"],
        fleet["min_separation"],
        fleet["access"],
        fleet["speeds"],
        fleet["horizons"],
    )[2]


def score_flights(
    config: ScenarioConfig, fleet: Mapping[str, Any], flights: Any
) -> tuple[float, bool, float]:
    """(the team's max-min rate in bps/Hz, feasible, the worst breach of eq. (10) in m) of U
    flights (U, N, 2) m on a scenario and its fleet (module docstring; a UAV whose horizon ends
    before T is held at its final point after it: ``model.fleet_horizons``): ``ValueError`` for
    another shape or a value that is not finite."""
    configs = fleet_configs(config, fleet)
    q = np.asarray(flights, dtype=np.float64)
    if q.shape != (len(configs), config.N, 2):
        raise ValueError(
            f"the flights must have shape (U, N, 2) = ({len(configs)}, {config.N}, 2) (one flight per UAV, "
            f"its start first and its final point last), got {q.shape}"
        )
    if not np.isfinite(q).all():
        raise ValueError("the flights have NaN or infinite values")
    slots = horizon_slots(configs)
    own, worst = flights_feasibility(configs, q)
    feasible = own and flights_separated(q, float(fleet["min_separation"]), slots)
    rate = float(fleet_maxmin(config, q, access=fleet["access"], slots=slots).value)
    return rate, bool(feasible), worst


def make_fleet_env(config: ScenarioConfig, fleet: Mapping[str, Any], env_kwargs: Mapping[str, Any]) -> Any:
    """The parallel env of a scenario and its fleet, with ``env_kwargs`` (its own flights are
    scored by :func:`score_flights`, so the env's episode-end scoring is off)."""
    from ios_uav_env import parallel_env

    return parallel_env(config, **dict(fleet), **{**dict(env_kwargs), "best_schedule": False})


def fleet_episode(env: Any, act: Callable, seed: int | None, team: bool) -> tuple[np.ndarray, float]:
    """One episode in the parallel env ``env`` reset with ``seed``: (the flights (U, N, 2) m, its
    wall time in s). ``act`` maps one agent's observation to its action (the same function for
    every agent) or, with ``team``, the dict of the live agents' observations to their actions."""
    start = time.perf_counter()
    obs, _ = env.reset(seed=seed)
    for _ in range(MAX_STEPS):
        if not env.agents:
            break
        live = {agent: obs[agent] for agent in env.agents}  # (an agent past its horizon is gone)
        actions = act(live) if team else {agent: act(o) for agent, o in live.items()}
        obs, *_ = env.step(actions)
    else:
        raise RuntimeError(f"the episode did not end in {MAX_STEPS} steps")
    return env.trajectories, time.perf_counter() - start


def reference_row(rate: float, feasible: bool = True) -> tuple[float, float, bool, float, bool]:
    """A stored reference's values as a scored row's (rate, best rate, feasible, violation, own)."""
    return (float(rate), float(rate), bool(feasible), math.nan, True)


def evaluate_fleet(
    policy: Any,
    suite: Any,
    *,
    env_kwargs: Mapping[str, Any] | None = None,
    n: int | None = None,
    seed: int | None = 0,
    name: str | None = None,
    allow_task_change: bool = False,
) -> Any:
    """Score ``policy`` on the first ``n`` scenarios of the several-UAV ``suite`` (module
    docstring): a ``Results`` (% of the planner and of the bound). ``env_kwargs`` are added to
    the suite's and checked as on every suite (``overrides.check_overrides``: the fleet and the
    scenario fields are pinned, a task change needs ``allow_task_change``)."""
    from ios_uav_env.benchmark.metrics import metrics_of
    from ios_uav_env.benchmark.overrides import check_overrides, policy_env_kwargs
    from ios_uav_env.benchmark.policy_errors import NamedPolicy
    from ios_uav_env.benchmark.results import Results, ScenarioResult
    from ios_uav_env.benchmark.scoring import action_function, check_seed, policy_name

    check_seed(seed)
    own = policy_env_kwargs(suite, policy, env_kwargs)
    check_overrides(suite, own, allow_task_change=allow_task_change)
    team = bool(getattr(policy, "team", False))
    name = name or policy_name(policy)
    bind = getattr(policy, "bind", None)
    kwargs = {**suite.env_kwargs, **own}
    scenarios, metrics = suite.subset(n), metrics_of(suite)
    rows = []
    for i, s in enumerate((scenarios[0], *scenarios)):  # the first: a warm-up, not scored
        env = make_fleet_env(s.config, s.fleet, kwargs)
        try:
            chosen = bind(env.observation_names) if callable(bind) else policy  # a policy reading by name
            act = NamedPolicy(chosen if team else action_function(chosen), suite.name, name)
            act.at(s, warm_up=i == 0)
            flights, seconds = fleet_episode(env, act, seed, team)
        finally:
            env.close()
        if i:
            rate, feasible, worst = score_flights(s.config, s.fleet, flights)
            rows.append(ScenarioResult.of(s, metrics, (rate, rate, feasible, worst, True), seconds, flights))
    return Results.of(suite, name, kwargs, rows, scenarios)


def score_fleet_flights(
    flights: Mapping[int, Any],
    suite: Any,
    *,
    seconds: Mapping[int, float] | None = None,
    name: str = "flights",
) -> Any:
    """Score one plan of U flights per scenario (``{index: (U, N, 2) m}``, the suite's first n) by
    :func:`score_flights`; ``seconds``: each plan's time, if known (``ValueError`` naming the
    scenario for a missing index or a wrong shape)."""
    from ios_uav_env.benchmark.metrics import metrics_of
    from ios_uav_env.benchmark.results import Results, ScenarioResult

    indices = sorted(int(i) for i in flights)
    if not indices or indices != list(range(len(indices))) or indices[-1] >= len(suite):
        raise ValueError(
            f"the flights must cover scenarios 0..n-1 of {suite.name} ({len(suite)} scenarios), got {indices}"
        )
    scenarios, metrics, rows = suite.subset(len(indices)), metrics_of(suite), []
    for s in scenarios:
        try:
            rate, feasible, worst = score_flights(s.config, s.fleet, flights[s.index])
        except ValueError as err:
            raise ValueError(f"scenario {s.index}: {err}") from None
        t = float((seconds or {}).get(s.index, math.nan))
        rows.append(ScenarioResult.of(s, metrics, (rate, rate, feasible, worst, True), t))
    return Results.of(suite, name, {}, rows, scenarios)
