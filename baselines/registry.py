"""One registry of the planners and bounds: what each one optimises, and for which scenarios.

Every planner of ``baselines`` declares here the problems it solves: the objectives it
optimises (``ScenarioConfig.objective``), whether it honours an energy budget
(``energy_budget_j``), the node counts K it takes, and what it does with moving nodes
(``ScenarioConfig.motion``). Its ``solve`` calls :func:`check` first, so a planner never
optimises another problem than the config's without saying so: a config it does not handle is
refused with a :class:`PlannerMismatch` (a ``ValueError``) that names the field and the
registered planners that do handle it.

========================  ===================  ======  =====  ==========  =========
name                      objectives           budget  K      motion      kind
========================  ===================  ======  =====  ==========  =========
``dp``                    rate                 no      >= 1   static      optimum
``dp-ee``                 energy_efficiency    no      1      static      optimum
``dp-ee-multi``           energy_efficiency    no      >= 2   static      optimum
``dp-budget``             rate                 yes     1      static      optimum
``dp-clairvoyant``        rate                 no      >= 1   paths       optimum
``sca``                   rate                 no      >= 1   static      local
``sca-multi``             rate                 no      >= 2   paths       local
``sca-ee``                energy_efficiency    no      1      static      local
``tour``                  rate                 no      >= 1   paths       heuristic
``fixed``                 any (scored)         yes     >= 1   static      heuristic
``loiter``, ``hover``     any (scored)         yes     >= 1   static      heuristic
``mpc``                   rate                 no      >= 1   online      online
``dp-star``               rate                 no      2      static      optimum
``ao-star``               rate                 no      2      static      local
``dp-miso``               rate                 no      1      static      optimum
``dp-miso-sdma``          rate                 no      2..4   static      optimum
``ao-miso-sdma``          rate                 no      2..4   static      local
``dp-bound``              rate                 no      >= 1   paths       bound
``energy-bound``          energy_efficiency    no      1      static      bound
========================  ===================  ======  =====  ==========  =========

Motion: ``static`` refuses moving nodes; ``paths`` plans (or bounds) on the nodes' true paths
given in advance as ``paths=`` (the clairvoyant problem) and refuses a moving config without
them; ``online`` plans from the position reports as the flight goes (``baselines.mpc``).
A heuristic optimises nothing: it flies a fixed rule, and its plan is scored by the one scorer
on the config as it is (objective and budget included), so it takes any objective; it still
refuses moving nodes, whose score it would not see.

Access: a STAR surface serving both sides' nodes at once (``ScenarioConfig(surface="star",
star_access="noma")``) is scored by ``score_plan`` (``star_regions.scenario_maxmin``). ``dp-star``
plans it and ``ao-star`` polishes dp-star's plan off the grid (they and only they: ``accesses`` =
("noma",)); every other planner and bound above optimises the one-node-per-slot-share (TDMA)
schedule and refuses it, naming ``dp-star`` and ``ao-star``; the heuristics,
which optimise nothing, fly it and are scored on it.

Phase bits: a STAR surface of b-bit phases (``ScenarioConfig(surface="star", star_bits=b)``, TDMA)
has the slot rate of the node's exact b-bit phases (``channel.slot_rates``), again a function of the
UAV's position: ``dp`` plans it on those rate maps (``bits`` true) and ``dp-bound`` bounds it
(the relaxation of the aligned phases' amplitude, which no b-bit setting exceeds: its bound holds,
looser than for continuous phases); the heuristics (the tour among them, whose hover points and
schedule read the same rates) fly it and are scored on it; every other planner plans continuous
phases and refuses it, naming ``dp``.

Antennas: a multi-antenna UAV (``ScenarioConfig(antennas=N_t)``, N_t > 1) has the closed-form
rate of its aligned phases and MRT (``channel.slot_rates``). ``dp-miso`` plans it (one node, any
N_t, ``antennas`` true); the heuristics fly it and are scored on it; every other planner and bound
plans the single-antenna UAV and refuses it, naming ``dp-miso``. Serving K in [2, 4] nodes at once
(SDMA: N_t >= 2, ``score_plan`` by ``model.miso_sdma``), ``dp-miso-sdma`` plans it and
``ao-miso-sdma`` polishes its plan off the grid (``min_antennas`` 2: they refuse one antenna, whose
nodes are served one per slot share).

A caller that plans one problem and scores the plan on another on purpose (the rate DP's plan
under the energy objective, say) says so: it plans on ``config.replace(objective="rate")`` and
scores with :meth:`baselines.plan.Plan.scored_on`.

>>> from ios_uav_env import ScenarioConfig
>>> [p.name for p in handlers(ScenarioConfig(objective="energy_efficiency")) if p.kind == "optimum"]
['dp-ee']
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ios_uav_env import OBJECTIVES, ScenarioConfig
from ios_uav_env.model.config import STAR_ACCESS

#: What a planner does with moving nodes (module docstring).
MOTIONS: tuple[str, ...] = ("static", "paths", "online")
#: What a registered entry is.
KINDS: tuple[str, ...] = ("optimum", "local", "heuristic", "online", "bound")


class PlannerMismatch(ValueError):
    """A planner asked to solve a problem it does not handle (the message names what does)."""


@dataclass(frozen=True)
class PlannerSpec:
    """A registered planner or bound: where it lives and which problems it solves."""

    name: str  # registry name, e.g. "dp"
    entry: str  # "module:function" of its solve(config, **kwargs)
    objectives: tuple[str, ...]  # the ScenarioConfig.objective values it optimises (or scores, a heuristic)
    budget: bool  # honours energy_budget_j (its plans are optimised or scored within the budget)
    k_min: int  # fewest ground nodes K
    k_max: int | None  # most ground nodes (None: any)
    motion: str  # one of MOTIONS
    kind: str  # one of KINDS
    description: str
    # the STAR access schemes it plans or scores (``ScenarioConfig.star_access``; every other surface's
    # is "tdma", one node per slot share)
    accesses: tuple[str, ...] = ("tdma",)
    # plans (or, a heuristic, flies and is scored on) a multi-antenna UAV (``ScenarioConfig.antennas``
    # > 1: the closed-form rate of the aligned phases and MRT); every planner takes one antenna
    antennas: bool = False
    # plans (or, a heuristic, flies and is scored on) a STAR surface of b-bit phases (``ScenarioConfig.
    # star_bits``: the node's exact b-bit phases per slot); every other planner takes continuous ones
    bits: bool = False
    # the fewest antennas it plans (2: a multi-antenna UAV serving its nodes at once, SDMA)
    min_antennas: int = 1

    def __post_init__(self) -> None:
        if bad := [o for o in self.objectives if o not in OBJECTIVES]:
            raise ValueError(f"{self.name}: objectives must be among {OBJECTIVES}, got {bad}")
        if self.motion not in MOTIONS:
            raise ValueError(f"{self.name}: motion must be one of {MOTIONS}, got {self.motion!r}")
        if self.kind not in KINDS:
            raise ValueError(f"{self.name}: kind must be one of {KINDS}, got {self.kind!r}")
        if not self.accesses or (bad := [a for a in self.accesses if a not in STAR_ACCESS]):
            raise ValueError(f"{self.name}: accesses must be among {STAR_ACCESS}, got {list(self.accesses)}")
        if ":" not in self.entry:
            raise ValueError(f"{self.name}: entry must be 'module:function', got {self.entry!r}")

    def problem(self, config: ScenarioConfig, paths: Any = None) -> str | None:
        """Why this planner does not handle ``config`` (with ``paths`` given or not), or None."""
        if config.objective not in self.objectives:
            return f"objective={config.objective!r} (it optimises {' or '.join(map(repr, self.objectives))})"
        if config.energy_budget_j is not None and not self.budget:
            return f"energy_budget_j={config.energy_budget_j:g} J (it ignores an energy budget)"
        if config.energy_budget_j is None and self.name == "dp-budget":
            return "energy_budget_j=None (it maximises the rate within a budget: set one)"
        if config.K < self.k_min or (self.k_max is not None and config.K > self.k_max):
            allowed = (
                f"K >= {self.k_min}" if self.k_max is None
                else f"K = {self.k_min}" if self.k_max == self.k_min
                else f"{self.k_min} <= K <= {self.k_max}"
            )  # fmt: skip
            return f"{config.K} ground node(s) (it takes {allowed})"
        if config.motion is not None:
            if self.motion == "static":
                return "motion (moving nodes; it plans for static nodes)"
            if self.motion == "paths" and paths is None:
                return "motion without paths= (it plans on the nodes' true paths given in advance)"
        if config.antennas > 1 and not self.antennas:
            return (
                f"antennas={config.antennas} (it plans the single-antenna UAV; a multi-antenna UAV's rate is "
                "the closed form of its aligned phases and MRT)"
            )
        if config.star_bits is not None and not self.bits:
            return (
                f"star_bits={config.star_bits} (it plans a surface of continuous phases; a b-bit surface's "
                "slot rate is that of the node's exact b-bit phases, channel.slot_rates)"
            )
        if config.antennas < self.min_antennas:
            return (
                f"antennas={config.antennas} (it plans a UAV of >= {self.min_antennas} antennas serving its "
                "nodes at once, SDMA)"
            )
        if config.star_access not in self.accesses:
            if config.star_access == "noma":
                return (
                    "star_access='noma' (it optimises the one-node-per-slot-share schedule, TDMA; "
                    "score_plan scores a NOMA flight)"
                )
            return (
                f"surface={config.surface!r} with star_access={config.star_access!r} (it plans a STAR "
                "surface serving both sides' users at once: surface='star', star_access='noma')"
            )
        return None

    def load(self) -> Callable[..., Any]:
        """The entry point (imported on demand: ``ImportError`` if e.g. cvxpy is missing)."""
        module, function = self.entry.split(":")
        return getattr(importlib.import_module(module), function)


_ANY = OBJECTIVES
_BOTH = STAR_ACCESS
PLANNERS: dict[str, PlannerSpec] = {
    p.name: p
    for p in (
        PlannerSpec("dp", "baselines.dp:solve", ("rate",), False, 1, None, "static", "optimum",
                    "global optimum on a grid (K > 1: best DP plan and certified max-min bound)", bits=True),
        PlannerSpec("dp-ee", "baselines.dp_energy:solve_ee", ("energy_efficiency",), False, 1, 1, "static",
                    "optimum", "best energy efficiency on the DP grid (Dinkelbach)"),
        PlannerSpec("dp-ee-multi", "baselines.dp_energy_multi:solve", ("energy_efficiency",), False, 2, None,
                    "static", "optimum", "best energy efficiency found on the DP grid (Dinkelbach on the "
                    "schedule's dual) and a certified bound, K >= 2"),
        PlannerSpec("dp-budget", "baselines.dp_energy:solve_budget", ("rate",), True, 1, 1, "static",
                    "optimum", "best average rate within the energy budget on the DP grid (Lagrangian)"),
        PlannerSpec("dp-clairvoyant", "baselines.dp_moving:solve", ("rate",), False, 1, None, "paths",
                    "optimum", "grid optimum on given node paths (K > 1: best DP plan and max-min bound)"),
        PlannerSpec("sca", "baselines.sca:solve", ("rate",), False, 1, None, "static", "local",
                    "the paper's SCA, multi-start (K > 1: block-coordinate descent)"),
        PlannerSpec("sca-multi", "baselines.sca_multi:solve", ("rate",), False, 2, None, "paths", "local",
                    "block-coordinate SCA over trajectory and TDMA shares, on given node paths"),
        PlannerSpec("sca-ee", "baselines.sca_energy:solve", ("energy_efficiency",), False, 1, 1, "static",
                    "local", "SCA with the propulsion term inside Dinkelbach"),
        PlannerSpec("tour", "baselines.tour:solve", ("rate",), False, 1, None, "paths", "heuristic",
                    "tour over hover points with an LP schedule, on given node paths", bits=True),
        PlannerSpec("fixed", "baselines.fixed:fly_hover_fly", _ANY, True, 1, None, "static", "heuristic",
                    "fly-hover-fly over the first node (scored on the config)", accesses=_BOTH,
                    antennas=True, bits=True),
        PlannerSpec("loiter", "baselines.loiter:loiter", _ANY, True, 1, None, "static", "heuristic",
                    "fly to the rate peak at V_mr, circle it at V_mp, back to qF (scored on the config)",
                    accesses=_BOTH, antennas=True, bits=True),
        PlannerSpec("hover", "baselines.loiter:hover", _ANY, True, 1, None, "static", "heuristic",
                    "fly to the rate peak at v_max and hover there (scored on the config)", accesses=_BOTH,
                    antennas=True, bits=True),
        PlannerSpec("mpc", "baselines.mpc:run_online", ("rate",), False, 1, None, "online", "online",
                    "MPC (the tour or the receding-horizon DP) on the Kalman filter's predicted paths"),
        PlannerSpec("dp-star", "baselines.dp_star:solve", ("rate",), False, 2, 2, "static", "optimum",
                    "STAR surface serving both sides' users at once (NOMA): best DP plan over the user "
                    "weights and a certified max-min bound", accesses=("noma",)),
        PlannerSpec("ao-star", "baselines.ao_star:solve", ("rate",), False, 2, 2, "static", "local",
                    "dp-star's plan polished by alternating optimisation: the max-min dual weights and a "
                    "trust-region SCA step on a continuous trajectory (NOMA)", accesses=("noma",)),
        PlannerSpec("dp-miso", "baselines.dp:solve_miso", ("rate",), False, 1, 1, "static", "optimum",
                    "global optimum on a grid of the multi-antenna UAV's closed-form rate (aligned phases "
                    "and MRT, any N_t)", antennas=True),
        PlannerSpec("dp-miso-sdma", "baselines.dp_miso_sdma:solve", ("rate",), False, 2, 4, "static",
                    "optimum", "multi-antenna UAV serving K users at once (SDMA): best DP plan over the "
                    "user weights on the per-slot AO settings and a certified max-min bound", antennas=True,
                    min_antennas=2),
        PlannerSpec("ao-miso-sdma", "baselines.ao_miso_sdma:solve", ("rate",), False, 2, 4, "static",
                    "local", "dp-miso-sdma's plan polished by alternating optimisation: the max-min dual "
                    "weights and a trust-region SCA step on a continuous trajectory (SDMA)", antennas=True,
                    min_antennas=2),
        PlannerSpec("dp-bound", "baselines.dp_bound:clairvoyant_bound", ("rate",), False, 1, None, "paths",
                    "bound", "certified upper bound of the rate (max-min for K > 1), given node paths",
                    bits=True),
        PlannerSpec("energy-bound", "baselines.energy_bound:solve", ("energy_efficiency",), False, 1, 1,
                    "static", "bound", "certified upper bound of the energy efficiency"),
    )
}  # fmt: skip


def get(name: str) -> PlannerSpec:
    """The planner registered as ``name``; ``ValueError`` listing the names otherwise."""
    try:
        return PLANNERS[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown planner {name!r}; registered planners: {', '.join(PLANNERS)}") from None


def handlers(config: ScenarioConfig, paths: Any = None) -> list[PlannerSpec]:
    """The registered planners and bounds that handle ``config`` (with ``paths`` given or not)."""
    return [p for p in PLANNERS.values() if p.problem(config, paths) is None]


def check(name: str, config: ScenarioConfig, paths: Any = None) -> PlannerSpec:
    """Refuse ``config`` unless planner ``name`` handles it (:class:`PlannerMismatch` naming the
    field and the planners of the same kind, or any kind, that handle it); return its spec."""
    if not isinstance(config, ScenarioConfig):
        raise TypeError(f"config must be a ScenarioConfig, got {type(config).__name__}")
    spec = get(name)
    why = spec.problem(config, paths)
    if why is None:
        return spec
    fits = handlers(config, paths)
    if config.motion is not None and paths is None:  # those that would, given the true paths
        fits += [p for p in handlers(config, paths=True) if p not in fits]
    others = [p for p in fits if p is not spec]
    same = [p for p in others if p.kind == spec.kind] or others
    noma = config.star_access == "noma" and "noma" not in spec.accesses  # the NOMA planners: dp-star, ao-star
    bits = config.star_bits is not None and not spec.bits  # the b-bit planner: dp
    if noma or bits:  # name the planners that plan it, not only the heuristics of the same kind
        same = [p for p in others if p.kind != "heuristic"] or others
    names = ", ".join(f"{p.name} ({p.entry})" for p in same)
    hint = f"; use {names}" if names else "; no registered planner handles it"
    if spec in fits:  # it would, given the nodes' true paths
        hint = "; pass paths= (the nodes' true paths: the clairvoyant problem)" + (
            f", or use {names}" if names else ""
        )
    raise PlannerMismatch(f"planner {name!r} does not handle this config: {why}{hint}")


def solve(name: str, config: ScenarioConfig, **kwargs: Any) -> Any:
    """Run registered planner ``name`` on ``config`` (checked first); ``kwargs`` go to it."""
    spec = check(name, config, kwargs.get("paths"))
    return spec.load()(config, **kwargs)
