r"""A multi-antenna UAV serving K users at once over a flight (SDMA): the scorer's slot regions.

The UAV (``config.antennas`` = N_t > 1, the array of ``array.scenario_array``) serves the
scenario's K > 1 ground nodes in every slot with K beams of total power P and one surface setting
(``ios_uav_env.model.miso``). Its flight's max-min with time sharing inside each slot is the
regions problem of ``ios_uav_env.model.regions``; this module fixes the slot's region the scorer
credits, so that the scorer, the envs that set the beams and the planners share it exactly.

**The slot's settings.** For a weight vector w on the *weight lattice* (:func:`weight_lattice`:
the points of the simplex whose coordinates are multiples of 1 / L, L = :data:`LATTICE_LEVELS`
of K) the slot's setting at w is the better, in w . R, of

- the per-slot AO of the weighted sum rate at w (``miso_slot.optimise_slot(channel, "sum",
  random_starts=0, weights=w, max_iter=MAX_ITER)``: weighted WMMSE beams and closed-form phase
  updates from each user's aligned phases with MRT, and with ZF when N_t >= K), and
- each user served alone at full power with its aligned phases and MRT (``miso.tdma_rates``),

and the slot's credited region is the convex hull (time sharing) of the rate vectors of these J
settings (:func:`slot_points`, with the K users alone among them). Every setting is feasible, so
every credited rate vector is reachable; the users alone make TDMA's region a part of it, so an
SDMA flight is never scored below the same flight's TDMA schedule of ``miso.tdma_rates``.

**The score** (:func:`sdma_maxmin`): V = max min_k R_k over R = (1/N) sum_n R[n], R[n] in the
slot's credited region, solved exactly by ``regions.maxmin_regions`` (its pricer is exact over
the finite settings: per slot the largest w . R of its settings). ``ios_uav_env.score_plan`` scores
an SDMA scenario with it.

**The certified bound.** The true region (every beam set and surface setting) is larger: for any
w, min_k R_k <= w . R <= (1/N) sum_n ``miso.weighted_sum_bound``(G_n, w) with G_n the users'
single-user gains (interference-free, each user's best surface). :func:`sdma_maxmin` returns the
least of it over the lattice and the score's dual weights: above every flight's value on these
slots, whatever the beams. It is loose by the interference it ignores; its gap is reported.

**Sizes.** Each slot costs J AO runs; J = 9 for K = 2 (w_0 = 0, 1/8, ..., 1), 15 for K = 3 and 10
for K = 4, and the surface is capped at :data:`MAX_ELEMENTS` elements (the AO's element sweeps):
the paper's 6000-element surface is out of reach of a per-slot AO in a scorer.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ios_uav_env.model.array import scenario_array
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.miso import SlotChannel, slot_bounds, slot_channels, tdma_rates, weighted_sum_bound
from ios_uav_env.model.miso_runs import weighted_settings
from ios_uav_env.model.regions import Pricer, RegionSchedule, maxmin_regions

__all__ = [
    "LATTICE_LEVELS",
    "MAX_ELEMENTS",
    "MAX_ITER",
    "SdmaScore",
    "check_sdma_scenario",
    "lattice_index",
    "sdma_maxmin",
    "sdma_pricer",
    "slot_channel_at",
    "slot_points",
    "slot_setting",
    "weight_lattice",
]

#: L of the weight lattice per number of users K (the simplex's points with coordinates k / L).
LATTICE_LEVELS: dict[int, int] = {2: 8, 3: 4, 4: 2}
#: The largest surface (M elements) the SDMA scorer takes: each slot runs J per-slot AOs.
MAX_ELEMENTS = 256
#: AO iterations per start of a slot's setting (``miso_slot.optimise_slot``'s ``max_iter``): the
#: AO's own stopping rule (a relative gain below 1e-7) takes ~35 on these slots; 10 keep the
#: straight line's score of the SDMA ids' scenario within 0.1 % of 50's at a third of the cost.
MAX_ITER = 10


def check_sdma_scenario(config: ScenarioConfig, field: str = "config") -> None:
    """``ValueError`` naming ``field`` unless ``config`` is a scenario this module scores: N_t > 1
    antennas, K in [2, 4] static ground nodes, an IOS surface of at most :data:`MAX_ELEMENTS`."""
    if config.antennas < 2:
        raise ValueError(f"{field}: antennas must be an integer >= 2 for SDMA, got {config.antennas}")
    if config.K not in LATTICE_LEVELS:
        raise ValueError(
            f"{field}: ground_nodes must be K in [2, {max(LATTICE_LEVELS)}] nodes for SDMA scoring "
            f"(model.miso_sdma), got K = {config.K}"
        )
    if config.M > MAX_ELEMENTS:
        raise ValueError(
            f"{field}: ios_shape must have M = M_y M_z in [1, {MAX_ELEMENTS}] elements for SDMA scoring "
            f"(a per-slot AO per lattice weight; model.miso_sdma), got M = {config.M}"
        )
    if config.surface != "ios":
        raise ValueError(f"{field}: surface must be 'ios' for SDMA scoring, got {config.surface!r}")
    if config.motion is not None:
        raise ValueError(f"{field}: motion must be None (SDMA is scored for static nodes)")


def weight_lattice(k: int, levels: int | None = None) -> np.ndarray:
    """The lattice weights (J, K): every w >= 0 with sum 1 whose coordinates are multiples of
    1 / ``levels`` (default :data:`LATTICE_LEVELS` of K), in lexicographic order of the counts,
    user 0's weight falling (K = 2: w_0 = 1, 7/8, ..., 0)."""
    if not (isinstance(k, (int, np.integer)) and not isinstance(k, bool) and k >= 2):
        raise ValueError(f"k must be an integer >= 2 (users), got {k!r}")
    big = LATTICE_LEVELS.get(int(k)) if levels is None else levels
    if big is None or isinstance(big, bool) or not (isinstance(big, (int, np.integer)) and big >= 1):
        raise ValueError(
            f"levels must be an integer >= 1 (given for K in {sorted(LATTICE_LEVELS)}), got {big!r}"
        )
    rows = [c for c in itertools.product(range(big, -1, -1), repeat=k) if sum(c) == big]
    return np.array(rows, dtype=float) / big


def lattice_index(weights: np.ndarray, lattice: np.ndarray) -> int:
    """The index of the lattice point nearest ``weights`` (K,) in Euclidean distance (the first of
    ties): how an agent's weights become a setting of the lattice."""
    w = np.asarray(weights, dtype=float)
    return int(np.argmin(np.sum((lattice - w) ** 2, axis=1)))


def slot_channel_at(config: ScenarioConfig, position: np.ndarray) -> SlotChannel:
    """The slot channel of ``config``'s nodes for the UAV at ``position`` (2,) m, built for that one
    position (``miso.slot_channels`` of one row), so every caller gets it bit for bit alike."""
    return slot_channels(config, scenario_array(config), np.asarray(position, dtype=float).reshape(1, 2))[0]


def slot_setting(channel: SlotChannel, weights: np.ndarray, alone: np.ndarray | None = None) -> np.ndarray:
    """The rates (K,) bps/Hz of the slot's setting at ``weights`` (module docstring): the AO at w,
    or a user alone (``alone``: ``miso.tdma_rates(channel)``, computed when None) if w . R is
    larger there (the first such user)."""
    w = np.asarray(weights, dtype=float)
    solo = tdma_rates(channel) if alone is None else alone
    return weighted_settings(channel, w[None], solo, max_iter=MAX_ITER)[0]


def slot_points(config: ScenarioConfig, trajectory: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(points (N, J + K, K), gains (N, K)): per slot the rates of the J lattice settings
    (:func:`slot_setting`, in :func:`weight_lattice` order) and of each user alone, and the users'
    single-user gains G_k (``miso.slot_bounds``) for the certified bound."""
    check_sdma_scenario(config)
    q = np.asarray(trajectory, dtype=float)
    if q.ndim != 2 or q.shape[1] != 2 or not np.all(np.isfinite(q)):
        raise ValueError(f"trajectory must be a finite (N, 2) array in m, got shape {q.shape}")
    lattice = weight_lattice(config.K)
    points = np.empty((len(q), len(lattice) + config.K, config.K))
    gains = np.empty((len(q), config.K))
    for n, p in enumerate(q):
        channel = slot_channel_at(config, p)
        solo = tdma_rates(channel)
        points[n, : len(lattice)] = weighted_settings(channel, lattice, solo, max_iter=MAX_ITER)  # at once
        points[n, len(lattice) :] = np.diag(solo)
        gains[n] = slot_bounds(channel).gains
    return points, gains


def sdma_pricer(points: np.ndarray) -> Pricer:
    """The exact pricer of the finite settings ``points`` (N, J, K): at w each slot takes a setting
    of largest w . R (the first), and the bound is the mean of those maxima, g(w) itself."""
    p = np.asarray(points, dtype=float)

    def price(w: np.ndarray) -> tuple[np.ndarray, float]:
        values = p @ w  # (N, J)
        best = np.argmax(values, axis=1)
        return p[np.arange(len(p)), best].mean(axis=0), float(values.max(axis=1).mean())

    return price


@dataclass(frozen=True)
class SdmaScore:
    """The SDMA score of a flight (module docstring): ``value`` (bps/Hz) the max-min with time
    sharing of the credited settings, ``upper`` a certified bound over every beam set and surface
    setting on the same slots, ``schedule`` the regions solution (its rates, mix and weights)."""

    value: float
    upper: float
    schedule: RegionSchedule

    @property
    def gap(self) -> float:
        """upper / value - 1 (inf when the value is 0)."""
        return self.upper / self.value - 1.0 if self.value > 0 else math.inf


def certified_bound(gains: np.ndarray, weights: np.ndarray) -> float:
    """(1/N) sum_n ``miso.weighted_sum_bound``(G_n, w): at least every flight's max-min on these
    slots for any w on the simplex (module docstring)."""
    return float(np.mean([weighted_sum_bound(g, weights) for g in np.asarray(gains, dtype=float)]))


def sdma_maxmin(config: ScenarioConfig, trajectory: np.ndarray) -> SdmaScore:
    """The flight's SDMA max-min and its certified bound (module docstring)."""
    points, gains = slot_points(config, trajectory)
    schedule = maxmin_regions(sdma_pricer(points), config.K, tol=1e-9)
    candidates = [*weight_lattice(config.K), schedule.dual_weights]
    upper = min(certified_bound(gains, w) for w in candidates)
    if schedule.value > upper * (1 + 1e-9):
        raise RuntimeError(f"sdma_maxmin: the score {schedule.value!r} exceeds its bound {upper!r}")
    return SdmaScore(schedule.value, max(upper, schedule.value), schedule)
