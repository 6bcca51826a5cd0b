r"""A STAR surface serving two users over a flight: the max-min rate with time sharing, certified.

Two users, one on each side of the surface plane (``users`` (2, 2) m, in a fixed order 0, 1). In
slot n the UAV is on one side: the user there is served by reflection and the other by
transmission (``ios_uav_env.model.star``; the roles swap when the UAV crosses the plane). The
flight's max-min over the two users, with time sharing inside each slot, is solved by
``ios_uav_env.model.regions.maxmin_regions`` from the slot's *weighted-sum* problem, which
:func:`star_pricer` answers for:

- **TDMA**, any protocol: each user is served in its share with the surface set for it alone
  (``star_frontier.full_side``), so the slot's region is the hull of (c_r, 0) and (0, c_t) and
  the weighted sum is max(w_r c_r, w_t c_t), exactly. With the ``"fixed"`` protocol (the paper's
  IOS: amplitudes 1 and epsilon, shared phases) c_s is ``channel.slot_rates`` at user s, so the
  flight's value is the frame's max-min schedule of the two nodes (``maxmin_rate``).
- **NOMA, energy splitting, independent continuous phases**: each side's phases align to its user,
  the reachable amplitude pairs (A_r, A_t) form a convex set whose Pareto frontier is
  ``star_frontier.frontier_point``'s, and the weighted NOMA sum F_w(A_r, A_t) =
  max_p [w_r R_r + w_t R_t] (``regions.weighted_noma``) is nondecreasing in both amplitudes (the
  degraded broadcast channel's capacity region grows with either SNR), so the branch and bound
  of ``star_frontier.es_frontier_bb`` with F_w as its objective gives the maximum to ``tol``
  with a certified upper bound, which is the pricer's bound. Its region contains the TDMA
  vertices (all elements and all power to one user), so with time sharing the flight's value is
  never below TDMA's with the same protocol.

Other protocols, phase models and phase resolutions under NOMA are refused (their weighted-sum
optima are not built yet; ``star_slot`` has their per-slot max-min).

**As a scenario.** :func:`scenario_maxmin` is :func:`star_maxmin` of a ``ScenarioConfig`` of
surface ``"star"`` with two ground nodes, one on each side (its ``star_*`` fields the surface and
the access): ``ios_uav_env.score_plan`` scores a NOMA scenario (``star_access="noma"``) with it.
"""

from __future__ import annotations

import numpy as np

from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.regions import Pricer, RegionSchedule, maxmin_regions, weighted_noma
from ios_uav_env.model.star import ACCESS, StarChannels, StarSurface, star_channels
from ios_uav_env.model.star_frontier import DEFAULT_TOL, es_frontier_bb, frontier_point, full_side, rate_of

__all__ = ["scenario_maxmin", "star_maxmin", "star_pricer"]


def _roles(config: ScenarioConfig, trajectory: np.ndarray, users: np.ndarray) -> tuple[np.ndarray, list]:
    """(r (N,) the index of the reflection user per slot, the slots' StarChannels)."""
    x_c = config.ios_center[0]
    side = np.sign(users[:, 0] - x_c)
    if side[0] * side[1] >= 0:
        raise ValueError(
            f"users must lie on opposite sides of the surface plane x = {x_c:g} m (off it), got x = "
            f"{users[0, 0]:g} and {users[1, 0]:g} m"
        )
    r = np.where((trajectory[:, 0] - x_c) * side[0] >= 0, 0, 1)  # on the plane: user 0 reflects
    chans = [star_channels(config, q, users[i], users[1 - i]) for q, i in zip(trajectory, r, strict=True)]
    return r, chans


def _tdma_slot(ch: StarChannels, surface: StarSurface) -> tuple[float, float]:
    """(c_r, c_t): each user's rate with the surface set for it alone."""
    return rate_of(ch, full_side(ch, surface, "r")[0]), rate_of(ch, full_side(ch, surface, "t")[0])


def star_pricer(
    config: ScenarioConfig,
    trajectory: np.ndarray,
    users: np.ndarray,
    surface: StarSurface,
    access: str,
    tol: float = DEFAULT_TOL,
) -> Pricer:
    """The weighted-sum pricer of the two users' slot regions along ``trajectory`` (N, 2) m
    (module docstring), for ``maxmin_regions(price, 2)``; weights and points in the order of
    ``users`` (2, 2) m. ``tol``: the relative gap of the NOMA branch and bound."""
    if access not in ACCESS:
        raise ValueError(f"access must be one of {ACCESS}, got {access!r}")
    if not isinstance(surface, StarSurface):
        raise TypeError(f"surface must be a StarSurface, got {type(surface).__name__}")
    noma = access == "noma"
    if noma and (surface.protocol, surface.phases, surface.bits) != ("es", "independent", None):
        raise ValueError(
            "the weighted-sum slot optimum under NOMA is built for protocol 'es' with independent "
            f"continuous phases, got protocol={surface.protocol!r}, phases={surface.phases!r}, "
            f"bits={surface.bits!r} (access 'tdma' takes every protocol)"
        )
    q = np.asarray(trajectory, dtype=float)
    u = np.asarray(users, dtype=float)
    if q.ndim != 2 or q.shape[1] != 2 or not np.all(np.isfinite(q)):
        raise ValueError(f"trajectory must be a finite (N, 2) array in m, got shape {q.shape}")
    if u.shape != (2, 2) or not np.all(np.isfinite(u)):
        raise ValueError(f"users must be two finite (x, y) points in m, shape (2, 2), got {u.shape}")
    r, chans = _roles(config, q, u)
    tdma = None if noma else np.array([_tdma_slot(ch, surface) for ch in chans])  # (N, 2): (c_r, c_t)

    def price(w: np.ndarray) -> tuple[np.ndarray, float]:
        point, total = np.zeros(2), 0.0
        for n, ch in enumerate(chans):
            w_r, w_t = float(w[r[n]]), float(w[1 - r[n]])
            if noma:
                share = w_r / (w_r + w_t) if w_r + w_t > 0 else 0.5

                def f_w(c: StarChannels, a_r: float, a_t: float, share: float = share) -> float:
                    return weighted_noma(c.eta * a_r * a_r, c.eta * a_t * a_t, share)[0]

                _, upper, best = es_frontier_bb(ch, tol, objective=f_w)
                a_r, a_t = frontier_point(ch, best)[:2]
                _, rate_r, rate_t, _ = weighted_noma(ch.eta * a_r * a_r, ch.eta * a_t * a_t, share)
                total += (w_r + w_t) * upper
            else:
                c_r, c_t = tdma[n]
                rate_r, rate_t = (c_r, 0.0) if w_r * c_r >= w_t * c_t else (0.0, c_t)
                total += max(w_r * c_r, w_t * c_t)
            point[r[n]] += rate_r
            point[1 - r[n]] += rate_t
        return point / len(chans), total / len(chans)

    return price


def star_maxmin(
    config: ScenarioConfig,
    trajectory: np.ndarray,
    users: np.ndarray,
    surface: StarSurface,
    access: str,
    tol: float = DEFAULT_TOL,
) -> RegionSchedule:
    """The flight's max-min rate of the two ``users`` (bps/Hz) with time sharing in every slot, and
    its certified upper bound (module docstring; ``RegionSchedule.value`` <= V <= ``.upper``)."""
    return maxmin_regions(star_pricer(config, trajectory, users, surface, access, tol), 2, tol=max(tol, 1e-9))


def scenario_maxmin(
    config: ScenarioConfig, trajectory: np.ndarray, tol: float = DEFAULT_TOL
) -> RegionSchedule:
    """:func:`star_maxmin` of a STAR scenario: ``config.surface == "star"``, its two static ground
    nodes (one on each side of the surface plane) the users in the order of ``config.nodes``, its
    ``star_protocol``, ``star_phases`` and ``star_access``. Under TDMA this is the frame's two-node
    schedule (``maxmin_rate``); ``score_plan`` scores NOMA scenarios with it."""
    if config.surface != "star":
        raise ValueError(f"scenario_maxmin scores surface 'star' scenarios, got surface={config.surface!r}")
    x_c = config.ios_center[0]
    if config.K != 2:
        raise ValueError(
            f"a STAR scenario with star_access={config.star_access!r} is scored over two ground_nodes, one "
            f"on each side of the surface plane x = {x_c:g} m (star_regions.star_maxmin), got K = {config.K}"
        )
    if config.motion is not None:
        raise ValueError(
            f"a STAR scenario with star_access={config.star_access!r} is scored for static nodes "
            "(star_regions.star_maxmin), got a motion model"
        )
    surface = StarSurface(config.star_protocol, config.star_phases, config.star_bits)
    users = np.asarray(config.nodes, dtype=float)
    return star_maxmin(config, trajectory, users, surface, config.star_access, tol)
