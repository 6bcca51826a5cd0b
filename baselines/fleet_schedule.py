"""Several UAVs: the exact max-min schedule of given flights, with every slot's choices kept.

``ios_uav_env.model.fleet.fleet_maxmin`` prices the slots' regions and returns the flight's value
and rates; block-coordinate SCA (``baselines.fleet_sca``) also needs the schedule itself: which
link the surface lines up with and which node each UAV serves in every slot of every column the
LP mixes. :func:`fleet_schedule` prices the same choices (``link_gains_batch``, ``choice_rates``),
vectorised over the slots, and records them; its value is ``fleet_maxmin``'s to rounding (tested).

**Horizons** (``slots``, each UAV's slot count N_u; ``model.fleet_horizons``): a UAV past its
horizon is no choice of the slot, as in ``fleet_maxmin(..., slots=)``: the surface is never lined
up with its links, it serves nothing (its recorded node is -1) and, in a shared band, it is
silent (no interference). A slot no UAV flies serves nothing and records the alignment -1. With
every UAV flying all N slots (the default) the choices and the arithmetic are the plain ones.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np

from ios_uav_env import ScenarioConfig
from ios_uav_env.model.fleet import choice_rates, link_gains_batch
from ios_uav_env.model.fleet_horizons import active_slots, check_slots
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
    """The exact max-min schedule of the flights ``trajectories`` (U, N, 2) m (``fleet_pricer``'s
    pricing, each slot's choice recorded; its value is ``fleet_maxmin``'s to rounding, tested).
    ``slots``: each UAV's slot count N_u (default N each; module docstring)."""
    t = np.asarray(trajectories, dtype=float)
    u_n, k_n = t.shape[0], config.K
    gains = link_gains_batch(config, t.transpose(1, 0, 2))  # (N, U, K, U, K)
    n_n = gains.shape[0]
    flying = active_slots(check_slots(slots, u_n, n_n), n_n).T  # (N, U)
    live = np.flatnonzero(flying.any(axis=1))  # the slots some UAV flies (all of them by default)
    every = bool(flying.all())
    g, fly, rows = gains[live], flying[live], np.arange(len(live))
    recorded: list[tuple[np.ndarray, np.ndarray]] = []
    if access == "shared":
        table = np.array([choice_rates(s, config.eta, "shared") for s in g])  # (slots, L C, K)
        choices = np.array(list(itertools.product(range(-1, k_n), repeat=u_n)), dtype=np.int64)
        # a choice is the slot's if the surface serves a UAV flying it and the others are silent
        allowed = None
        if not every:
            gone = (choices[None, :, :] >= 0) & ~fly[:, None, :]  # (slots, C, U)
            allowed = np.repeat(fly, k_n, axis=1)[:, :, None] & ~gone.any(axis=2)[:, None, :]
            allowed = allowed.reshape(len(live), -1)

        def price(w: np.ndarray) -> tuple[np.ndarray, float]:
            values = table @ w
            if allowed is not None:
                values = np.where(allowed, values, -np.inf)
            best = np.argmax(values, axis=1)
            recorded.append((best // len(choices), choices[best % len(choices)]))
            return table[rows, best].sum(axis=0) / n_n, float(values[rows, best].sum() / n_n)

    else:
        rates = np.log2(1.0 + config.eta * g)
        uavs = np.arange(u_n)

        def price(w: np.ndarray) -> tuple[np.ndarray, float]:
            weighted = rates * w
            each = weighted.max(axis=4)  # (slots, U*, K*, U): each UAV's best node
            if not every:  # a UAV past its horizon serves nothing and is no alignment
                each = np.where(fly[:, None, None, :], each, 0.0)
            values = each.sum(axis=3).reshape(len(live), -1)
            if not every:
                values = np.where(np.repeat(fly, k_n, axis=1), values, -np.inf)
            best = np.argmax(values, axis=1)
            us, ks = np.divmod(best, k_n)
            node = np.argmax(weighted[rows, us, ks], axis=2)  # (slots, U)
            got = rates[rows[:, None], us[:, None], ks[:, None], uavs, node]
            if not every:
                node, got = np.where(fly, node, -1), np.where(fly, got, 0.0)
            recorded.append((best, node))
            point = np.bincount(node[fly], got[fly], minlength=k_n)  # the flying UAVs' service
            return point / n_n, float(values[rows, best].sum() / n_n)

    result = maxmin_regions(price, k_n, tol=1e-9)
    j = len(result.mix)
    align = np.full((j, n_n), -1, dtype=np.int64)
    nodes = np.full((j, n_n, u_n), -1, dtype=np.int64)
    for i, (a, b) in enumerate(recorded[:j]):
        align[i, live], nodes[i, live] = a, b
    dual = np.asarray(result.dual_weights, dtype=float)
    return FleetSchedule(result.value, result.rates, dual, result.mix, align, nodes, gains)
