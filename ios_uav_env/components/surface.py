"""Surface components: what stands between the UAV and the ground nodes.

``ios`` (the paper's intelligent omni-surface: it reflects to the UAV's side and transmits
through to the other, the transmitted power scaled by ``epsilon``), ``ris`` (a reflect-only
surface: a node across it gets the direct link only), ``none`` (the direct link alone) and
``star`` (a STAR surface: reflects and transmits, each element's split between the sides and its
phases set for the node served; ``docs/model.md``, "STAR surfaces"). The physics is
``ios_uav_env.model.channel`` on ``ScenarioConfig.surface``; a surface component says which
sides it serves and which controls it takes. The surfaces take one control, their closed-form
phases (eq. (13), ``channel.phase_shifts``; a STAR surface of b-bit phases, the node's exact
b-bit ones, ``channel.zeta``): a link given ``phases=None`` applies it, and any
(K, M) phase array is accepted by the link's per-element model.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

from ios_uav_env.components.base import Component, Registry
from ios_uav_env.model.config import STAR_FIELDS, ScenarioConfig, check_star

__all__ = ["SURFACES", "IOSSurface", "NoSurface", "RISSurface", "STARSurface", "Surface", "surface_of"]


@dataclasses.dataclass(frozen=True)
class Surface(Component):
    """A surface; ``reflects`` / ``transmits``: whether it serves a node on the UAV's side of its
    plane / on the other side."""

    family: ClassVar[str] = "surface"
    reflects: ClassVar[bool] = False
    transmits: ClassVar[bool] = False

    def config_fields(self) -> dict[str, Any]:
        """The ``ScenarioConfig`` fields this surface sets."""
        return {"surface": self.kind}


#: The surface registry (names: ``ScenarioConfig.surface``'s values).
SURFACES: Registry[Surface] = Registry("surface")


@SURFACES.register("ios")
@dataclasses.dataclass(frozen=True)
class IOSSurface(Surface):
    """The intelligent omni-surface: reflects and transmits (``epsilon`` scales the transmission)."""

    kind: ClassVar[str] = "ios"
    reflects: ClassVar[bool] = True
    transmits: ClassVar[bool] = True


@SURFACES.register("ris")
@dataclasses.dataclass(frozen=True)
class RISSurface(Surface):
    """A reflect-only surface (RIS): a node across the plane has the direct link only."""

    kind: ClassVar[str] = "ris"
    reflects: ClassVar[bool] = True


@SURFACES.register("none")
@dataclasses.dataclass(frozen=True)
class NoSurface(Surface):
    """No surface: the direct UAV-node link only."""

    kind: ClassVar[str] = "none"


@SURFACES.register("star")
@dataclasses.dataclass(frozen=True)
class STARSurface(Surface):
    """A STAR surface: reflects and transmits, with the choices of
    ``ios_uav_env.model.star.StarSurface`` (``protocol``, ``phases``, ``bits``) and the ``access``
    scheme, the ``ScenarioConfig`` fields ``star_*``. Under TDMA the node served gets the whole
    surface on its side (``ScenarioConfig.transmit_factor``: 1) at its aligned phases, or with
    ``bits`` = b at its exact b-bit phases (``channel.zeta``); under NOMA both sides' nodes are
    served at once (continuous phases), which ``score_plan`` scores (``star_regions.star_maxmin``)
    and ``STARUAV-NOMA-v0`` runs."""

    kind: ClassVar[str] = "star"
    reflects: ClassVar[bool] = True
    transmits: ClassVar[bool] = True

    protocol: str = "es"
    phases: str = "independent"
    bits: int | None = None
    access: str = "tdma"

    def __post_init__(self) -> None:
        check_star(self.protocol, self.phases, self.bits, self.access, prefix="surface.")

    @classmethod
    def variants(cls) -> tuple[Surface, ...]:
        """Each access scheme: TDMA (the envs run it) and NOMA (``score_plan`` scores it), and TDMA
        with 2-bit phases (the envs run it, but not with faded or measured rates)."""
        return (cls(), cls(access="noma"), cls(bits=2))

    def config_fields(self) -> dict[str, Any]:
        """``surface="star"`` and the ``star_*`` fields."""
        return {
            "surface": self.kind,
            **{name: getattr(self, name.removeprefix("star_")) for name in STAR_FIELDS},
        }


def surface_of(config: ScenarioConfig) -> Surface:
    """The surface component of ``config`` (with a STAR surface's ``star_*`` fields)."""
    if config.surface != "star":
        return SURFACES.make(config.surface)
    return STARSurface(**{name.removeprefix("star_"): getattr(config, name) for name in STAR_FIELDS})
