"""A policy's episodes on a surface-control suite (STAR-control, ``star-v1``; MISO-control,
``miso-v1``): each scenario's env, the policy bound to it, and its rows
(:mod:`ios_uav_env.benchmark.star_suite` and :mod:`ios_uav_env.benchmark.miso_suite` say what a
scenario holds; both are scored by ``star_suite.star_episode``)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ios_uav_env.benchmark.metrics import metrics_of
from ios_uav_env.benchmark.overrides import check_overrides, policy_env_kwargs
from ios_uav_env.benchmark.policy_calls import action_function, check_seed, policy_name
from ios_uav_env.benchmark.policy_errors import NamedPolicy
from ios_uav_env.benchmark.results import Results, ScenarioResult
from ios_uav_env.benchmark.star_suite import StarTask, make_star_env, star_episode
from ios_uav_env.benchmark.suite_registry import MISO_CONTROL

__all__ = ["bound_policy", "evaluate_star", "control_of"]


def bound_policy(policy: Any, task: StarTask, where: str) -> Any:
    """``policy`` bound to ``task`` (``policy.bind(task)`` if it has ``bind``, else itself);
    ``ValueError`` naming ``where`` if the result declares an ``observation_space`` or an
    ``action_space`` (an SB3 model) of another shape than the scenario's."""
    bind = getattr(policy, "bind", None)
    chosen = bind(task) if callable(bind) else policy
    for what, space, width in (("takes observations", "observation_space", len(task.observation_names)),
                               ("gives actions", "action_space", task.action_dim)):  # fmt: skip
        wanted = getattr(getattr(chosen, space, None), "shape", None)
        if wanted is not None and tuple(wanted) != (width,):
            raise ValueError(
                f"{where}: the policy {what} of shape {tuple(wanted)}, the scenario's env ({width},) "
                f"({task}): give the policy a bind(task) that picks one for each scenario "
                "(ios_uav_env.benchmark.star_suite)"
            )
    return chosen


def control_of(suite: Any) -> tuple[Any, Any, str, str]:
    """A surface-control suite's env maker, task class, scenario field of the env keywords and
    ``info`` key of a slot's certified bound."""
    if suite.kind == MISO_CONTROL:
        from ios_uav_env.benchmark.miso_suite import MisoTask, make_miso_env

        return make_miso_env, MisoTask, "miso", "bound"
    return make_star_env, StarTask, "star", "optimum_upper"


def evaluate_star(
    policy: Any,
    suite: Any,
    *,
    env_kwargs: Mapping[str, Any] | None = None,
    n: int | None = None,
    seed: int | None = 0,
    name: str | None = None,
    allow_task_change: bool = False,
) -> Results:
    """Score ``policy`` on the first ``n`` scenarios of the surface-control ``suite`` (STAR- or
    MISO-control: :func:`control_of`): a ``Results``
    (% of the per-slot optimum and of its certified bound). Each scenario's episode is reset with
    the scenario's own seed (``seed`` is checked, not used: the seed fixes the line, so it is the
    scenario's). ``env_kwargs`` are added to the suite's and checked as on every suite
    (``overrides.check_overrides``: the scenario's keywords are pinned). A plan's time is the
    policy's own calls over the episode, after an unscored warm-up episode of the first scenario."""
    check_seed(seed)
    own = policy_env_kwargs(suite, policy, env_kwargs)
    check_overrides(suite, own, allow_task_change=allow_task_change)
    name = name or policy_name(policy)
    kwargs = {**suite.env_kwargs, **own}
    scenarios, metrics = suite.subset(n), metrics_of(suite)
    make_env, task_of, field, upper = control_of(suite)
    rows = []
    for i, s in enumerate((scenarios[0], *scenarios)):  # the first: a warm-up, not scored
        where = f"{suite.name} scenario {s.index}"
        keywords = getattr(s, field)
        env = make_env(keywords, {**kwargs, "optimum": False})  # (the reference holds it)
        try:
            chosen = bound_policy(policy, task_of.of(keywords, env), where)
            act = NamedPolicy(action_function(chosen), suite.name, name)
            act.at(s, warm_up=i == 0)
            episode = star_episode(env, act, s.seed, s.config, where, upper)
        finally:
            env.close()
        if i:
            rate = episode.value
            rows.append(ScenarioResult.of(s, metrics, (rate, rate, True, 0.0, True), episode.seconds))
    return Results.of(suite, name, kwargs, rows, scenarios)
