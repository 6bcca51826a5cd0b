"""A world: one choice of every component, checked as a whole, and the env that runs it.

``World(surface, link, objective, motion, knowledge, nodes)`` holds a component of each family
(given as objects, names or dicts with ``kind``) and the number K of ground nodes. It maps to
the two things an env is made from, ``config_fields()`` (``ScenarioConfig``) and
``option_fields()`` (``EnvOptions``), and back: ``World.of(config, options)`` is the world of an
env's scenario and options. :meth:`World.check` refuses a combination the simulator does not
run, naming the components and why; every env calls it at construction, so the refusal and
its message live here only. :func:`combinations` walks every combination of the registered
kinds (at their default parameters), the matrix the tests run through the env checker.
"""

from __future__ import annotations

import dataclasses
import itertools
import numbers
from collections.abc import Iterator
from typing import Any

from ios_uav_env.components.knowledge import KNOWLEDGE, Knowledge
from ios_uav_env.components.link import LINKS, Link
from ios_uav_env.components.motion import MOTIONS, Motion
from ios_uav_env.components.objective import OBJECTIVES, Objective
from ios_uav_env.components.surface import SURFACES, Surface, surface_of
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.miso_sdma import LATTICE_LEVELS

__all__ = ["FAMILIES", "UnsupportedWorld", "World", "combinations", "noma_runs", "sdma_runs"]

#: family name -> its registry, in the order of ``World``'s fields.
FAMILIES = {
    "surface": SURFACES,
    "link": LINKS,
    "objective": OBJECTIVES,
    "motion": MOTIONS,
    "knowledge": KNOWLEDGE,
}


class UnsupportedWorld(ValueError):
    """A combination of components the simulator does not run (the message says which and why)."""


@dataclasses.dataclass(frozen=True)
class World:
    """One component of each family and K ground ``nodes`` (module docstring). Defaults: the
    paper's world (an IOS, the single-antenna expected-gain link, the rate, static, exactly known
    nodes, one node)."""

    surface: Surface | str | dict = "ios"
    link: Link | str | dict = "single_antenna"
    objective: Objective | str | dict = "rate"
    motion: Motion | str | dict = "static"
    knowledge: Knowledge | str | dict = "exact"
    nodes: int = 1

    def __post_init__(self) -> None:
        for family, registry in FAMILIES.items():
            object.__setattr__(self, family, registry.make(getattr(self, family)))
        k = self.nodes
        if not (isinstance(k, numbers.Integral) and not isinstance(k, bool) and k >= 1):
            raise ValueError(f"nodes must be an integer >= 1 (K, the number of ground nodes), got {k!r}")
        object.__setattr__(self, "nodes", int(k))

    @classmethod
    def of(
        cls,
        config: ScenarioConfig,
        *,
        channel: str = "expected",
        knowledge: str = "exact",
        report_sigma: float | None = None,
        filter_estimate: bool = False,
    ) -> World:
        """The world of ``config`` and the env options given (``EnvOptions``' fields)."""
        motion: Any = "static" if config.motion is None else config.motion.to_dict()
        know: Any = {"kind": "filtered" if filter_estimate else knowledge}
        if knowledge == "reports" and report_sigma is not None:
            know["sigma"] = report_sigma
        return cls(
            surface=surface_of(config),
            link=_link_of(config.antennas, channel),
            objective={"kind": config.objective, "budget_j": config.energy_budget_j},
            motion=motion,
            knowledge=know,
            nodes=config.K,
        )

    def config_fields(self) -> dict[str, Any]:
        """The ``ScenarioConfig`` fields of the surface, the link (its antennas), the objective and
        the motion."""
        return {
            **self.surface.config_fields(),
            **self.link.config_fields(),
            **self.objective.config_fields(),
            **self.motion.config_fields(),
        }

    def option_fields(self) -> dict[str, Any]:
        """The ``EnvOptions`` fields of the link and the knowledge."""
        return {**self.link.option_fields(), **self.knowledge.option_fields()}

    def names(self) -> dict[str, str]:
        """family -> kind, and ``nodes``: the world in one line (for messages and tables)."""
        out: dict[str, Any] = {family: getattr(self, family).kind for family in FAMILIES}
        if self.link.kind == "multi_antenna":
            out["link"] += f" (antennas={self.link.antennas})"
        if self.link.fading != "expected":
            out["link"] += f" ({self.link.fading})"
        if getattr(self.surface, "access", "tdma") != "tdma":
            out["surface"] += f" ({self.surface.access})"
        if getattr(self.surface, "bits", None) is not None:
            out["surface"] += f" ({self.surface.bits}-bit phases)"
        if self.objective.budget_j is not None:
            out["objective"] += " within a budget"
        return {**out, "nodes": f"K = {self.nodes}"}

    def problems(self) -> list[str]:
        """Why the simulator does not run this world (empty when it does); see ``RULES``."""
        return [why for applies, why in RULES if applies(self)]

    def check(self) -> World:
        """``self`` if the simulator runs it, else ``UnsupportedWorld`` naming the components and why."""
        problems = self.problems()
        if problems:
            named = ", ".join(f"{family} {kind}" for family, kind in self.names().items())
            raise UnsupportedWorld(f"unsupported world ({named}): " + "; ".join(problems))
        return self


def noma_runs(world: World, nodes: tuple[int, ...] = (2,)) -> bool:
    """Whether an env runs ``world``'s NOMA STAR surface (``envs.star_noma``, the view
    ``"star_noma"``): two static, exactly known nodes (K in ``nodes``), the expected-gain link, the
    rate objective without a budget (the other envs refuse NOMA by their own check,
    ``settings.check_world``)."""
    return (
        world.nodes in nodes
        and world.motion.kind == "static"
        and world.knowledge.exact
        and world.link.fading == "expected"
        and world.objective.kind == "rate"
        and world.objective.budget_j is None
    )


def sdma_runs(world: World) -> bool:
    """Whether an env runs ``world``'s multi-antenna UAV serving several nodes at once
    (``envs.miso_sdma``, the view ``"miso_sdma"``): K in [2, 4] static, exactly known nodes (the
    SDMA scorer's weight lattices: ``model.miso_sdma.LATTICE_LEVELS``), an IOS, the expected-gain
    link, the rate objective without a budget (the other envs refuse it by their own check,
    ``settings.check_world``)."""
    return world.surface.kind == "ios" and noma_runs(world, tuple(LATTICE_LEVELS))


#: The combinations the simulator does not run: (applies to a world, why). Each names the
#: components involved and, where one exists, what to use instead.
RULES: tuple[tuple[Any, str], ...] = (
    (
        lambda w: w.surface.kind == "star" and w.surface.access == "noma" and not noma_runs(w),
        "surface star with access 'noma', the field star_access: it serves a node on each side in one slot, "
        "which the envs run for two static, exactly known nodes (one on each side of the surface plane) "
        "with fading 'expected' and the rate objective without a budget (ios_uav_env/STARUAV-NOMA-v0); "
        "score another NOMA flight with ios_uav_env.score_plan (ios_uav_env.model.star_regions.star_maxmin), "
        "or use access 'tdma' in an env",
    ),
    (
        lambda w: (
            w.surface.kind == "star"
            and w.surface.bits is not None
            and (w.link.fading != "expected" or not w.knowledge.exact)
        ),
        "surface star with b-bit phases (the field star_bits) and fading 'rician' or measured rates "
        "(knowledge reports, filtered or rates): a b-bit slot's rate is that of the node's exact b-bit "
        "phases on the LoS channel (model.star_slot's TDMA rate), with no faded sample modelled; use "
        "fading 'expected' (channel='expected') with knowledge exact, or continuous phases (star_bits=None)",
    ),
    (
        lambda w: w.link.fading != "expected" and not w.knowledge.exact,
        "link fading 'rician' with measured rates (knowledge reports, filtered or rates): a measured rate is "
        "the slot's own faded sample, so a second faded rate of the same slot would contradict it; use "
        "fading 'expected' with measured rates, or knowledge exact with fading 'rician'",
    ),
    (
        lambda w: w.link.kind == "multi_antenna" and (w.link.fading != "expected" or not w.knowledge.exact),
        "link multi_antenna with fading 'rician' or measured rates (knowledge reports, filtered or rates): "
        "the multi-antenna UAV's rate is the closed form of its aligned phases and MRT (model.miso), with "
        "no faded sample of a flight modelled; use fading 'expected' (channel='expected') with knowledge "
        "exact, or the single_antenna link for faded or measured rates; a multi-antenna UAV's Rician channel "
        "runs per slot in ios_uav_env/MISOControl-v0 (channel='rician', model.miso_fading)",
    ),
    (
        lambda w: w.link.kind == "multi_antenna" and w.surface.kind == "star" and w.surface.bits is not None,
        "link multi_antenna with surface star of b-bit phases (the field star_bits): the multi-antenna UAV's "
        "rate is the closed form of its aligned phases and MRT (model.miso), and b-bit phases are modelled "
        "for a single-antenna UAV; use the single_antenna link, or continuous phases (star_bits=None)",
    ),
    (
        lambda w: w.link.kind == "multi_antenna" and w.nodes > 1 and not sdma_runs(w),
        "link multi_antenna with several nodes: the multi-antenna UAV serves them at once (SDMA with the "
        "per-slot beams), which the envs run for K in [2, 4] static, exactly known nodes on an ios surface "
        "with fading 'expected' and the rate objective without a budget (ios_uav_env/MISOUAV-SDMA-v0, "
        "-K3-v0, -K4-v0); score "
        "another SDMA flight with ios_uav_env.score_plan (ios_uav_env.model.miso_sdma), or use one node "
        "(K = 1), or the single_antenna link for one node per slot share (TDMA)",
    ),
)


def _link_of(antennas: int, fading: str) -> dict[str, Any]:
    """The link of a scenario's ``antennas`` and the env's ``channel``: one antenna or several."""
    if antennas == 1:
        return {"kind": "single_antenna", "fading": fading}
    return {"kind": "multi_antenna", "antennas": antennas, "fading": fading}


def combinations(
    nodes: tuple[int, ...] = (1, 3), budgets: tuple[float | None, ...] = (None,)
) -> Iterator[World]:
    """Every world of the registered kinds (each kind's ``variants()``, e.g. a link per fading),
    for each K in ``nodes`` and each objective budget in ``budgets`` (supported or not:
    ``World.check`` tells)."""
    choices = [
        [v for kind in registry.names() for v in registry.get(kind).variants()]
        for registry in FAMILIES.values()
    ]
    for k, budget in itertools.product(nodes, budgets):
        for surface, link, objective, motion, knowledge in itertools.product(*choices):
            objective = dataclasses.replace(objective, budget_j=budget)
            yield World(
                surface=surface, link=link, objective=objective, motion=motion, knowledge=knowledge, nodes=k
            )
