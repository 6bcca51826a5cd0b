"""The multi-antenna UAV hovering at one point: every scheme's rate against the transmit power P.

With the UAV fixed at a hover point q, a slot of :mod:`ios_uav_env.model.miso` is the classical
RIS / IOS MISO downlink: N_t antennas, K single-antenna users, one shared surface configuration,
linear precoding under a total power P. :func:`power_sweep` evaluates, for each P of a list (dBm),
the sum rate or the max-min rate (bps/Hz) of the per-slot optimum and of the references, and the
certified upper bound, so every power has each scheme's gap to the bound.

**How P enters.** P (dBm) replaces the scenario's ``power_w`` = 10^(P / 10) mW; the noise
sigma^2 is its ``noise_dbm``, so the transmit SNR is eta = P / sigma^2, in dB
10 log10 eta = P - ``noise_dbm`` (:attr:`PowerSweep.snr_db`). The antenna and element gains
(``g_tx``, ``g_rx``, ``g_element``) scale the channel's amplitudes, not eta. The channel at P is
``miso.slot_channel(config.replace(power_w=...), array, q)`` (:func:`sweep_channel`): the same
geometry scaled by sqrt(eta).

**The schemes** (:data:`SCHEMES`):

- ``AO``: the best alternating-optimisation run (``miso_slot``) from the starts of
  ``miso_slot.optimise_slot`` (each user's aligned phases with MRT and ZF beams, ``random_starts``
  random phase draws), from each user alone at full power (its aligned phases and MRT, the other
  beams zero: the sum rate only) and from the previous power's solution. At fixed phases and
  beams every SINR_k = eta a_k / (eta b_k + 1) rises with eta, so the last start makes AO's value
  non-decreasing along the (increasing) powers; the single-user starts make its sum rate at least
  TDMA's (one user all the slot, ``tdma_value``).
- ``MRT aligned``, ``ZF aligned``, ``MRT random``, ``ZF random``, ``TDMA``: ``miso.baselines``
  (equal powers 1 / K; the best of the K users' aligned phases, or one random draw, the same
  draw at every P; ZF is NaN when N_t < K).
- the bound: ``miso.slot_bounds`` (interference-free water filling of the single-user gains G_k
  for the sum rate, log2(1 + 1 / sum_k 1 / G_k) for the max-min rate), certified for every
  precoder and surface.

**What the curves must do** (tested in ``tests/model/test_miso_sweep.py``). Write G_k = eta Gamma_k
(Gamma_k: user k's best channel gain per unit eta).

- Every scheme stays below the bound at every P; AO stays above MRT and ZF with aligned phases
  (they are among its starts, and AO never lowers its objective) and, for the sum rate, TDMA.
- *High P: degrees of freedom.* With N_t >= K independent rows, ZF removes the interference:
  at fixed phases SINR_k = eta z_k / K with z_k independent of eta, its sum rate is
  sum_k log2(1 + eta z_k / K), whose slope rises towards K log2(10) / 10 bps/Hz per dB
  (:func:`dof_slope`, K streams) and never exceeds it. The bound's water filling tends to equal
  powers, sum_k log2(G_k / K) + o(1): the same slope, so ZF's gap tends to the constant
  sum_k log2(Gamma_k / z_k) >= 0. MRT with K >= 2 users and a shared surface is
  interference-limited: its SINRs tend to constants and its slope to 0. The max-min rate has
  one stream's slope, log2(10) / 10, for ZF and the bound.
- *Low P.* To first order in eta the interference is negligible next to the noise and
  log2(1 + x) = x / ln 2, so the sum rate is sum_k p_k |h_k w_k|^2 / ln 2: the matched filter
  (MRT) is the best beam direction, and all the power goes to the strongest user with its
  aligned phases. That is TDMA's sum value log2(1 + max_k G_k), and the water filling gives the
  bound exactly that value as soon as 1 / G_(2) - 1 / G_(1) >= 1 (the two largest gains): TDMA
  and AO (its single-user starts) attain the bound there, to rounding. Equal-power MRT keeps the
  matched filter but splits the power: its ratio to the optimum tends to
  max_j (1 / K) sum_k ||h_k(psi_j)||^2 / max_k G_k, psi_j user j's aligned phases
  (:func:`low_power_mrt_ratio`), which is 1 only for K = 1 or equally strong users; ZF is below
  MRT there (it spends power on cancelling interference that does not matter yet). For the
  max-min rate TDMA's 1 / sum_k (1 / R_k) and the bound both tend to 1 / (ln 2 sum_k 1 / G_k),
  while SDMA's AO can stay below them (one surface setting serves every user at once).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ios_uav_env.model import miso
from ios_uav_env.model.array import ArrayConfig
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.miso_slot import SlotSolution, alone_starts, best_of_starts, optimise_starts

__all__ = [
    "POWER_RANGE_DBM", "SCHEMES", "PowerSweep", "check_powers", "dof_slope", "low_power_mrt_ratio",
    "power_sweep", "sweep_channel",
]  # fmt: skip

#: The schemes of a sweep, in the table's order (the module docstring).
SCHEMES: tuple[str, ...] = ("AO", "MRT aligned", "ZF aligned", "MRT random", "ZF random", "TDMA")
#: The transmit powers a sweep accepts, dBm (1e-13 W to 10 MW: any SNR the model can represent).
POWER_RANGE_DBM: tuple[float, float] = (-100.0, 100.0)


@dataclass(frozen=True, eq=False)
class PowerSweep:
    """One objective's rates (bps/Hz) against the transmit power at a fixed hover point."""

    objective: str  # "sum" or "maxmin"
    powers_dbm: np.ndarray  # (P,) dBm, increasing: the transmit power P
    snr_db: np.ndarray  # (P,) dB, 10 log10 eta = P - noise_dbm
    values: dict[str, np.ndarray]  # scheme of SCHEMES -> (P,) bps/Hz (NaN: undefined, ZF when N_t < K)
    bound: np.ndarray  # (P,) bps/Hz, the certified upper bound (miso.slot_bounds)
    gains: np.ndarray  # (P, K) the single-user gains G_k (receive SNR of user k alone, linear)
    seconds: np.ndarray  # (P,) s, AO's time at each power
    solutions: tuple[SlotSolution, ...]  # AO's best run at each power (phases, beams, rates)

    def gap(self, scheme: str) -> np.ndarray:
        """bound - value of ``scheme`` at each power (bps/Hz, >= 0 up to rounding)."""
        return self.bound - self._values(scheme)

    def slope(self, scheme: str) -> np.ndarray:
        """The slope of ``scheme``'s curve between consecutive powers, bps/Hz per dB, shape (P - 1,);
        ``"bound"`` for the bound's."""
        y = self.bound if scheme == "bound" else self._values(scheme)
        return np.diff(y) / np.diff(self.powers_dbm)

    def _values(self, scheme: str) -> np.ndarray:
        if scheme not in self.values:
            raise ValueError(f"scheme must be one of {tuple(self.values)}, got {scheme!r}")
        return self.values[scheme]


def dof_slope(streams: int) -> float:
    """The high-SNR slope of ``streams`` interference-free streams: streams x log2(10) / 10 bps/Hz
    per dB (each rate log2(1 + c eta) gains log2(10) per decade of eta)."""
    if not (isinstance(streams, (int, np.integer)) and streams >= 0):
        raise ValueError(f"streams must be an integer >= 0, got {streams!r}")
    return streams * math.log2(10.0) / 10.0


def check_powers(powers_dbm: Sequence[float] | np.ndarray) -> np.ndarray:
    """``powers_dbm`` as a float (P,) array: non-empty, finite, strictly increasing, within
    :data:`POWER_RANGE_DBM`; else ``ValueError``."""
    p = np.asarray(powers_dbm, dtype=float)
    lo, hi = POWER_RANGE_DBM
    if p.ndim != 1 or p.size == 0 or not np.all(np.isfinite(p)) or np.any(p < lo) or np.any(p > hi):
        raise ValueError(
            f"powers_dbm must be a non-empty list of finite transmit powers in [{lo:g}, {hi:g}] dBm, "
            f"got {powers_dbm!r}"
        )
    if np.any(np.diff(p) <= 0):
        raise ValueError(f"powers_dbm must be strictly increasing (dBm), got {powers_dbm!r}")
    return p


def sweep_channel(
    config: ScenarioConfig, array: ArrayConfig, position: np.ndarray, power_dbm: float
) -> miso.SlotChannel:
    """The slot channel of ``config``'s K users at the hover ``position`` (2,) m with the transmit
    power ``power_dbm`` (dBm) in place of ``config.power_w`` (the module docstring)."""
    p = float(check_powers([power_dbm])[0])
    return miso.slot_channel(config.replace(power_w=10.0 ** (p / 10.0) * 1e-3), array, position)


def low_power_mrt_ratio(channel: miso.SlotChannel) -> float:
    """The low-power limit of (equal-power MRT with the best aligned phases) / (the sum-rate
    optimum): max_j (1 / K) sum_k ||h_k(psi_j)||^2 / max_k G_k (the module docstring). A ratio of
    first-order terms, so it does not depend on eta."""
    best = max(
        float(np.sum(np.abs(channel.matrix(miso.aligned_phases(channel, j))) ** 2)) for j in range(channel.K)
    )
    return best / channel.K / float(np.max(miso.slot_bounds(channel).gains))


def power_sweep(
    config: ScenarioConfig,
    array: ArrayConfig,
    position: np.ndarray,
    powers_dbm: Sequence[float] | np.ndarray,
    objective: str = "sum",
    *,
    random_starts: int = 2,
    seed: int = 0,
    max_iter: int = 100,
    tol: float = 1e-7,
    on_power: Callable[[float], None] | None = None,
) -> PowerSweep:
    """Every scheme of :data:`SCHEMES` and the certified bound for ``objective`` at each of the
    increasing ``powers_dbm`` (dBm), the UAV hovering at ``position`` (2,) m with ``array``
    (the module docstring). AO: ``random_starts`` random phase draws (seeded by ``seed``, as the
    random-phase baselines' one draw), ``max_iter`` and ``tol`` per start, and the previous power's
    solution as a warm start. ``on_power(p)`` is called after each power (a progress bar)."""
    miso.check_objective(objective)
    powers = check_powers(powers_dbm)
    if not (isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0):
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    values = {name: np.full(powers.size, np.nan) for name in SCHEMES}
    bound, seconds = np.empty(powers.size), np.empty(powers.size)
    gains = np.empty((powers.size, config.K))
    solutions: list[SlotSolution] = []
    previous: SlotSolution | None = None
    for i, p in enumerate(powers):
        channel = sweep_channel(config, array, position, float(p))
        start = time.perf_counter()
        starts = optimise_starts(channel, random_starts, np.random.default_rng(seed))
        starts += alone_starts(channel) if objective == "sum" else []
        if previous is not None:
            starts.append((f"previous power ({powers[i - 1]:g} dBm)", previous.phases, previous.beams))
        best = best_of_starts(channel, objective, starts, max_iter=max_iter, tol=tol)
        seconds[i] = time.perf_counter() - start
        values["AO"][i] = best.value
        for name, value in miso.baselines(channel, objective, np.random.default_rng(seed)).items():
            values[name][i] = value
        bounds = miso.slot_bounds(channel)
        bound[i], gains[i] = bounds.of(objective), bounds.gains
        solutions.append(best)
        previous = best
        if on_power is not None:
            on_power(float(p))
    snr_db = powers - config.noise_dbm
    return PowerSweep(objective, powers, snr_db, values, bound, gains, seconds, tuple(solutions))
