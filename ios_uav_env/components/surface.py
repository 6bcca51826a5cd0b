"""Surface components: what stands between the UAV and the ground nodes.

``ios`` (the paper's intelligent omni-surface: it reflects to the UAV's side and transmits
through to the other, the transmitted power scaled by ``epsilon``), ``ris`` (a reflect-only
surface: a node across it gets the direct link only) and ``none`` (the direct link alone). The
physics is ``ios_uav_env.model.channel`` on ``ScenarioConfig.surface``; a surface component
says which sides it serves and which controls it takes. Today's surfaces take one control, their
closed-form phases (eq. (13), ``channel.phase_shifts``): a link given ``phases=None`` applies it,
and any (K, M) phase array is accepted by the link's per-element model.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

from ios_uav_env.components.base import Component, Registry

__all__ = ["SURFACES", "IOSSurface", "NoSurface", "RISSurface", "Surface"]


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
