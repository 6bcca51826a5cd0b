"""A policy's episodes on a several-UAV suite and the scoring of flights planned elsewhere: the
parallel env of each scenario and its fleet, the rollout (a policy shared by every agent, or a
team policy), and the rows of ``fleet_suite.score_flights``
(:mod:`ios_uav_env.benchmark.fleet_suite` says what a scenario holds and how a plan is scored).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from ios_uav_env.benchmark.fleet_suite import score_flights
from ios_uav_env.benchmark.metrics import metrics_of
from ios_uav_env.benchmark.overrides import check_overrides, policy_env_kwargs
from ios_uav_env.benchmark.policy_calls import action_function, check_seed, policy_name
from ios_uav_env.benchmark.policy_errors import NamedPolicy
from ios_uav_env.benchmark.results import Results, ScenarioResult
from ios_uav_env.benchmark.trajectories import check_plan_time
from ios_uav_env.model.config import ScenarioConfig

__all__ = ["evaluate_fleet", "fleet_episode", "make_fleet_env", "score_fleet_flights"]

#: Most steps of one episode before it is declared stuck.
MAX_STEPS = 100_000


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
        t = check_plan_time((seconds or {}).get(s.index, math.nan), f"scenario {s.index}", unknown=True)
        rows.append(ScenarioResult.of(s, metrics, (rate, rate, feasible, worst, True), t))
    return Results.of(suite, name, {}, rows, scenarios)
