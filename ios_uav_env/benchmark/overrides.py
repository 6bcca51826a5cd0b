"""Which env arguments a run on a suite may add: a suite is a task, and its name says which.

A suite's task is its env (``suite.env_id`` with the suite's ``env_kwargs``) on its pinned
scenarios; its reference values were computed for that task. Every argument the suite's env
takes is in one of four classes:

- :data:`PRESENTATION`: what the policy is shown, made from what it already knows (the
  instance features, the rate-peak hint, the length scale, the energy weight, the Kalman
  estimate of the reports it receives, the padding of the node blocks) or how the env renders;
- :data:`REWARD`: the shaping of the per-step reward, which no score reads;
- :data:`TASK`: what the UAV knows (``knowledge``, ``report_sigma``; a STAR surface's controller:
  ``channel_phases``), the channel it flies in,
  the projection of its moves (``arrival_guard``) and the shares its actions can give
  (``share_sharpness``): another value is another task. :func:`check_overrides` refuses it
  unless ``allow_task_change`` is given, and the results then carry the change
  (``Results.task_changes``), printed and saved as another task (``Results.task``);
- :data:`PINNED`: what a reset draws (``config``, ``ranges``, ``focus``, ``focus_prob``), what
  the suite's scoring computes (``best_schedule``), a fleet's and a STAR scenario's keywords
  (:data:`FLEET`, :data:`STAR`) and every ``ScenarioConfig`` field: the suite
  pins each scenario at reset and scores each episode, so they would be ignored.
  :func:`check_overrides` refuses them; :func:`policy_env_kwargs` drops them from a policy's own
  ``env_kwargs`` (its training draw), which the suite replaces by its scenarios.

An argument the env takes that is in none of them is taken as a task change (tests check that
every argument of every suite's env is classified).
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import inspect
from collections.abc import Mapping
from typing import Any

from ios_uav_env.model.config import SCENARIO_FIELDS

#: Shown to the policy or rendered: functions of what the policy already knows. Allowed.
PRESENTATION: frozenset[str] = frozenset(
    {"instance_features", "peak_hint", "length_scale", "energy_reference", "filter_estimate",
     "max_nodes", "random_nodes", "render_mode"}
)  # fmt: skip
#: The reward's shaping (no score reads the reward). Allowed.
REWARD: frozenset[str] = frozenset({"reach_weight", "terminal_weight", "softmin_beta"})
#: Another value is another task, by what it changes.
TASK: dict[str, str] = {
    "knowledge": "what the UAV is told of the node each slot",
    "report_sigma": "the noise of the position reports",
    "channel": "the channel the rates are drawn from",
    "arrival_guard": "the projection of every move onto the moves that still reach qF",
    "share_sharpness": "the shares an action can give (the softmax of its scores)",
    "surface_sharpness": "the surface's time shares the UAVs' bids can give (the softmax of the bids)",
    "channel_phases": "what the surface's controller is told of the channels each slot",
    "view": "the observation view and the action type it is read with (the id's preset)",
    "action": "the action type (the view's)",
    "draws": "whether each reset draws its scenario (the v0 view's randomised ids)",
    "control": "how the surface control's action sets the surface (phases, or offsets to the aligned)",
}
#: What a reset draws: the suite pins every scenario instead. Refused (dropped from a policy's own).
DRAW: frozenset[str] = frozenset({"config", "ranges", "focus", "focus_prob"})
#: What the suite's scoring fixes: the episode-end schedule it reports (``best_schedule``; a
#: training run may skip it) and the surface control's per-slot optimum in ``info`` (``optimum``:
#: a STAR-control suite holds it as a reference and rolls policies out without it). Refused
#: (dropped from a policy's own), as the draws are.
SCORING: frozenset[str] = frozenset({"best_schedule", "optimum"})
#: A several-UAV suite's fleet (``fleet_suite.FLEET_FIELDS``): each scenario fixes it.
FLEET: frozenset[str] = frozenset(
    {"uavs", "starts", "finals", "speeds", "access", "min_separation", "horizons"}
)
#: A STAR-control suite's env keywords (``star_suite.STAR_FIELDS``): each scenario fixes them.
STAR: frozenset[str] = frozenset({"elements", "bits", "group", "protocol", "access", "direct_link"})
#: A MISO-control suite's env keywords (``miso_suite.MISO_FIELDS``): each scenario fixes them; and
#: ``access``, which its scenarios leave at the env's default (linear precoding: the suite's
#: references are the SDMA AO's), so another would score one problem against another's references.
MISO: frozenset[str] = frozenset({"antennas", "users", "elements", "objective", "access"})
PINNED: frozenset[str] = DRAW | SCORING | FLEET | STAR | MISO | SCENARIO_FIELDS
#: Presentation arguments a policy's own ``env_kwargs`` fix: the observations it was trained on.
OBSERVATION: frozenset[str] = PRESENTATION - {"render_mode"}


def _env_classes(env_id: str) -> tuple[type, ...]:
    """The env class of ``env_id``; for a several-UAV suite's parallel env, it and the class of
    its UAVs' rows (``MultiNodeEnv``), whose arguments it passes on."""
    from ios_uav_env.benchmark.suite_registry import FLEET_ENV_ID

    if env_id == FLEET_ENV_ID:
        from ios_uav_env.envs.fleet import FleetParallelEnv
        from ios_uav_env.envs.multi import MultiNodeEnv

        return (FleetParallelEnv, *_with_stepper(MultiNodeEnv, {}))
    import gymnasium as gym

    import ios_uav_env  # noqa: F401  (registers the ids)

    spec = gym.spec(env_id)
    module, _, attr = str(spec.entry_point).partition(":")
    cls = getattr(importlib.import_module(module), attr)
    return _with_stepper(cls, spec.kwargs or {})


def _with_stepper(cls: type, kwargs: Mapping[str, Any]) -> tuple[type, ...]:
    """``cls`` and, for a ``UAVEnv`` (``stepper_class``), the stepper class it runs with ``kwargs``,
    whose constructor takes the env's arguments besides ``UAVEnv``'s own."""
    stepper = getattr(cls, "stepper_class", None)
    return (cls,) if stepper is None else (cls, stepper(**kwargs))


def _own_inits(env_id: str) -> list[Any]:
    """The ``__init__`` of the env classes of ``env_id`` and of their bases in this package,
    subclass first (the first class's first)."""
    own = [c for cls in _env_classes(env_id) for c in cls.__mro__
           if c.__module__.startswith("ios_uav_env.") and "__init__" in vars(c)]  # fmt: skip
    return [c.__init__ for c in dict.fromkeys(own)]


@functools.cache
def env_arguments(env_id: str) -> frozenset[str]:
    """Every keyword argument the env of ``env_id`` takes: its constructors' named parameters,
    the ``EnvOptions`` fields and the ``ScenarioConfig`` fields."""
    from ios_uav_env.envs.options import OPTION_FIELDS

    named = {
        p.name
        for init in _own_inits(env_id)
        for p in inspect.signature(init).parameters.values()
        if p.name not in ("self", "env") and p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL)
    }
    return frozenset(named | OPTION_FIELDS | SCENARIO_FIELDS)


@functools.cache
def _id_defaults(env_id: str) -> dict[str, Any]:
    import gymnasium as gym

    from ios_uav_env.envs.options import EnvOptions

    defaults: dict[str, Any] = {f.name: f.default for f in dataclasses.fields(EnvOptions)}
    for init in reversed(_own_inits(env_id)):  # a subclass's (and the fleet's) default wins
        for p in inspect.signature(init).parameters.values():
            if p.default is not p.empty:
                defaults[p.name] = p.default
    spec = gym.registry.get(env_id)
    return {**defaults, **dict((spec.kwargs if spec is not None else None) or {})}


def env_defaults(suite: Any) -> dict[str, Any]:
    """The value of each env argument in the suite's task: the env's defaults, its id's
    registered arguments, the suite's ``env_kwargs``."""
    return {**_id_defaults(suite.env_id), **dict(suite.env_kwargs)}


def classify(name: str) -> str:
    """``"presentation"``, ``"reward"``, ``"task"``, ``"pinned"`` or ``"unclassified"``."""
    classes = (("presentation", PRESENTATION), ("reward", REWARD), ("task", TASK), ("pinned", PINNED))
    for kind, names in classes:
        if name in names:
            return kind
    return "unclassified"


def task_changes(suite: Any, env_kwargs: Mapping[str, Any] | None) -> dict[str, Any]:
    """The arguments of ``env_kwargs`` that make another task than the suite's: a :data:`TASK`
    argument (or one the env takes that is unclassified) at another value than the suite's."""
    defaults, taken = env_defaults(suite), env_arguments(suite.env_id)
    missing = object()
    return {
        k: v
        for k, v in dict(env_kwargs or {}).items()
        if (k in TASK or (classify(k) == "unclassified" and k in taken)) and defaults.get(k, missing) != v
    }


def task_label(suite_name: str, changes: Mapping[str, Any]) -> str:
    """The name a result is printed and saved under: the suite's, or, for a changed task,
    ``"<suite> with k=v, ... [not <suite>'s task]"``."""
    if not changes:
        return suite_name
    changed = ", ".join(f"{k}={v!r}" for k, v in sorted(changes.items()))
    return f"{suite_name} with {changed} [not {suite_name}'s task]"


def check_names(suite: Any, env_kwargs: Mapping[str, Any] | None) -> None:
    """``ValueError`` naming the arguments of ``env_kwargs`` that the suite's env does not take."""
    taken = env_arguments(suite.env_id)
    unknown = sorted(k for k in dict(env_kwargs or {}) if k not in taken)
    if unknown:
        options = sorted(k for k in taken if k not in PINNED)
        raise ValueError(f"{suite.env_id} takes no env argument {unknown}; it takes {options} "
                         "(and the scenario fields, which the suite pins)")  # fmt: skip


def check_overrides(
    suite: Any, env_kwargs: Mapping[str, Any] | None, *, allow_task_change: bool = False
) -> dict[str, Any]:
    """The task changes of ``env_kwargs`` on ``suite`` (:func:`task_changes`); ``ValueError``
    naming the argument, the suite and the way out for an argument the env does not take
    (:func:`check_names`), a :data:`PINNED` argument (always: it would be ignored) or a task
    change without ``allow_task_change``."""
    kwargs = dict(env_kwargs or {})
    check_names(suite, kwargs)
    pinned = sorted(k for k in kwargs if k in PINNED)
    if pinned:
        fields = [k for k in pinned if k in SCENARIO_FIELDS]
        fleet = [k for k in pinned if k in FLEET]
        star = [k for k in pinned if k in STAR | MISO] if getattr(suite, "star_control", False) else []
        what = (f"the scenario fields {fields} come from each scenario" if fields
                else f"the {'MISO' if getattr(suite, 'miso_control', False) else 'STAR'} keywords {star} "
                "come from each scenario" if star
                else f"the fleet's {fleet} come from each scenario" if fleet
                else "no reset draws a scenario")  # fmt: skip
        pins = (
            "every scenario's keywords and episode seed are pinned"
            if getattr(suite, "star_control", False)
            else "every scenario's ScenarioConfig is pinned at reset (options={'config': ...})"
        )
        raise ValueError(
            f"env_kwargs {pinned} would be ignored on suite {suite.name}: {pins}, so {what}; drop them "
            "(another scenario is another suite: a suite file)"
        )
    changes = task_changes(suite, kwargs)
    if changes and not allow_task_change:
        defaults = env_defaults(suite)
        what = {k: TASK.get(k, "an argument of unknown effect") for k in changes}
        parts = [f"{k}={v!r} (the suite's: {defaults.get(k, 'none')!r}; {what[k]})"
                 for k, v in sorted(changes.items())]  # fmt: skip
        raise ValueError(
            f"env_kwargs {', '.join(parts)} change the task of suite {suite.name}: its references were "
            f"computed with the suite's values, so the scores would not be {suite.name} scores. To run it "
            "anyway, pass allow_task_change=True (--allow-task-change on the command line): the results are "
            f"then labelled {task_label(suite.name, changes)!r}"
        )
    return changes


def policy_env_kwargs(suite: Any, policy: Any, env_kwargs: Mapping[str, Any] | None) -> dict[str, Any]:
    """The env arguments ``policy`` runs with on ``suite``: ``env_kwargs`` if given, else the
    policy's own ``env_kwargs`` attribute without its training draw (:data:`PINNED`: the suite
    pins every scenario). ``ValueError`` if given ``env_kwargs`` show the policy other
    observations than its own declare (an :data:`OBSERVATION` argument of its own at another
    value, or left out where the suite's env has another default): e.g. another
    ``energy_reference`` than the one it was trained with."""
    own = {k: v for k, v in dict(getattr(policy, "env_kwargs", None) or {}).items() if k not in PINNED}
    if env_kwargs is None:
        return own
    check_names(suite, env_kwargs)
    given, defaults, missing = dict(env_kwargs), env_defaults(suite), object()
    wrong = {k: v for k, v in own.items() if k in OBSERVATION and given.get(k, defaults.get(k, missing)) != v}
    if wrong:
        parts = [f"{k}={v!r}, env_kwargs give {given[k]!r}" if k in given
                 else f"{k}={v!r}, env_kwargs leave it at {defaults.get(k)!r}"
                 for k, v in sorted(wrong.items())]  # fmt: skip
        fix = ", ".join(f"{k}:{v!r}" for k, v in sorted(wrong.items()))
        raise ValueError(
            f"the policy was trained with {'; '.join(parts)}: it would see other observations than its own. "
            f"Give {fix} (or no env_kwargs: the policy's own)"
        )
    return given
