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
schedule of ``maxmin_rate`` (tested); each UAV added can only help (its band is its own).

**A shared band** (``access="shared"``): the UAVs transmit in the same band, so at node k the
other transmitting UAVs' signals are interference. With the expected gains g_{u,k}(l) = E|h|^2 of
the links under alignment l (:func:`link_gains`; the rate of a lone link is log2(1 + eta g)), UAV
u serving node k while the UAVs of the set T transmit gives it

    log2(1 + eta g_{u,k}(l) / (1 + eta sum_{v in T, v != u} g_{v,k}(l))),

interference treated as noise (a node does not decode the others' signals). A slot's choices
then also let a UAV stay silent (a_u = none), which a shared band can make worth it, and the
pricer enumerates them all, (K + 1)^U per alignment. Interference only lowers rates, so the
shared band's value is at most the orthogonal bands' (tested), which is the interference-free
relaxation a bound of the shared band may use.

**Horizons** (``horizons`` of :func:`fleet_setup`, ``slots`` of :func:`fleet_maxmin`): UAV u flies
only its slots 0 .. N_u - 1; in a slot it no longer flies it is no link and no alignment of the
enumeration (it serves nothing, takes no surface share, causes no interference), and the rates
are still averaged over the N slots. The (U, N, 2) arrays hold it at its final point after its
horizon, masked by N_u: ``model.fleet_horizons``.
"""

from __future__ import annotations

import itertools
import math
import numbers
from typing import Any

import numpy as np

from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.fleet_horizons import active_slots, check_horizons, check_slots
from ios_uav_env.model.fleet_links import cached_link_gains, link_gains, link_gains_batch, link_rates
from ios_uav_env.model.regions import Pricer, RegionSchedule, maxmin_regions
from ios_uav_env.model.separation import DEFAULT_SEPARATION, check_separated

__all__ = [
    "ACCESS", "LANE_OFFSET", "MAX_SHARED_CHOICES", "choice_rates", "default_lanes", "fleet_maxmin",
    "fleet_pricer", "fleet_setup", "link_gains", "link_gains_batch", "link_rates", "shared_slot_service",
    "slot_service",
]  # fmt: skip

#: How the UAVs share the spectrum: a band each, or one band (interference at the nodes).
ACCESS: tuple[str, ...] = ("orthogonal", "shared")

#: m, the offset in y between consecutive UAVs' default lanes (:func:`default_lanes`).
LANE_OFFSET = 80.0
#: Most choices a shared band's slot may have (U K alignments x (K + 1)^U node-or-silence
#: choices): the pricer stores them all per slot (:func:`choice_rates`).
MAX_SHARED_CHOICES = 200_000


def default_lanes(config: ScenarioConfig, uavs: int) -> tuple[np.ndarray, np.ndarray]:
    """(starts, finals), (U, 2) m each: UAV u flies the scenario's q0 -> qF moved
    :data:`LANE_OFFSET` x u m in -y (parallel lanes; the fleet env's and planner's default)."""
    shift = np.zeros((uavs, 2))
    shift[:, 1] = -LANE_OFFSET * np.arange(uavs)
    return np.asarray(config.q0, dtype=float) + shift, np.asarray(config.qF, dtype=float) + shift


def _number(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


def fleet_setup(
    config: ScenarioConfig,
    uavs: Any = 2,
    starts: Any = None,
    finals: Any = None,
    min_separation: Any = DEFAULT_SEPARATION,
    access: Any = "orthogonal",
    speeds: Any = None,
    horizons: Any = None,
) -> tuple[np.ndarray, np.ndarray, list[ScenarioConfig]]:
    """(starts, finals, each UAV's scenario): the fleet's arguments checked, ``ValueError`` naming
    the argument and its allowed values otherwise. ``uavs`` U >= 1; ``starts`` / ``finals`` (U, 2)
    m (default :func:`default_lanes`), every two at least ``min_separation`` m (>= 0) apart; each
    UAV's scenario is ``config`` with its start and final point, its speed limit ``speeds[u]``
    (m/s, > 0; default ``config.v_max`` for every UAV) and its horizon ``horizons[u]`` as its T
    (s, a multiple of dt within [2 dt, T]; default the scenario's T for every UAV;
    ``model.fleet_horizons``), the final point reachable by then; ``access`` one of
    :data:`ACCESS`, a shared band at most :data:`MAX_SHARED_CHOICES` choices. Each UAV's slot
    count N_u is its scenario's N (``fleet_horizons.horizon_slots``)."""
    if isinstance(uavs, bool) or not isinstance(uavs, numbers.Integral) or uavs < 1:
        raise ValueError(f"uavs must be an integer >= 1, got {uavs!r}")
    u_n = int(uavs)
    if not (_number(min_separation) and min_separation >= 0):
        raise ValueError(f"min_separation must be a finite number >= 0 (m), got {min_separation!r}")
    if access not in ACCESS:
        raise ValueError(f"access must be one of {ACCESS}, got {access!r}")
    choices = u_n * config.K * (config.K + 1) ** u_n
    if access == "shared" and u_n > 1 and choices > MAX_SHARED_CHOICES:
        raise ValueError(
            f"access='shared' with uavs={u_n} and K={config.K} nodes has {choices} choices per slot, more "
            f"than {MAX_SHARED_CHOICES} (the enumeration's limit): use fewer UAVs or nodes"
        )
    lanes = default_lanes(config, u_n)
    points = []
    for name, value, default in (("starts", starts, lanes[0]), ("finals", finals, lanes[1])):
        try:
            p = np.asarray(default if value is None else value, dtype=float)
        except (TypeError, ValueError):
            p = np.empty(0)
        if p.shape != (u_n, 2) or not np.all(np.isfinite(p)):
            raise ValueError(
                f"{name} must be a finite ({u_n}, 2) array of points in m, one per UAV, got {value!r}"
            )
        check_separated(p, float(min_separation), name)
        points.append(p)
    try:
        v = np.broadcast_to(np.asarray(config.v_max if speeds is None else speeds, dtype=float), (u_n,))
    except (TypeError, ValueError):
        v = np.array([np.nan])
    if v.shape != (u_n,) or not np.all(np.isfinite(v) & (v > 0)):
        raise ValueError(f"speeds must be None or {u_n} finite speeds > 0 (m/s, one per UAV), got {speeds!r}")
    slots = check_horizons(config, u_n, horizons)
    configs = []
    for u in range(u_n):
        (sx, sy), (fx, fy) = points[0][u], points[1][u]
        fields = {"q0": (float(sx), float(sy)), "qF": (float(fx), float(fy))}
        if speeds is not None:
            fields["v_max"] = float(v[u])
        try:
            configs.append(config.replace(**fields))
        except ValueError as err:
            raise ValueError(f"starts[{u}] / finals[{u}] / speeds: {err}") from None
        if slots[u] < config.N:  # its own horizon (the scenario's T itself otherwise)
            try:
                configs[u] = configs[u].replace(T=float(slots[u]) * config.dt)
            except ValueError as err:
                raise ValueError(f"horizons[{u}] = {slots[u] * config.dt:g} s: {err}") from None
    return points[0], points[1], configs


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


def _trajectories(trajectories: np.ndarray) -> np.ndarray:
    t = np.asarray(trajectories, dtype=float)
    if t.ndim != 3 or t.shape[2] != 2 or t.shape[0] < 1 or not np.all(np.isfinite(t)):
        raise ValueError(
            f"trajectories must be a finite (U, N, 2) array in m with U >= 1, got shape {t.shape}"
        )
    return t


def _check_access(access: str) -> None:
    if access not in ACCESS:
        raise ValueError(f"access must be one of {ACCESS}, got {access!r}")


def choice_rates(gains: np.ndarray, eta: float, access: str = "shared") -> np.ndarray:
    """(U K (K + 1)^U, K) bps/Hz: the nodes' rates of every choice of a slot, alignment l (row
    block l) times each UAV's node or silence (``itertools.product(range(-1, K), repeat=U)``, -1
    silent), from the slot's :func:`link_gains` ``gains``; ``access`` (:data:`ACCESS`) says whether
    the other transmitting UAVs interfere (module docstring)."""
    _check_access(access)
    g = np.asarray(gains, dtype=float)
    u_n, k_n = g.shape[2], g.shape[3]
    g = g.reshape(u_n * k_n, u_n, k_n)  # (alignment, u, k)
    choices = np.array(list(itertools.product(range(-1, k_n), repeat=u_n)), dtype=np.int64)
    active = (choices >= 0).astype(float)
    out = np.zeros((g.shape[0], len(choices), k_n))
    for u in range(u_n):
        rows = np.flatnonzero(choices[:, u] >= 0)
        node = choices[rows, u]
        signal = g[:, u, node]  # (alignment, choice)
        if access == "shared":  # the other active UAVs at the node this one serves
            heard = np.einsum("cv,lvc->lc", active[rows], g[:, :, node]) - signal
            out[:, rows, node] += np.log2(1.0 + eta * signal / (1.0 + eta * heard))
        else:
            out[:, rows, node] += np.log2(1.0 + eta * signal)
    return out.reshape(-1, k_n)


def _slot_arrays(table: np.ndarray, active: np.ndarray) -> np.ndarray:
    """A slot's (U, K, U, K) gains or rates restricted to its ``active`` UAVs (U,) bool: the links
    of the UAVs still flying under the alignments to them (the array itself when all are)."""
    if active.all():
        return table
    return table[active][:, :, active]


def _slot_groups(active: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The slots some UAV flies, grouped by which UAVs fly (``active`` (N, U) bool): [(their slot
    indices, the (U,) mask)], so each group is priced as one array (one group with equal horizons)."""
    groups: dict[bytes, list[int]] = {}
    for n, mask in enumerate(active):
        if mask.any():
            groups.setdefault(mask.tobytes(), []).append(n)
    return [(np.array(idx), active[idx[0]]) for idx in groups.values()]


def fleet_pricer(
    config: ScenarioConfig,
    trajectories: np.ndarray,
    access: str = "orthogonal",
    slots: Any = None,
    record: list[tuple[np.ndarray, np.ndarray]] | None = None,
) -> Pricer:
    """The exact weighted-sum pricer of the slots' regions for the U UAVs' ``trajectories``
    (U, N, 2) m (module docstring), for ``maxmin_regions(price, config.K)``: in orthogonal bands
    each UAV's best node under each alignment; in a shared band every choice enumerated
    (:func:`choice_rates`). ``slots``: each UAV's slot count N_u (default N each): UAV u takes part
    in slots 0 .. N_u - 1 only (``model.fleet_horizons``); a slot none flies serves nothing, and
    the rates are averaged over all N slots. ``record``: a list each call appends its choices to,
    (align (N,), nodes (N, U)): the surface's link u* K + k* (-1 in a slot no UAV flies) and each
    UAV's node (-1 silent or past its horizon) in every slot."""
    _check_access(access)
    t = _trajectories(trajectories)
    u_n, n_slots, k_n = t.shape[0], t.shape[1], config.K
    active = active_slots(check_slots(slots, u_n, n_slots), n_slots).T  # (N, U)
    gains = cached_link_gains(config, t.transpose(1, 0, 2))  # (N, U, K, U, K)
    groups = _slot_groups(active)
    uavs_of = [np.flatnonzero(mask) for _, mask in groups]  # each group's flying UAVs

    def keep(align: list[np.ndarray], nodes: list[np.ndarray]) -> None:
        """Record one call's choices, each group's in the fleet's own slot and UAV indices."""
        if record is None:
            return
        full_align, full_nodes = np.full(n_slots, -1, np.int64), np.full((n_slots, u_n), -1, np.int64)
        for (idx, _), flying, a, n in zip(groups, uavs_of, align, nodes, strict=True):
            full_align[idx] = flying[a // k_n] * k_n + a % k_n
            full_nodes[idx[:, None], flying] = n
        record.append((full_align, full_nodes))

    if access == "shared":
        tables = [
            np.array([choice_rates(_slot_arrays(gains[n], mask), config.eta, "shared") for n in idx])
            for idx, mask in groups
        ]  # per group, (slots, alignments x choices, K)
        choices = [
            np.array(list(itertools.product(range(-1, k_n), repeat=len(flying))), dtype=np.int64)
            for flying in uavs_of
        ]

        def price_enumerated(w: np.ndarray) -> tuple[np.ndarray, float]:
            point, total, align, nodes = np.zeros(k_n), 0.0, [], []
            for table, each in zip(tables, choices, strict=True):
                values = table @ w
                rows, best = np.arange(len(table)), np.argmax(values, axis=1)
                point += table[rows, best].sum(axis=0)
                total += float(values[rows, best].sum())
                align.append(best // len(each))
                nodes.append(each[best % len(each)])
            keep(align, nodes)
            return point / n_slots, total / n_slots

        return price_enumerated
    rates = np.log2(1.0 + config.eta * gains)  # (N, U*, K*, U, K): under alignment (u*, k*)
    flying_rates = [np.array([_slot_arrays(rates[n], mask) for n in idx]) for idx, mask in groups]

    def price(w: np.ndarray) -> tuple[np.ndarray, float]:
        point, total, align, served = np.zeros(k_n), 0.0, [], []
        for r in flying_rates:  # the slots of one set of flying UAVs, (slots, U*, K*, U, K) of those
            rows, uavs = np.arange(r.shape[0]), np.arange(r.shape[3])
            weighted = r * w
            values = weighted.max(axis=4).sum(axis=3).reshape(len(r), -1)  # each UAV its best node
            best = np.argmax(values, axis=1)
            us, ks = np.divmod(best, k_n)
            nodes = np.argmax(weighted[rows, us, ks], axis=2)  # (slots, U)
            np.add.at(point, nodes.ravel(), r[rows, us, ks][rows[:, None], uavs, nodes].ravel())
            total += float(values[rows, best].sum())
            align.append(best)
            served.append(nodes)
        keep(align, served)
        return point / n_slots, total / n_slots

    return price


def shared_slot_service(
    gains: np.ndarray, eta: float, shares: np.ndarray, surface_shares: np.ndarray
) -> np.ndarray:
    """(K,) bps/Hz: :func:`slot_service`'s schedule (UAV u serves node k a fraction ``shares[u, k]``,
    the surface serves UAV u a fraction ``surface_shares[u]``, independent) in a shared band: every
    UAV transmits all the slot, so each moment is the choice (alignment to the served node of the
    surface's UAV, each UAV's node) with the probability of the product of the shares, and node k
    gets its expected rate with the others' interference (:func:`choice_rates`)."""
    g = np.asarray(gains, dtype=float)
    alpha = np.asarray(shares, dtype=float)
    beta = np.asarray(surface_shares, dtype=float)
    u_n, k_n = alpha.shape
    out = np.zeros(k_n)
    for nodes in itertools.product(range(k_n), repeat=u_n):
        p = float(np.prod(alpha[np.arange(u_n), nodes]))
        if p == 0.0:
            continue
        for us in range(u_n):
            gl = g[us, nodes[us]]  # (U, K): every link under this alignment
            for u in range(u_n):
                k = nodes[u]
                heard = sum(gl[v, k] for v in range(u_n) if v != u)
                out[k] += p * beta[us] * np.log2(1.0 + eta * gl[u, k] / (1.0 + eta * heard))
    return out


def fleet_maxmin(
    config: ScenarioConfig,
    trajectories: np.ndarray,
    *,
    access: str = "orthogonal",
    tol: float = 1e-9,
    slots: Any = None,
) -> RegionSchedule:
    """The flight's max-min rate of ``config``'s K nodes served by U UAVs sharing the surface, in
    orthogonal bands or one shared band (``access``), with time sharing in every slot, and its bound
    (module docstring; the pricer is exact, so the two meet to ``tol``). ``slots``: each UAV's slot
    count N_u (its horizon; default every UAV all N slots): UAV u serves in its slots 0 .. N_u - 1
    only, its held way-points after are not read (``model.fleet_horizons``)."""
    return maxmin_regions(fleet_pricer(config, trajectories, access, slots), config.K, tol=tol)
