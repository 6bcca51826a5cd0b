"""The fleet's rules on one fleet's arrays: what the parallel env and its batched form both apply.

A fleet is U rows of the multi-node env (one per UAV: its move, node shares, propulsion and
observation); these functions couple them, for one fleet at a time, the same code whether the
rows are single envs (``envs.fleet.FleetParallelEnv``) or rows of batched ones
(``envs.fleet_vector.FleetVectorEnv``): the surface's shares between the UAVs, the slot's service
of the nodes, each agent's observation and what a fleet refuses; the guarded moves (unit disk, arrival guard,
separation) are the model's flight rule, ``model.separation.guarded_moves``, re-exported here.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.fleet import cached_link_gains, link_gains_batch, shared_slot_service, slot_service
from ios_uav_env.model.separation import GUARD_MARGIN, guard_distance, guarded_moves  # noqa: F401

__all__ = [
    "GUARD_MARGIN", "agent_observations", "check_team_world", "guard_distance", "guarded_moves", "slots_of",
    "surface_shares",
]  # fmt: skip


def check_team_world(config: ScenarioConfig, kwargs: Mapping[str, Any]) -> None:
    """Refuse, naming the field, what several UAVs do not model yet (``config`` the fleet's
    scenario, ``kwargs`` the UAV rows' keywords)."""
    if config.motion is not None:
        raise ValueError("config.motion: several UAVs serve static nodes (motion=None); one UAV: uavs=1")
    if config.objective != "rate":
        raise ValueError(
            f"config.objective={config.objective!r}: several UAVs have the rate objective (max-min); "
            "one UAV: uavs=1"
        )
    if kwargs.get("random_nodes") is not None:
        raise ValueError("random_nodes: several UAVs fly one scenario (its K nodes); one UAV: uavs=1")
    refused = {"channel": "expected", "knowledge": "exact", "softmin_beta": 0.0, "peak_hint": False}
    for name, allowed in refused.items():
        if name in kwargs and kwargs[name] != allowed:
            raise ValueError(
                f"{name}={kwargs[name]!r}: several UAVs take {name}={allowed!r} (one UAV: uavs=1)"
            )
    if "arrival_guard" in kwargs and not kwargs["arrival_guard"]:
        raise ValueError("arrival_guard=False: several UAVs always fly the arrival and separation guards")


def surface_shares(bids: np.ndarray, sharpness: float) -> np.ndarray:
    """(U,): the surface's shares of the slot, the softmax of ``sharpness`` x the bids clipped to
    [-1, 1]."""
    scaled = np.clip(np.asarray(bids, dtype=float), -1.0, 1.0) * sharpness
    beta = np.exp(scaled - scaled.max())
    return beta / beta.sum()


def slots_of(
    config: ScenarioConfig,
    access: str,
    q: np.ndarray,
    shares: np.ndarray,
    beta: np.ndarray,
    cache: bool = False,
) -> np.ndarray:
    """(B, K) bps/Hz: the nodes' rates of the slot of B fleets at their way-points ``q`` (B, U, 2)
    m, with their node shares (B, U, K) and surface shares ``beta`` (B, U): the links' gains of all
    fleets at once (``model.fleet.link_gains_batch``), then ``model.fleet.slot_service`` (or in a
    shared band ``shared_slot_service``) per fleet. The arrays are taken C-contiguous, so that a
    fleet's rates do not depend on how the caller sliced them (numpy's sums may round differently
    on strided views). ``cache``: the gains through the model's per-slot cache
    (``model.fleet.cached_link_gains``, the same values bit for bit), so that scoring the flights
    afterwards (``fleet_maxmin``, which reads that cache) computes none of them again."""
    q, shares, beta = (np.ascontiguousarray(x, dtype=float) for x in (q, shares, beta))
    gains = _batch_layout(cached_link_gains(config, q)) if cache else link_gains_batch(config, q)
    if access == "shared":
        return np.array(
            [shared_slot_service(g, config.eta, a, c) for g, a, c in zip(gains, shares, beta, strict=True)]
        )
    rates = np.log2(1.0 + config.eta * gains)
    return np.array([slot_service(r, a, c) for r, a, c in zip(rates, shares, beta, strict=True)])


def _batch_layout(gains: np.ndarray) -> np.ndarray:
    """``gains`` (B, U, K, U, K) C-contiguous, as ``model.fleet.cached_link_gains`` returns them,
    laid out in memory as ``link_gains_batch`` returns its own (a transposed view of its (B, U K,
    U K) product): the same values, so that the slot's rates and sums round as they do for fleets
    computed by the batch (numpy's elementwise results keep their input's layout, and its sums
    round by the memory order)."""
    b_n, u_n, k_n = gains.shape[:3]
    square = gains.reshape(b_n, u_n * k_n, u_n * k_n)
    return square.transpose(0, 2, 1).copy().transpose(0, 2, 1).reshape(gains.shape)


def agent_observations(
    obs: np.ndarray, node_rates: np.ndarray, q: np.ndarray, served_at: list[int], scale: float
) -> np.ndarray:
    """(U, d + 2 (U - 1)) float32: each UAV's row observation ``obs`` (U, d) with its node blocks'
    ``served`` (columns ``served_at``) the team's ``node_rates`` (K_max,), then the other UAVs'
    positions relative to it, (q_v - q_u) / ``scale``, in agent order."""
    u_n = len(q)
    out = np.empty((u_n, obs.shape[1] + 2 * (u_n - 1)))
    for u in range(u_n):
        o = obs[u].astype(np.float64)
        o[served_at] = node_rates
        others = [(q[v] - q[u]) / scale for v in range(u_n) if v != u]
        out[u] = np.concatenate([o, *others])
    return out.astype(np.float32)
