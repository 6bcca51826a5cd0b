"""Several UAVs: the exact max-min schedule of given flights, with every slot's choices kept.

``ios_uav_env.model.fleet.fleet_maxmin`` prices the slots' regions and returns the flight's value
and rates; block-coordinate SCA (``baselines.fleet_sca``) also needs the schedule itself: which
link the surface lines up with and which node each UAV serves in every slot of every column the
LP mixes. :func:`fleet_schedule` runs ``fleet_maxmin``'s own pricer (``model.fleet.fleet_pricer``)
with its choices recorded (``record=``), so its value is ``fleet_maxmin``'s.

**Horizons** (``slots``, each UAV's slot count N_u; ``model.fleet_horizons``): a UAV past its
horizon is no choice of the slot, as in ``fleet_maxmin(..., slots=)``: the surface is never lined
up with its links, it serves nothing (its recorded node is -1) and, in a shared band, it is
silent (no interference). A slot no UAV flies serves nothing and records the alignment -1. With
every UAV flying all N slots (the default) the choices and the arithmetic are the plain ones.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ios_uav_env import ScenarioConfig
from ios_uav_env.model.fleet import fleet_pricer
from ios_uav_env.model.fleet_links import cached_link_gains
from ios_uav_env.model.regions import maxmin_regions

__all__ = ["FleetSchedule", "fleet_schedule"]


@dataclass
class FleetSchedule:
    """Block 1: the exact schedule of U flights. ``value``, ``rates`` (K,) and ``dual`` (K,) as
    ``maxmin_regions``'; ``mix`` (J,) the columns' shares; ``align`` (J, N) the surface's link
    u* K + k* (-1 in a slot no UAV flies) and ``nodes`` (J, N, U) each UAV's node (-1 silent or
    past its horizon) in every slot of every column; ``gains`` (N, U, K, U, K) the slots'
    ``link_gains``."""

    value: float
    rates: np.ndarray
    dual: np.ndarray
    mix: np.ndarray
    align: np.ndarray
    nodes: np.ndarray
    gains: np.ndarray


def fleet_schedule(
    config: ScenarioConfig, trajectories: np.ndarray, access: str = "orthogonal", slots: Any = None
) -> FleetSchedule:
    """The exact max-min schedule of the flights ``trajectories`` (U, N, 2) m: ``fleet_maxmin``'s,
    from the same pricer (``fleet_pricer(..., record=)``), with each column's choices kept.
    ``slots``: each UAV's slot count N_u (default N each; module docstring)."""
    t = np.asarray(trajectories, dtype=float)
    recorded: list[tuple[np.ndarray, np.ndarray]] = []
    result = maxmin_regions(fleet_pricer(config, t, access, slots, record=recorded), config.K, tol=1e-9)
    j = len(result.mix)  # the columns are the first j calls' choices (the last call may add none)
    align = np.array([a for a, _ in recorded[:j]])
    nodes = np.array([n for _, n in recorded[:j]])
    gains = cached_link_gains(config, t.transpose(1, 0, 2))  # (the pricer's, from the cache)
    dual = np.asarray(result.dual_weights, dtype=float)
    return FleetSchedule(result.value, result.rates, dual, result.mix, align, nodes, gains)
