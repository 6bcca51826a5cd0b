"""The result type every planner returns."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ios_uav_env import ScenarioConfig, TrajectoryReport, score_plan
from ios_uav_env.io import atomic_write_text


@dataclass
class Plan:
    """A planned trajectory, scored by the one model (``ios_uav_env.score_plan``): its rate is
    ``ios_uav_env.maxmin_rate`` (its best TDMA schedule), which is ``ios_uav_env.average_rate``
    for one ground node; its energy and energy efficiency are the score's too."""

    scheme: str  # e.g. "ia", "ra", "ia-ft", "cuc", "dp"
    config: ScenarioConfig
    trajectory: np.ndarray  # (N, 2) m
    mean_rate: float  # bps/Hz, eq. (9) with the exact model (K > 1: the max-min rate min_k R_k)
    feasible: bool  # eq. (10) within FEASIBILITY_TOL (and the energy budget, if the config sets one)
    report: TrajectoryReport
    energy: float  # J, propulsion energy of the flight
    energy_efficiency: float  # bits/J, B T mean_rate / energy
    objective_value: float  # the score of config.objective: mean_rate or energy_efficiency
    seconds: float  # wall time of the planner
    history: list[dict[str, Any]] = field(default_factory=list)  # per-iteration records (SCA)
    info: dict[str, Any] = field(default_factory=dict)  # planner-specific extras

    @classmethod
    def from_trajectory(
        cls,
        scheme: str,
        config: ScenarioConfig,
        trajectory: np.ndarray,
        seconds: float,
        history: list[dict[str, Any]] | None = None,
        info: dict[str, Any] | None = None,
    ) -> Plan:
        """Score ``trajectory`` with the model and check it against eq. (10).

        For K > 1 nodes the score is the certified max-min rate and ``info`` gets the best
        schedule's ``shares`` (K x N, as lists) and per-node rates ``node_rates``."""
        q = np.asarray(trajectory, dtype=float)
        scored = score_plan(config, q)  # the one scorer: its best schedule
        info = dict(info or {})
        if scored.best is not None:
            info.update(shares=scored.best.shares.tolist(), node_rates=scored.best.node_rates.tolist())
        return cls(
            scheme=scheme,
            config=config,
            trajectory=q,
            mean_rate=scored.rate,
            feasible=scored.feasible,
            report=scored.report,
            energy=scored.energy,
            energy_efficiency=scored.energy_efficiency,
            objective_value=scored.objective_value,
            seconds=float(seconds),
            history=list(history or []),
            info=info,
        )

    def scored_on(self, config: ScenarioConfig, scheme: str | None = None) -> Plan:
        """This plan's trajectory scored on another ``config`` (same geometry, e.g. another
        objective or budget): the explicit way to report a plan made for one problem under another
        (``baselines.registry``). ``scheme`` defaults to this plan's; ``seconds`` and ``info`` are
        kept, the schedule entries of ``info`` rescored."""
        info = {k: v for k, v in self.info.items() if k not in ("shares", "node_rates")}
        name = self.scheme if scheme is None else scheme
        return Plan.from_trajectory(name, config, self.trajectory, self.seconds, self.history, info)

    def to_dict(self) -> dict[str, Any]:
        return {
            "scheme": self.scheme,
            "config": self.config.to_dict(),
            "mean_rate": self.mean_rate,
            "feasible": self.feasible,
            "energy": self.energy,
            "energy_efficiency": self.energy_efficiency,
            "objective_value": self.objective_value,
            "report": self.report.to_dict(),
            "seconds": self.seconds,
            "trajectory": self.trajectory.tolist(),
            "history": self.history,
            "info": self.info,
        }

    def save_json(self, path: str | Path) -> Path:
        """Write the plan as JSON atomically (temp file + rename)."""
        return atomic_write_text(path, json.dumps(self.to_dict(), indent=1, default=float))
