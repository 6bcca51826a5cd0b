"""Score any policy, or any file of trajectories, on a suite: numpy and Gymnasium only.

A policy is any of:

- a callable from one observation to one action (a plain function, a
  ``ios_uav_env.envs.policies.HoverAt``, a CleanRL/TorchRL actor wrapped in a function);
- an object with ``predict(obs, deterministic=True) -> (action, state)`` (Stable-Baselines3;
  a model trained with ``VecNormalize`` needs its statistics applied to the observation, as
  ``agents.loading.load_agent`` of a checkout does);
- a batched callable from a (B, obs_dim) array to a (B, 2) array: pass ``batched=True`` or give
  it an attribute ``batched = True``; each scenario is then planned in the single env with the
  policy on a batch of one observation, and with ``at_once`` every scenario at once in the id's
  natively batched env (its ``vector_entry_point``, made directly, so on every supported
  Gymnasium), one row per scenario.

Actions may be numpy arrays, lists or CPU tensors (anything with ``detach``). Each scenario is
one deterministic episode in the suite's env (``suite.env_id``) pinned to the scenario with
``reset(seed=seed, options={"config": cfg})``; the policy sees that env's observation, with
``env_kwargs`` added (default: the policy's own ``env_kwargs`` attribute, as ``HoverAt("peak")``
has ``{"peak_hint": True}``). The plan is scored by the one scorer: ``ios_uav_env.average_rate``
(eq. (9)) and ``check_trajectory`` (eq. (10)) of the env's trajectory; the time to plan is the
episode's wall time from the reset to the last step (policy and env) in the single env, after
an unscored warm-up episode: what planning one scenario costs a user, without compilations or
first calls (with ``at_once``: the warm batch's wall time divided by the number of scenarios).

>>> from ios_uav_env.benchmark import evaluate
>>> from ios_uav_env.envs.policies import HoverAt
>>> results = evaluate(HoverAt("peak"), n=3)
>>> results.aggregate.feasible, round(results.aggregate.mean_pct_dp, 2)
(3, 99.77)

A STAR-control suite (``suite="star-v1"``) plays each scenario's episode of
``ios_uav_env/STARControl-v0`` with the policy bound to the scenario (``policy.bind(task)``, if it
has ``bind``) and scores it by the env's reward sum as % of the per-slot optimum and of its bound
(:mod:`ios_uav_env.benchmark.star_suite`).

A several-UAV suite (``suite="multi-uav-v1"``) rolls each scenario's fleet out in
``ios_uav_env.parallel_env``, the policy acting for every agent (or, with ``team = True``, for
the team), and scores the flights with ``fleet_maxmin``
(:mod:`ios_uav_env.benchmark.fleet_suite`).

On a multi-node suite (``suite="multi-node-v1"``) the env is ``MultiNodeEnv``
(``ios_uav_env/IOSUAV-MultiNode-Random-v0``), one env pinned per scenario (a batched policy sees
a batch of one): the action is the move and one score per node, and each plan is scored by the
same ``score_plan`` with the shares the policy chose (its own min_k R_k, and its best schedule);
the :class:`~ios_uav_env.benchmark.results.Results` then report % of SCA and of the certified
bound. Scoring a multi-node suite needs scipy (the best schedule is an LP). A policy's plan time
stops before the scoring, as the planners' (``Plan.seconds``, taken before
``Plan.from_trajectory`` scores the plan): the env's own best-schedule LP of the last step
(``score_seconds``, for ``info["best_schedule_rate"]``) is not counted.

A file of trajectories is scored by :mod:`ios_uav_env.benchmark.trajectory_scoring`
(:func:`score_trajectories`, re-exported here).
"""

from __future__ import annotations

import importlib
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from ios_uav_env.benchmark.metrics import Metrics, metrics_of
from ios_uav_env.benchmark.overrides import check_overrides, policy_env_kwargs
from ios_uav_env.benchmark.policy_calls import action_function, check_seed, policy_name  # noqa: F401
from ios_uav_env.benchmark.policy_errors import NamedPolicy
from ios_uav_env.benchmark.results import Results, ScenarioResult
from ios_uav_env.benchmark.suite import Suite, SuiteScenario, suite_of
from ios_uav_env.benchmark.suite_registry import DEFAULT_SUITE
from ios_uav_env.benchmark.trajectory_scoring import score_trajectories  # noqa: F401 (re-exported)
from ios_uav_env.envs.rollout import decision_interval
from ios_uav_env.model.score import score_plan

MAX_STEPS = 100_000


def play(
    env: Any, act: Callable, scenario: SuiteScenario, seed: int | None, repeat: int | None = None
) -> float:
    """One episode of ``act`` in ``env`` pinned to ``scenario`` (reset with ``seed``) until it
    terminates or truncates (``RuntimeError`` after :data:`MAX_STEPS`); its wall time in seconds.
    ``act`` is asked every ``repeat`` slots (default: its own, ``rollout.decision_interval``)."""
    repeat = decision_interval(act) if repeat is None else repeat
    start = time.perf_counter()
    obs, _ = env.reset(seed=seed, options={"config": scenario.config})
    for t in range(MAX_STEPS):
        if t % repeat == 0:
            action = act(obs)
        obs, _, terminated, truncated, _ = env.step(action)
        if np.any(terminated) or np.any(truncated):
            break
    else:
        raise RuntimeError(f"scenario {scenario.index}: the episode did not end in {MAX_STEPS} steps")
    return time.perf_counter() - start


def episode(
    env: Any, act: Callable, scenario: SuiteScenario, seed: int | None, metrics: Metrics
) -> ScenarioResult:
    """One episode of ``act`` on ``scenario`` in the single env ``env`` (a batched action function
    as :func:`batch_of_one`), scored by ``score_plan`` of its trajectory (and, K > 1 nodes, the
    shares the policy chose). A mobile scenario's episode is reset with its own seed (``seed`` is
    not used) and scored on the node's true path, which must be the scenario's (``RuntimeError``
    otherwise: the env drew another)."""
    cfg = scenario.config
    paths = scenario.paths()
    if paths is not None:
        seed = scenario.seed
    seconds = play(env, act, scenario, seed, decision_interval(act))
    base = env.unwrapped
    seconds -= getattr(base, "score_seconds", 0.0)  # the env's scoring LP is not the plan's time
    trajectory = base.trajectory
    shares = base.shares if cfg.K > 1 else None  # (a multi-node suite runs the single env)
    if paths is not None:
        if not np.array_equal(base.paths, paths):
            raise RuntimeError(
                f"scenario {scenario.index}: the env drew another node path than the suite's (seed "
                f"{scenario.seed}): its draws are not those of ios_uav_env.envs.knowledge"
            )
    try:
        score = score_plan(cfg, trajectory, shares, paths)
    except ValueError as err:
        raise ValueError(f"scenario {scenario.index}: {err}") from None
    return ScenarioResult.of(scenario, metrics, score, seconds, trajectory, shares)


def _make_env(
    env_id: str, env_kwargs: Mapping[str, Any], batched: bool, num_envs: int = 1
) -> tuple[Any, bool]:
    """The env to run in, and whether it is batched (the id's batched env of ``num_envs`` rows,
    if it has one)."""
    import gymnasium as gym

    import ios_uav_env  # noqa: F401  (registers the ids)

    spec = gym.spec(env_id)
    entry = getattr(spec, "vector_entry_point", None)
    if batched and isinstance(entry, str):  # as make_vec(vectorization_mode="vector_entry_point") does
        module, _, attr = entry.partition(":")
        vector_env = getattr(importlib.import_module(module), attr)
        return vector_env(num_envs=num_envs, **{**(spec.kwargs or {}), **env_kwargs}), True
    return gym.make(env_id, **env_kwargs), False


def check_env_kwargs(
    suite: Suite, env_kwargs: Mapping[str, Any], policy: Any = None, *, allow_task_change: bool = False
) -> None:
    """``ValueError`` if ``env_kwargs`` (added to the suite's) would be ignored or change the suite's
    task without ``allow_task_change`` (:func:`~ios_uav_env.benchmark.overrides.check_overrides`),
    if the suite's env does not take them, or if ``policy`` says which observations it takes (an
    ``observation_space``, as SB3's models and ``agents.numpy_policy.NumpyPolicy`` do) and the
    env's are of another shape: the env is made once with them, and closed, before any scenario runs."""
    check_overrides(suite, env_kwargs, allow_task_change=allow_task_change)
    _check_env_takes(suite, env_kwargs, policy)


def _check_env_takes(suite: Suite, env_kwargs: Mapping[str, Any], policy: Any) -> None:
    """:func:`check_env_kwargs` after its ``check_overrides`` (for a caller that ran it already)."""
    kwargs = {**suite.env_kwargs, **dict(env_kwargs)}
    if suite.fleets:  # a fleet on the first scenario (an agent's observations depend on its U)
        from ios_uav_env.benchmark.fleet_scoring import make_fleet_env

        try:
            make_fleet_env(suite[0].config, suite[0].fleet, kwargs).close()
        except (TypeError, ValueError) as err:
            raise ValueError(
                f"{suite.env_id} does not take the env_kwargs {dict(env_kwargs)}: {err}"
            ) from None
        return
    if suite.star_control:  # the first scenario's env (the widths are each scenario's: bound per scenario)
        from ios_uav_env.benchmark.star_scoring import control_of

        make_env, _, field, _ = control_of(suite)
        try:
            make_env(getattr(suite[0], field), kwargs).close()
        except (TypeError, ValueError) as err:
            raise ValueError(
                f"{suite.env_id} does not take the env_kwargs {dict(env_kwargs)}: {err}"
            ) from None
        return
    try:
        env, _ = _make_env(suite.env_id, kwargs, False)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{suite.env_id} does not take the env_kwargs {dict(env_kwargs)}: {err}") from None
    shape, wanted = (
        env.observation_space.shape,
        getattr(getattr(policy, "observation_space", None), "shape", None),
    )
    env.close()
    if wanted is not None and tuple(wanted) != tuple(shape):
        raise ValueError(
            f"the policy takes observations of shape {tuple(wanted)}, but {suite.env_id} with the env_kwargs "
            f"{kwargs} gives {tuple(shape)}: pass the env arguments it was trained with (e.g. "
            "instance_features:false for a specialist of a fixed id, peak_hint:true for a hinted agent)"
        )


def evaluate(
    policy: Any,
    suite: Suite | str = DEFAULT_SUITE,
    *,
    env_kwargs: Mapping[str, Any] | None = None,
    n: int | None = None,
    batched: bool | None = None,
    seed: int | None = 0,
    name: str | None = None,
    at_once: bool = False,
    allow_task_change: bool = False,
) -> Results:
    """Score ``policy`` on the first ``n`` scenarios of ``suite`` (all for None): a :class:`Results`
    (per scenario: rate, feasibility, % of DP and of SCA, time to plan; their aggregate).

    ``env_kwargs`` are added to the suite's env arguments (default: ``policy.env_kwargs`` if it
    has them, without its training draw: :func:`~ios_uav_env.benchmark.overrides.policy_env_kwargs`,
    which also refuses ``env_kwargs`` that show the policy other observations than its own
    declare); ``batched`` (default: ``policy.batched``) gives the policy a batch of one
    observation; ``seed`` (None or an integer >= 0) seeds each scenario's reset; ``at_once``:
    every scenario at once in the batched env (:func:`evaluate_scenarios`). Env arguments that
    would be ignored (a scenario field, a reset's draw) are refused, and so are those that change
    the suite's task (:mod:`~ios_uav_env.benchmark.overrides`) unless ``allow_task_change``: the
    results then name the changed task (``Results.task``) wherever they are printed or saved.
    """
    suite = suite_of(suite)
    if suite.fleets:  # several UAVs: episodes of PettingZoo's parallel env (benchmark.fleet_suite)
        from ios_uav_env.benchmark.fleet_scoring import evaluate_fleet

        if batched or at_once:
            raise ValueError(f"batched and at_once are for single-UAV suites; {suite.name} flies fleets")
        return evaluate_fleet(policy, suite, env_kwargs=env_kwargs, n=n, seed=seed, name=name,
                              allow_task_change=allow_task_change)  # fmt: skip
    if suite.star_control:  # the surface's settings: episodes of STARControl-v0 or MISOControl-v0
        from ios_uav_env.benchmark.star_scoring import evaluate_star

        if batched or at_once:
            raise ValueError(f"batched and at_once are for UAV-flight suites; {suite.name} sets a surface")
        return evaluate_star(policy, suite, env_kwargs=env_kwargs, n=n, seed=seed, name=name,
                             allow_task_change=allow_task_change)  # fmt: skip
    own = policy_env_kwargs(suite, policy, env_kwargs)
    check_overrides(suite, own, allow_task_change=allow_task_change)  # once: the calls below skip it
    if getattr(policy, "observation_space", None) is not None:
        _check_env_takes(suite, own, policy)
    from ios_uav_env.envs.rollout import policy_for  # a policy reading features by name: checked first

    policy = policy_for(policy, suite.env_id, {**suite.env_kwargs, **dict(own or {})})
    batched = bool(getattr(policy, "batched", False) if batched is None else batched)
    name = name or policy_name(policy)
    act = action_function(policy)
    if at_once and batched:  # run_episodes hands the batch to a function that says it takes one
        act = _takes_a_batch(act)
    check_seed(seed)
    return _evaluate_checked(act, suite, suite.subset(n), own, seed, name, batched=batched, at_once=at_once)


def _takes_a_batch(act: Callable) -> Callable:
    def batch(obs: np.ndarray) -> np.ndarray:
        return act(obs)

    batch.batched = True  # type: ignore[attr-defined]
    return batch


def evaluate_scenarios(
    act: Callable,
    suite: Suite,
    scenarios: Sequence[SuiteScenario],
    env_kwargs: Mapping[str, Any] | None,
    seed: int | None,
    name: str,
    *,
    batched: bool = False,
    at_once: bool = False,
    allow_task_change: bool = False,
) -> Results:
    """Roll ``act`` (an action function, :func:`action_function`) out on ``scenarios`` of
    ``suite`` in the suite's env with ``env_kwargs`` added to the suite's, and score each plan.
    ``env_kwargs`` that would be ignored, or change the suite's task without
    ``allow_task_change``, are refused (:func:`~ios_uav_env.benchmark.overrides.check_overrides`).

    A plan's time is what planning that scenario costs a user: without ``at_once``, the wall time
    of its episode in the id's single env (a ``batched`` action function sees a batch of one
    observation, :func:`batch_of_one`), after one unscored warm-up episode of the first scenario
    in the same env, so no compilation, cache load or first call of the policy is in any
    scenario's time. ``at_once`` (single-node suites): every scenario at once, row i of the id's
    batched env pinned to scenario i (``ios_uav_env.envs.rollout.run_episodes``: the same
    episodes as one env pinned per scenario); ``act`` sees the (B, obs_dim) batch (one call per
    row unless it says ``batched = True``), and a plan's time is the batch's divided by B (after
    a warm-up batch of the first scenario): the time per plan when the suite is planned at once.

    An exception of ``act`` is raised again as
    :class:`~ios_uav_env.benchmark.policy_errors.PolicyError` naming the suite, the scenario
    (or the batch) and ``name``, the policy's own exception chained."""
    check_seed(seed)
    check_overrides(suite, env_kwargs, allow_task_change=allow_task_change)
    return _evaluate_checked(act, suite, scenarios, env_kwargs, seed, name, batched=batched, at_once=at_once)


def _evaluate_checked(
    act: Callable,
    suite: Suite,
    scenarios: Sequence[SuiteScenario],
    env_kwargs: Mapping[str, Any] | None,
    seed: int | None,
    name: str,
    *,
    batched: bool,
    at_once: bool,
) -> Results:
    """:func:`evaluate_scenarios` after its checks of ``seed`` and ``env_kwargs`` (run once by the caller)."""
    metrics = metrics_of(suite)
    kwargs = {**suite.env_kwargs, **dict(env_kwargs or {})}
    named = NamedPolicy(act, suite.name, name)  # a policy's error names the suite, scenario and policy
    if at_once:
        return _at_once(named, suite, scenarios, kwargs, seed, name, metrics)
    env, _ = _make_env(suite.env_id, kwargs, False)  # one scenario is planned in the single env
    act = batch_of_one(named) if batched else named
    try:
        max_nodes = getattr(env.unwrapped, "max_nodes", 1)
        too_many = [s.index for s in scenarios if s.config.K > max_nodes]
        if too_many:
            raise ValueError(
                f"scenarios {too_many} have more nodes than the env's max_nodes = {max_nodes} "
                f"(env_kwargs {kwargs})"
            )
        if scenarios:  # warm-up, not scored: compilations and first calls stay out of the plan times
            named.at(scenarios[0], warm_up=True)
            episode(env, act, scenarios[0], seed, metrics)
        rows = []
        for s in scenarios:
            named.at(s)
            rows.append(episode(env, act, s, seed, metrics))
    finally:
        env.close()
    return Results.of(suite, name, kwargs, rows, scenarios)


def batch_of_one(act: Callable) -> Callable[[np.ndarray], np.ndarray]:
    """A batched action function (a (B, obs_dim) batch to (B, action_dim)) as a function of one
    observation, the batch of one row it sees; its ``repeat`` kept. ``ValueError`` if it returns
    another shape than (1, action_dim)."""

    def one(obs: np.ndarray) -> np.ndarray:
        action = np.asarray(act(np.asarray(obs)[None]))
        if action.ndim != 2 or action.shape[0] != 1:
            raise ValueError(
                f"a batched policy must return a (B, action_dim) action (B=1 here), got {action.shape}"
            )
        return action[0]

    one.repeat = decision_interval(act)  # type: ignore[attr-defined]
    return one


def _at_once(
    act: NamedPolicy, suite: Suite, scenarios: Sequence[SuiteScenario], kwargs: dict[str, Any],
    seed: int | None, name: str, metrics: Metrics,
) -> Results:  # fmt: skip
    """:func:`evaluate_scenarios` with ``at_once`` (``metrics``: the suite's)."""
    from ios_uav_env.envs.rollout import run_episodes

    if suite.multi_node or suite.mobile:
        raise ValueError(f"at_once is for static single-node suites; {suite.name} is a {suite.kind} suite")
    if not scenarios:
        raise ValueError("no scenarios to evaluate")
    seeds = None if seed is None else [seed]
    for count in (1, len(scenarios)):  # a warm-up batch of the first scenario, then the timed one
        vec, vector = _make_env(suite.env_id, kwargs, True, count)
        try:
            if not vector:
                raise ValueError(
                    f"{suite.env_id} has no batched env here (Gymnasium >= 1.0): evaluate without at_once"
                )
            configs = [s.config for s in scenarios[:count]]
            if count == 1:
                act.at(scenarios[0], warm_up=True)
            else:
                act.at_once(scenarios)
            episodes = run_episodes(vec, act, seed=None if seeds is None else seeds * count,
                                    options={"configs": configs})  # fmt: skip
        finally:
            vec.close()
    rows = [ScenarioResult.of(s, metrics, score_plan(s.config, e.trajectory), e.seconds, e.trajectory)
            for s, e in zip(scenarios, episodes, strict=True)]  # fmt: skip
    return Results.of(suite, name, kwargs, rows, scenarios)
