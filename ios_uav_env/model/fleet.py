r"""Several UAVs, one surface, K nodes, orthogonal bands: the flight's max-min rate, certified.

U UAVs fly their own trajectories q_u (N, 2) m over the same N slots (the scenario's dt and
altitude) and share one IOS. Each UAV transmits in a band of its own (no interference between
UAVs) and serves at most one node at a time (TDMA within a UAV, time sharing inside the slot).
The surface takes one configuration per slot and the closed-form phases (eq. (13)) can line it
up with one UAV-node link l = (u*, k*) only: every other link sees the same phases, misaligned
for it (``channel.phased_rates`` with those phases, as ``components.SingleAntennaLink.rates``:
at most its aligned rate, the direct path and a partial surface sum). Which link the surface
serves is part of the decision.

A slot's choices are then (l, a_1 .. a_U) with a_u the node UAV u serves, giving node k the rate
sum_{u: a_u = k} r_{u,k}(l), and with time sharing the slot's region is the hull of those points.
The flight's max-min over the nodes is the regions problem of ``ios_uav_env.model.regions``,
priced exactly by enumeration: for weights w, max over l of sum_u max_k w_k r_{u,k}(l) (U K
alignments, each with U K link rates per slot).

With U = 1 the surface best serves the link the UAV serves, so the value is the frame's max-min
schedule of ``maxmin_rate`` (tested); each UAV added can only help (its band is its own). A shared
band, where the UAVs interfere at the nodes, is not modelled here.
"""

from __future__ import annotations

import numpy as np

from ios_uav_env.model import channel
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.regions import Pricer, RegionSchedule, maxmin_regions

__all__ = ["LANE_OFFSET", "default_lanes", "fleet_maxmin", "fleet_pricer", "link_rates", "slot_service"]

#: m, the offset in y between consecutive UAVs' default lanes (:func:`default_lanes`).
LANE_OFFSET = 80.0


def default_lanes(config: ScenarioConfig, uavs: int) -> tuple[np.ndarray, np.ndarray]:
    """(starts, finals), (U, 2) m each: UAV u flies the scenario's q0 -> qF moved
    :data:`LANE_OFFSET` x u m in -y (parallel lanes; the fleet env's and planner's default)."""
    shift = np.zeros((uavs, 2))
    shift[:, 1] = -LANE_OFFSET * np.arange(uavs)
    return np.asarray(config.q0, dtype=float) + shift, np.asarray(config.qF, dtype=float) + shift


def link_rates(config: ScenarioConfig, positions: np.ndarray) -> np.ndarray:
    """(U, K, U, K) bps/Hz: r[u*, k*, u, k], node k's rate from UAV u at ``positions`` (U, 2) m when
    the surface's phases line up the link (u*, k*) (eq. (13) for node k* seen from UAV u*)."""
    q = channel.as_positions(positions, "positions")
    nodes = [config.node_config(k) for k in range(config.K)]
    u_n, k_n = len(q), config.K
    # every alignment's phases, row (u*, k*) = u* K + k*: node k*'s eq. (13) from each UAV u*
    aligned = np.stack([channel.phase_shifts(nodes[ks], q) for ks in range(k_n)], axis=1).reshape(
        u_n * k_n, -1
    )
    out = np.empty((u_n, k_n, u_n, k_n))
    for u in range(u_n):
        at_u = np.repeat(q[u : u + 1], u_n * k_n, axis=0)
        for k in range(k_n):  # link (u, k) under every alignment at once
            out[:, :, u, k] = channel.phased_rates(nodes[k], at_u, aligned).reshape(u_n, k_n)
    return out


def slot_service(rates: np.ndarray, shares: np.ndarray, surface_shares: np.ndarray) -> np.ndarray:
    """(K,) bps/Hz: each node's rate over one slot in which UAV u serves node k a fraction
    ``shares[u, k]`` of the slot (rows sum to 1) and the surface lines up with UAV u's link a
    fraction ``surface_shares[u]`` (sum 1), the two time shares independent: while the surface
    serves UAV u* it is aligned to the node u* serves at that moment. ``rates`` (U, K, U, K) as
    :func:`link_rates`. Node k gets

        sum_u shares[u, k] (beta_u r[u, k, u, k]
                            + sum_{u* != u} beta_{u*} sum_{k*} shares[u*, k*] r[u*, k*, u, k]),

    a time-shared mix of the slot's choices (alignment, one node per UAV), hence a point of the
    region :func:`fleet_pricer` prices (tested): the flight's rates from these shares are at most
    :func:`fleet_maxmin`'s. With U = 1: node k gets ``shares[0, k] r[0, k, 0, k]``."""
    r = np.asarray(rates, dtype=float)
    alpha = np.asarray(shares, dtype=float)
    beta = np.asarray(surface_shares, dtype=float)
    u_n = alpha.shape[0]
    # seen[a, u, k]: link (u, k)'s rate while the surface serves UAV a (aligned to a's node mix)
    seen = np.einsum("ab,abuk->auk", alpha, r)
    for u in range(u_n):
        seen[u, u] = r[u, np.arange(r.shape[1]), u, np.arange(r.shape[1])]
    effective = np.einsum("a,auk->uk", beta, seen)
    return (alpha * effective).sum(axis=0)


def fleet_pricer(config: ScenarioConfig, trajectories: np.ndarray) -> Pricer:
    """The exact weighted-sum pricer of the slots' regions for the U UAVs' ``trajectories``
    (U, N, 2) m (module docstring), for ``maxmin_regions(price, config.K)``."""
    t = np.asarray(trajectories, dtype=float)
    if t.ndim != 3 or t.shape[2] != 2 or t.shape[0] < 1 or not np.all(np.isfinite(t)):
        raise ValueError(
            f"trajectories must be a finite (U, N, 2) array in m with U >= 1, got shape {t.shape}"
        )
    rates = [link_rates(config, t[:, n]) for n in range(t.shape[1])]  # per slot (U, K, U, K)
    u_n, k_n = t.shape[0], config.K

    def price(w: np.ndarray) -> tuple[np.ndarray, float]:
        point, total = np.zeros(k_n), 0.0
        for r in rates:
            weighted = w[None, None, None, :] * r  # (u*, k*, u, k)
            per_uav = weighted.max(axis=3)  # each UAV's best node under each alignment
            values = per_uav.sum(axis=2).reshape(-1)
            best = int(np.argmax(values))
            us, ks = divmod(best, k_n)
            for u in range(u_n):
                k = int(np.argmax(weighted[us, ks, u]))
                point[k] += r[us, ks, u, k]
            total += float(values[best])
        return point / len(rates), total / len(rates)

    return price


def fleet_maxmin(config: ScenarioConfig, trajectories: np.ndarray, *, tol: float = 1e-9) -> RegionSchedule:
    """The flight's max-min rate of ``config``'s K nodes served by U UAVs in orthogonal bands
    sharing the surface, with time sharing in every slot, and its bound (module docstring; the
    pricer is exact, so the two meet to ``tol``)."""
    return maxmin_regions(fleet_pricer(config, trajectories), config.K, tol=tol)
