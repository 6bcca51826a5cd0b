r"""A multi-antenna UAV serving K users over a flight: the max-min rate with time sharing, certified.

In slot n the UAV at q[n] (``ios_uav_env.model.miso``: N_t antennas, one shared surface setting,
beams of total power P) can reach any rate vector its beams and the surface's phases give, and with
time sharing inside the slot the hull of those. The flight's max-min over the users is then the
regions problem of ``ios_uav_env.model.regions`` (``maxmin_regions``), priced by the slot's
*weighted* sum rate max sum_k w_k R_k:

- the point: the better of the best AO run of ``miso_slot.optimise_slot(..., weights=w)``
  (weighted WMMSE beams and phase updates from each user's aligned phases with MRT, and ZF when
  N_t >= K) and the best user served alone at full power with its aligned phases and MRT
  (``miso.tdma_rates``): a feasible setting either way, so its rates are reachable;
- the bound: ``miso.weighted_sum_bound`` of the users' single-user gains G_k (interference-free,
  each user's best surface), certified for every setting.

Every user served alone is among the candidates, so the flight's value is never below TDMA's on
the same slots (the frame's schedule of ``miso.tdma_rates``), and the time sharing between
simultaneous service and one user at a time is what the per-slot max-min AO alone cannot do. The bound is as
loose as the per-user bound is for the weighted sum: its gap is reported, not hidden.
"""

from __future__ import annotations

import numpy as np

from ios_uav_env.model.array import ArrayConfig
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.miso import slot_bounds, slot_channel, tdma_rates, weighted_sum_bound
from ios_uav_env.model.miso_runs import weighted_settings
from ios_uav_env.model.regions import Pricer, RegionSchedule, maxmin_regions

__all__ = ["miso_maxmin", "miso_pricer"]


def miso_pricer(
    config: ScenarioConfig, array: ArrayConfig, trajectory: np.ndarray, *, max_iter: int = 50
) -> Pricer:
    """The weighted-sum pricer of the K users' slot regions along ``trajectory`` (N, 2) m (module
    docstring), for ``maxmin_regions(price, config.K)``. ``max_iter``: AO iterations per start."""
    q = np.asarray(trajectory, dtype=float)
    if q.ndim != 2 or q.shape[1] != 2 or not np.all(np.isfinite(q)):
        raise ValueError(f"trajectory must be a finite (N, 2) array in m, got shape {q.shape}")
    channels = [slot_channel(config, array, p) for p in q]
    gains = [slot_bounds(c).gains for c in channels]
    alone = [tdma_rates(c) for c in channels]  # each user served alone: the TDMA vertices

    def price(w: np.ndarray) -> tuple[np.ndarray, float]:
        point, total = np.zeros(config.K), 0.0
        for c, g, solo in zip(channels, gains, alone, strict=True):
            rates = weighted_settings(c, w[None], solo, max_iter=max_iter)[0]
            bound, value = weighted_sum_bound(g, w), float(w @ rates)
            if value > bound * (1 + 1e-9) + 1e-12:
                raise RuntimeError(f"miso_pricer: the weighted sum {value!r} exceeds its bound {bound!r}")
            point += rates
            total += max(bound, value)  # (they differ by rounding at the most: checked above)
        return point / len(channels), total / len(channels)

    return price


def miso_maxmin(
    config: ScenarioConfig,
    array: ArrayConfig,
    trajectory: np.ndarray,
    *,
    max_iter: int = 50,
    tol: float = 1e-6,
    max_columns: int = 200,
) -> RegionSchedule:
    """The flight's max-min rate of ``config``'s K users served by the multi-antenna UAV, with time
    sharing in every slot, and a certified upper bound (module docstring). ``max_columns``: where
    the regions' column generation stops (the bound stays certified; the gap says how far)."""
    price = miso_pricer(config, array, trajectory, max_iter=max_iter)
    return maxmin_regions(price, config.K, tol=tol, max_columns=max_columns)
