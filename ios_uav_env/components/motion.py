"""Motion components: how the ground nodes move during an episode.

``static`` (the paper: every node at its configured position) and ``gauss_markov``
(``ios_uav_env.model.mobility.GaussMarkov``, the Gauss-Markov walk; its parameters are that
model's, validated there). The config field is ``motion`` (None for static).
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

from ios_uav_env.components.base import Component, Registry
from ios_uav_env.model.mobility import GaussMarkov as _GaussMarkovModel

__all__ = ["MOTIONS", "GaussMarkovMotion", "Motion", "StaticMotion"]


@dataclasses.dataclass(frozen=True)
class Motion(Component):
    """A motion model of the ground nodes."""

    family: ClassVar[str] = "motion"
    moves: ClassVar[bool] = False

    def config_fields(self) -> dict[str, Any]:
        """The ``ScenarioConfig`` fields this motion sets."""
        return {"motion": None}


#: The motion registry.
MOTIONS: Registry[Motion] = Registry("motion")


@MOTIONS.register("static")
@dataclasses.dataclass(frozen=True)
class StaticMotion(Motion):
    """Every node stays at its configured position (``motion=None``)."""

    kind: ClassVar[str] = "static"


@MOTIONS.register("gauss_markov")
@dataclasses.dataclass(frozen=True)
class GaussMarkovMotion(_GaussMarkovModel, Motion):
    """The Gauss-Markov walk of ``model.mobility.GaussMarkov`` (same fields, same validation)."""

    kind: ClassVar[str] = "gauss_markov"
    moves: ClassVar[bool] = True

    def config_fields(self) -> dict[str, Any]:
        fields = {f.name: getattr(self, f.name) for f in dataclasses.fields(_GaussMarkovModel)}
        return {"motion": _GaussMarkovModel(**fields)}

    def to_dict(self) -> dict[str, Any]:
        return _GaussMarkovModel.to_dict(self)
