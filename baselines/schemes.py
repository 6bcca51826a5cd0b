"""The paper's benchmark schemes (and the DP optimum), runnable on any ScenarioConfig.

=========  =======  ==========================================================
scheme     surface  planner
=========  =======  ==========================================================
``ia``     IOS      SCA (``baselines.sca.solve``), the paper's proposal
``ra``     RIS      SCA
``ia-ft``  IOS      fixed fly-hover-fly trajectory (``baselines.fixed``)
``cuc``    none     SCA
``dp``     config's global optimum on a grid (``baselines.dp.solve``)
``dp-ia``  IOS      DP
``dp-ra``  RIS      DP
``dp-cuc`` none     DP
``dp-sta`` STAR     DP (a STAR surface, TDMA: ``ScenarioConfig(surface="star")``)
``dp-star`` STAR    DP over the user weights (NOMA: both sides' users at once, ``baselines.dp_star``)
``tour``   config's tour heuristic (``baselines.tour``), for several ground nodes
=========  =======  ==========================================================

With several ground nodes (``ScenarioConfig.ground_nodes``) every plan is scored by the
max-min rate (``ios_uav_env.maxmin_rate``); SCA runs block-coordinate descent and ``dp``
returns the best DP plan with a certified upper bound in ``info["upper_bound"]``.

``baselines.sca`` (which needs cvxpy) is imported only when an SCA scheme runs, so the
other schemes work without it.

>>> from baselines.schemes import run_scheme
>>> from ios_uav_env import ScenarioConfig
>>> plan = run_scheme("ia-ft", ScenarioConfig(T=60, ios_shape=(10, 6)))
>>> plan.scheme, plan.feasible
('ia-ft', True)
"""

from __future__ import annotations

import dataclasses
import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from baselines import registry
from baselines.plan import Plan
from ios_uav_env import ScenarioConfig


@dataclass(frozen=True)
class Scheme:
    """A named benchmark: which surface, which planner."""

    name: str
    surface: str | None  # "ios", "ris", "none", "star"; None keeps the config's surface
    planner: str  # a name of baselines.registry.PLANNERS: "sca", "dp", "fixed" or "tour"
    description: str
    access: str | None = None  # the STAR access it sets ("noma" for dp-star); None keeps the config's

    def __post_init__(self) -> None:
        registry.get(self.planner)


SCHEMES: dict[str, Scheme] = {
    s.name: s
    for s in (
        Scheme("ia", "ios", "sca", "IOS, trajectory optimised by SCA (the paper's proposal)"),
        Scheme("ra", "ris", "sca", "RIS (reflection only), trajectory optimised by SCA"),
        Scheme("ia-ft", "ios", "fixed", "IOS, fixed fly-hover-fly trajectory over G"),
        Scheme("cuc", "none", "sca", "no surface, trajectory optimised by SCA"),
        Scheme("dp", None, "dp", "global optimum on a grid (DP), the config's surface"),
        Scheme("dp-ia", "ios", "dp", "IOS, global optimum on a grid (DP)"),
        Scheme("dp-ra", "ris", "dp", "RIS, global optimum on a grid (DP)"),
        Scheme("dp-cuc", "none", "dp", "no surface, global optimum on a grid (DP)"),
        Scheme("dp-sta", "star", "dp", "STAR surface (TDMA), global optimum on a grid (DP)"),
        Scheme(
            "dp-star",
            "star",
            "dp-star",
            "STAR surface serving both users at once (NOMA): best DP plan "
            "over the user weights, certified bound",
            access="noma",
        ),
        Scheme(
            "tour", None, "tour", "tour heuristic over hover points (several nodes), the config's surface"
        ),
    )
}


def get_scheme(name: str) -> Scheme:
    """The :class:`Scheme` called ``name``; ``ValueError`` listing the valid names otherwise."""
    try:
        return SCHEMES[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown scheme {name!r}; valid schemes: {', '.join(SCHEMES)}") from None


def sca_unavailable_reason() -> str | None:
    """Why the SCA schemes cannot run (``baselines.sca`` missing or broken), or None if they can."""
    try:
        importlib.import_module("baselines.sca")
    except ImportError as exc:
        return f"baselines.sca cannot be imported ({exc}); the SCA schemes need it and cvxpy"
    return None


def available(name: str) -> bool:
    """Whether scheme ``name`` can run in this installation."""
    return get_scheme(name).planner != "sca" or sca_unavailable_reason() is None


def _planner(kind: str) -> Callable[..., Plan]:
    """The entry point of registered planner ``kind`` (``baselines.registry``)."""
    if kind == "sca" and (reason := sca_unavailable_reason()) is not None:
        raise ImportError(reason)
    return registry.get(kind).load()


def scheme_config(name: str, config: ScenarioConfig) -> ScenarioConfig:
    """``config`` with the surface of scheme ``name`` (unchanged for ``"dp"`` and ``"tour"``) and,
    for ``"dp-star"``, its access (``star_access="noma"``)."""
    scheme = get_scheme(name)
    changes = {}
    if scheme.surface is not None and scheme.surface != config.surface:
        changes["surface"] = scheme.surface
    if scheme.access is not None and scheme.access != config.star_access:
        changes["star_access"] = scheme.access
    return config.replace(**changes) if changes else config


def run_scheme(name: str, config: ScenarioConfig, **kwargs: Any) -> Plan:
    """Run benchmark scheme ``name`` on ``config`` (its surface set by the scheme).

    Parameters
    ----------
    name : str
        One of :data:`SCHEMES` (``ia``, ``ra``, ``ia-ft``, ``cuc``, ``dp``, ``dp-ia``,
        ``dp-ra``, ``dp-cuc``, ``dp-sta``, ``dp-star``, ``tour``).
    config : ScenarioConfig
        The scenario; only its ``surface`` (and, for ``dp-star``, ``star_access``) is overridden
        by the scheme.
    **kwargs
        Passed to the planner: ``resolution``, ``margin``, ``progress`` (DP), ``hover``
        (ia-ft), whatever ``baselines.sca.solve`` takes (SCA).

    Returns
    -------
    Plan
        The planner's plan, with ``scheme`` set to ``name``.

    Raises
    ------
    ValueError
        Unknown scheme, or a config its planner does not handle
        (:class:`baselines.registry.PlannerMismatch`, naming the planners that do).
    ImportError
        An SCA scheme while ``baselines.sca`` (or cvxpy) is not available.
    """
    scheme = get_scheme(name)
    plan = _planner(scheme.planner)(scheme_config(name, config), **kwargs)
    return dataclasses.replace(plan, scheme=name)
