"""Knowledge components: what the UAV is told of the ground nodes each slot.

``exact`` (their true positions), ``reports`` (a noisy position report, error std ``sigma`` m
per component, and the measured rate), ``filtered`` (the same reports through the Kalman filter
of ``ios_uav_env.model.kalman``: the node features are its estimate) and ``rates`` (the measured
rate only). The env options are ``knowledge``, ``report_sigma`` and ``filter_estimate``.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

from ios_uav_env.components.base import Component, Registry, finite_number
from ios_uav_env.model.reports import REPORT_SIGMA

__all__ = ["KNOWLEDGE", "Exact", "Filtered", "Knowledge", "MeasuredRates", "Reports"]


@dataclasses.dataclass(frozen=True)
class Knowledge(Component):
    """What the UAV knows of the nodes (``exact``: everything)."""

    family: ClassVar[str] = "knowledge"
    #: the env option ``knowledge``
    option: ClassVar[str] = "exact"

    def option_fields(self) -> dict[str, Any]:
        """The env options this knowledge sets."""
        return {"knowledge": self.option}

    @property
    def exact(self) -> bool:
        return self.option == "exact"


#: The knowledge registry.
KNOWLEDGE: Registry[Knowledge] = Registry("knowledge")


@KNOWLEDGE.register("exact")
@dataclasses.dataclass(frozen=True)
class Exact(Knowledge):
    """The nodes' true positions."""

    kind: ClassVar[str] = "exact"


@KNOWLEDGE.register("reports")
@dataclasses.dataclass(frozen=True)
class Reports(Knowledge):
    """Noisy position reports (std ``sigma`` m per component) and measured rates."""

    kind: ClassVar[str] = "reports"
    option: ClassVar[str] = "reports"
    sigma: float = REPORT_SIGMA

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "sigma", finite_number(self.sigma, "knowledge.sigma", positive=False, unit="m")
        )

    def option_fields(self) -> dict[str, Any]:
        out: dict[str, Any] = {"knowledge": "reports"}
        if self.sigma != REPORT_SIGMA:
            out["report_sigma"] = self.sigma
        return out


@KNOWLEDGE.register("filtered")
@dataclasses.dataclass(frozen=True)
class Filtered(Reports):
    """The reports of :class:`Reports` through the Kalman filter (its estimate is observed)."""

    kind: ClassVar[str] = "filtered"

    def option_fields(self) -> dict[str, Any]:
        return {**super().option_fields(), "filter_estimate": True}


@KNOWLEDGE.register("rates")
@dataclasses.dataclass(frozen=True)
class MeasuredRates(Knowledge):
    """The measured rate only (no position)."""

    kind: ClassVar[str] = "rates"
    option: ClassVar[str] = "rates"
