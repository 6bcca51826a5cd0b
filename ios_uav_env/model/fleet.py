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

from functools import lru_cache

import numpy as np

from ios_uav_env.model import channel
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.regions import Pricer, RegionSchedule, maxmin_regions
from ios_uav_env.model.surface import element_positions, element_to_ground

__all__ = ["LANE_OFFSET", "default_lanes", "fleet_maxmin", "fleet_pricer", "link_rates", "slot_service"]

#: m, the offset in y between consecutive UAVs' default lanes (:func:`default_lanes`).
LANE_OFFSET = 80.0


def default_lanes(config: ScenarioConfig, uavs: int) -> tuple[np.ndarray, np.ndarray]:
    """(starts, finals), (U, 2) m each: UAV u flies the scenario's q0 -> qF moved
    :data:`LANE_OFFSET` x u m in -y (parallel lanes; the fleet env's and planner's default)."""
    shift = np.zeros((uavs, 2))
    shift[:, 1] = -LANE_OFFSET * np.arange(uavs)
    return np.asarray(config.q0, dtype=float) + shift, np.asarray(config.qF, dtype=float) + shift


@lru_cache(maxsize=32)
def _node_geometry(config: ScenarioConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(elements (M, 3), d_mG (K, M), the departure cosines cubed (K, M), e^{-j 2 pi d_mG / lambda}
    (K, M)) of ``config``'s surface and nodes (the per-element model's, ``channel``)."""
    w = element_positions(config)
    per_node = [element_to_ground(config.node_config(k)) for k in range(config.K)]
    d_mg = np.array([d for d, _ in per_node])
    cos3 = np.array([c for _, c in per_node]) ** 3
    return w, d_mg, cos3, np.exp(-1j * (2 * np.pi / config.wavelength) * d_mg)


def link_rates(config: ScenarioConfig, positions: np.ndarray) -> np.ndarray:
    """(U, K, U, K) bps/Hz: r[u*, k*, u, k], node k's rate from UAV u at ``positions`` (U, 2) m when
    the surface's phases line up the link (u*, k*) (eq. (13) for node k* seen from UAV u*).

    The per-element model of ``channel.phased_rates``, factorised: with the element phases
    E_m^u = e^{-j 2 pi d_Um^u / lambda} and F_m^k = e^{-j 2 pi d_mG^k / lambda}, the surface term of
    link (u, k) under alignment l = (u*, k*) is e^{-j 2 pi d_UG^l / lambda} sum_m a_m^{uk} E_m^u F_m^k
    conj(E_m^{u*} F_m^{k*}), so every link under every alignment is one complex matrix product
    (U K x M by M x U K). Equal to ``phased_rates`` with ``phase_shifts`` of the aligned link to
    about 1e-11 relative (the phases, ~2 pi d / lambda ~ 1e5 rad, round differently; tested)."""
    q = channel.as_positions(positions, "positions")
    u_n, k_n = len(q), config.K
    w, d_mg, cos3, f = _node_geometry(config)
    wave = 2 * np.pi / config.wavelength
    d_um = np.sqrt(
        (q[:, 0:1] - w[:, 0]) ** 2 + (q[:, 1:2] - w[:, 1]) ** 2 + (config.uav_altitude - w[:, 2]) ** 2
    )
    k_a = np.abs((q[:, 0:1] - w[:, 0]) / d_um) ** 3  # (U, M)
    nodes = [config.node_config(k) for k in range(k_n)]
    side = np.array([channel.side_factor(nodes[k], q[:, 0]) for k in range(k_n)]).T  # (U, K)
    amp = config.J * k_a[:, None, :] * (side[:, :, None] * cos3[None]) / (d_um[:, None, :] * d_mg[None])
    phase = np.exp(-1j * wave * d_um)[:, None, :] * f[None]  # (U, K, M): E^u F^k
    sums = (amp * phase).reshape(u_n * k_n, -1) @ phase.reshape(u_n * k_n, -1).conj().T  # [(u, k), l]
    d_ug = np.array([[np.sqrt(((q[u] - nodes[k].ground_node) ** 2).sum() + config.uav_altitude**2)
                      for k in range(k_n)] for u in range(u_n)]).reshape(-1)  # fmt: skip
    a_d = np.array(
        [channel.direct_amplitude(nodes[k], q[u : u + 1])[0] for u in range(u_n) for k in range(k_n)]
    )
    los = sums + (a_d[:, None] * np.exp(-1j * wave * (d_ug[:, None] - d_ug[None, :])))
    kappa = config.kappa
    total = amp.sum(axis=2).reshape(-1) + a_d  # sum_m a_m + a_D of each link
    gain = kappa / (1 + kappa) * np.abs(los) ** 2 + (total**2 / (1 + kappa))[:, None]
    rates = np.log2(1.0 + config.eta * gain)  # [(u, k), (u*, k*)]
    return rates.T.reshape(u_n, k_n, u_n, k_n)


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
