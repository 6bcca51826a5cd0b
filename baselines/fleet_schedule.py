"""Several UAVs: the exact max-min schedule of given flights, with every slot's choices kept.

``ios_uav_env.model.fleet.fleet_maxmin`` prices the slots' regions and returns the flight's value
and rates; block-coordinate SCA (``baselines.fleet_sca``) also needs the schedule itself: which
link the surface lines up with and which node each UAV serves in every slot of every column the
LP mixes. :func:`fleet_schedule` prices the same choices (``link_gains_batch``, ``choice_rates``),
vectorised over the slots, and records them; its value is ``fleet_maxmin``'s to rounding (tested).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from ios_uav_env import ScenarioConfig
from ios_uav_env.model.fleet import choice_rates, link_gains_batch
from ios_uav_env.model.regions import maxmin_regions

__all__ = ["FleetSchedule", "fleet_schedule"]


@dataclass
class FleetSchedule:
    """Block 1: the exact schedule of U flights. ``value``, ``rates`` (K,) and ``dual`` (K,) as
    ``maxmin_regions``'; ``mix`` (J,) the columns' shares; ``align`` (J, N) the surface's link
    u* K + k* and ``nodes`` (J, N, U) each UAV's node (-1 silent) in every slot of every column;
    ``gains`` (N, U, K, U, K) the slots' ``link_gains``."""

    value: float
    rates: np.ndarray
    dual: np.ndarray
    mix: np.ndarray
    align: np.ndarray
    nodes: np.ndarray
    gains: np.ndarray


def fleet_schedule(
    config: ScenarioConfig, trajectories: np.ndarray, access: str = "orthogonal"
) -> FleetSchedule:
    """The exact max-min schedule of the flights ``trajectories`` (U, N, 2) m (``fleet_pricer``'s
    pricing, each slot's choice recorded; its value is ``fleet_maxmin``'s to rounding, tested)."""
    t = np.asarray(trajectories, dtype=float)
    u_n, k_n = t.shape[0], config.K
    gains = link_gains_batch(config, t.transpose(1, 0, 2))  # (N, U, K, U, K)
    n_n, slots = gains.shape[0], np.arange(gains.shape[0])
    recorded: list[tuple[np.ndarray, np.ndarray]] = []
    if access == "shared":
        table = np.array([choice_rates(g, config.eta, "shared") for g in gains])  # (N, L C, K)
        choices = np.array(list(itertools.product(range(-1, k_n), repeat=u_n)), dtype=np.int64)

        def price(w: np.ndarray) -> tuple[np.ndarray, float]:
            values = table @ w
            best = np.argmax(values, axis=1)
            recorded.append((best // len(choices), choices[best % len(choices)]))
            return table[slots, best].sum(axis=0) / n_n, float(values[slots, best].sum() / n_n)

    else:
        rates = np.log2(1.0 + config.eta * gains)

        def price(w: np.ndarray) -> tuple[np.ndarray, float]:
            weighted = rates * w
            values = weighted.max(axis=4).sum(axis=3).reshape(n_n, -1)
            best = np.argmax(values, axis=1)
            us, ks = np.divmod(best, k_n)
            node = np.argmax(weighted[slots, us, ks], axis=2)  # (N, U)
            recorded.append((best, node))
            got = rates[slots[:, None], us[:, None], ks[:, None], np.arange(u_n), node]
            point = np.bincount(node.ravel(), got.ravel(), minlength=k_n)
            return point / n_n, float(values[slots, best].sum() / n_n)

    result = maxmin_regions(price, k_n, tol=1e-9)
    j = len(result.mix)
    return FleetSchedule(
        result.value, result.rates, np.asarray(result.dual_weights, dtype=float), result.mix,
        np.array([a for a, _ in recorded[:j]]), np.array([b for _, b in recorded[:j]]), gains,
    )  # fmt: skip
