"""Objective components: what an episode's score is (``ios_uav_env.model.score.score_plan``).

``rate``: the average rate of eq. (9), which for K > 1 nodes is the max-min rate min_k R_k
(each node's average over TDMA shares); ``energy_efficiency``: B T R / E (bits/J), R that same
rate and E the flight's propulsion energy. Either can hold an energy budget ``budget_j`` (J): a
plan using more is infeasible ("the rate within an energy budget" is ``rate`` with a budget).
The config fields are ``objective`` and ``energy_budget_j``.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

from ios_uav_env.components.base import Component, Registry, finite_number

__all__ = ["OBJECTIVES", "EnergyEfficiency", "Objective", "Rate"]


@dataclasses.dataclass(frozen=True)
class Objective(Component):
    """An objective with an optional energy budget ``budget_j`` (J, > 0; None: no budget)."""

    family: ClassVar[str] = "objective"
    #: ``True`` when the flight's energy enters the score itself (not only the budget).
    counts_energy: ClassVar[bool] = False
    budget_j: float | None = None

    def __post_init__(self) -> None:
        if self.budget_j is not None:  # (None: no budget)
            budget = finite_number(self.budget_j, "objective.budget_j", positive=True, unit="J; or None")
            object.__setattr__(self, "budget_j", budget)

    def config_fields(self) -> dict[str, Any]:
        """The ``ScenarioConfig`` fields this objective sets."""
        return {"objective": self.kind, "energy_budget_j": self.budget_j}

    @property
    def uses_energy(self) -> bool:
        """Whether the flight's energy matters at all (in the score or against the budget)."""
        return self.counts_energy or self.budget_j is not None


#: The objective registry (names: ``ScenarioConfig.objective``'s values).
OBJECTIVES: Registry[Objective] = Registry("objective")


@OBJECTIVES.register("rate")
@dataclasses.dataclass(frozen=True)
class Rate(Objective):
    """The average rate (bps/Hz), max-min over nodes when K > 1."""

    kind: ClassVar[str] = "rate"


@OBJECTIVES.register("energy_efficiency")
@dataclasses.dataclass(frozen=True)
class EnergyEfficiency(Objective):
    """The energy efficiency B T R / E (bits/J)."""

    kind: ClassVar[str] = "energy_efficiency"
    counts_energy: ClassVar[bool] = True
