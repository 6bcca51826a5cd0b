"""Suites of several UAVs (kind ``"multi-uav"``, ``multi-uav-v1``): each scenario's fleet, the one
scorer of its flights, and a policy's episodes in ``ios_uav_env.parallel_env``.

A scenario holds its ``ScenarioConfig`` (K static nodes, the rate objective) and its ``fleet``:
``parallel_env``'s arguments :data:`FLEET_FIELDS` (``uavs``, ``starts``, ``finals``, ``speeds``,
``access``, ``min_separation``, ``horizons``), checked at load by ``ios_uav_env.model.fleet.fleet_setup``, the
check the env and the planner share. A plan is U flights (U, N, 2) m:

- **Rate**: the team's max-min rate with the best time sharing in every slot,
  ``ios_uav_env.model.fleet.fleet_maxmin(config, flights, access=...)``: the one scorer of a
  fleet, whoever flew it (the planner's references were scored by it too);
- **Feasible**: every UAV's flight meets eq. (10) with its own start, final point and speed
  (``check_trajectory``) and every two UAVs keep ``min_separation`` at every way-point
  (``model.separation.flights_separated``). An infeasible plan scores 0.

A policy is scored by rolling it out in the parallel env made on the scenario with the suite's
``env_kwargs`` (``max_nodes``, so that every scenario's observations and actions have the same
node blocks) and ``best_schedule=False`` (the flights are scored once, here): either one policy
shared by every agent (a callable, an SB3 model: :func:`~ios_uav_env.benchmark.scoring.action_function`,
applied to each agent's own observation, as parameter-shared IPPO acts), or a team policy that
says ``team = True`` and maps the dict of the live agents' observations to a dict of their
actions. A policy with a ``bind`` method (one that reads features by name, as
:class:`~ios_uav_env.benchmark.fleet_policies.NearestWorstNode`) is bound to each scenario's
``observation_names`` first. An agent's observation has 2 (U - 1) columns for the other UAVs,
so its width depends on the scenario's U. A plan's time is its episode's wall time, after an
unscored warm-up episode. Rolling policies out needs the ``marl`` extra (PettingZoo); loading a
suite and scoring flights do not.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.fleet import fleet_maxmin, fleet_setup
from ios_uav_env.model.fleet_horizons import flights_feasibility, horizon_slots
from ios_uav_env.model.separation import flights_separated

__all__ = ["FLEET_FIELDS", "check_fleet", "fleet_configs", "score_flights"]

#: A several-UAV scenario's fleet: ``parallel_env``'s arguments that the scenario fixes.
FLEET_FIELDS = ("uavs", "starts", "finals", "speeds", "access", "min_separation", "horizons")


def check_fleet(config: ScenarioConfig, fleet: Any, where: str) -> dict[str, Any]:
    """``fleet`` as stored (plain lists and numbers), checked: exactly the keys
    :data:`FLEET_FIELDS`, valid for ``config`` (``fleet_setup``), with several UAVs
    (``ValueError`` naming ``where`` and the field otherwise)."""
    if not isinstance(fleet, Mapping):
        raise ValueError(f"{where}: fleet must be an object of {list(FLEET_FIELDS)}, got {fleet!r}")
    if set(fleet) != set(FLEET_FIELDS):
        raise ValueError(
            f"{where}: fleet must have exactly the fields {list(FLEET_FIELDS)}, got {sorted(map(str, fleet))}"
        )
    if config.motion is not None or config.objective != "rate":
        raise ValueError(
            f"{where}: a fleet serves static nodes with the rate objective (motion None, objective "
            f"'rate'), got motion={config.motion!r}, objective={config.objective!r}"
        )
    if isinstance(fleet["uavs"], bool) or not isinstance(fleet["uavs"], int) or fleet["uavs"] < 2:
        raise ValueError(f"{where}: fleet.uavs must be an integer >= 2 (a fleet), got {fleet['uavs']!r}")
    try:
        fleet_configs(config, fleet)
    except ValueError as err:
        raise ValueError(f"{where}: fleet: {err}") from None
    return {name: fleet[name] for name in FLEET_FIELDS}


def fleet_configs(config: ScenarioConfig, fleet: Mapping[str, Any]) -> list[ScenarioConfig]:
    """Each UAV's scenario (its start, final point and speed limit): ``fleet_setup``'s."""
    return fleet_setup(
        config,
        fleet["uavs"],
        fleet["starts"],
        fleet["finals"],
        fleet["min_separation"],
        fleet["access"],
        fleet["speeds"],
        fleet["horizons"],
    )[2]


def score_flights(
    config: ScenarioConfig, fleet: Mapping[str, Any], flights: Any
) -> tuple[float, bool, float]:
    """(the team's max-min rate in bps/Hz, feasible, the worst breach of eq. (10) in m) of U
    flights (U, N, 2) m on a scenario and its fleet (module docstring; a UAV whose horizon ends
    before T is held at its final point after it: ``model.fleet_horizons``): ``ValueError`` for
    another shape or a value that is not finite."""
    configs = fleet_configs(config, fleet)
    q = np.asarray(flights, dtype=np.float64)
    if q.shape != (len(configs), config.N, 2):
        raise ValueError(
            f"the flights must have shape (U, N, 2) = ({len(configs)}, {config.N}, 2) (one flight per UAV, "
            f"its start first and its final point last), got {q.shape}"
        )
    if not np.isfinite(q).all():
        raise ValueError("the flights have NaN or infinite values")
    slots = horizon_slots(configs)
    own, worst = flights_feasibility(configs, q)
    feasible = own and flights_separated(q, float(fleet["min_separation"]), slots)
    rate = float(fleet_maxmin(config, q, access=fleet["access"], slots=slots).value)
    return rate, bool(feasible), worst
