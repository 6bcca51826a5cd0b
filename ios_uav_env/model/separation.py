r"""The separation guard: U UAVs never come closer than a minimum distance d_min.

Every UAV flies its slot's move at constant speed over the same slot, so between way-points UAV
u is at q_u + s (p_u - q_u) for s in [0, 1] (q: this slot's way-points, p: the next ones as
proposed). The distance of a pair (u, v) is then |c + s w| with c = q_u - q_v and
w = (p_u - q_u) - (p_v - q_v), a quadratic in s:

    |c + s w|^2 = d_min^2   <=>   |w|^2 s^2 + 2 (c . w) s + (|c|^2 - d_min^2) = 0.

If the pair is separated at s = 0 (|c| >= d_min), it stays separated up to the smaller root s_1
of that quadratic (none in [0, 1], or the pair moves apart: all of the slot). The guard flies
every UAV the same fraction t = min over the pairs of s_1, clipped to [0, 1] (the common
fraction): the way-points q + t (p - q). So every pair keeps d_min along the whole flight,
between way-points included, whatever the proposed moves, by induction from separated starts
(:func:`check_separated`).

The common fraction is the simple rule that is provably safe, but it stops every UAV at the first
contact a slot's moves would make, a bystander far from it too. So the guard first tries per-UAV
fractions: the pair that would meet first flies up to that moment (both its fractions scaled by
the contact time), the others fly on, until no pair meets within the slot; the result is checked
all along (:func:`flights_separated`), and only if it fails does the common fraction apply. A pair
in contact that keeps pushing together stays put: the UAVs have to go round each other. The guard
never lengthens a move, so the speed limit holds; it can cost a UAV its arrival at its final
point (the moves it lost), which the env reports as a terminal miss, as for a single UAV whose
arrival guard is off. A UAV past its own horizon has left (``model.fleet_horizons``): the guard
and :func:`flights_separated` consider only the UAVs still flying. Rounding: each root is taken a
relative 1e-9 short, the way-points are checked, and a fraction halves until they are separated
(t = 0, staying put, always is).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ios_uav_env.model.guard import guarded_position

__all__ = [
    "DEFAULT_SEPARATION", "GUARD_MARGIN", "check_separated", "flights_separated", "guard_distance",
    "guarded_moves", "min_distance", "separated_moves",
]  # fmt: skip

#: The guard keeps the UAVs this relative margin (plus 1e-9 m) beyond d_min, so that the
#: kernels' rounding of a guarded move (~1e-13 m) never brings two of them within d_min.
GUARD_MARGIN = 1e-9


def guard_distance(min_separation: float) -> float:
    """m: the distance the separation guard keeps (``min_separation`` and the margin)."""
    return min_separation * (1.0 + GUARD_MARGIN) + GUARD_MARGIN


#: m, the default minimum separation d_min (the fleet env's and planner's).
DEFAULT_SEPARATION = 10.0
#: Relative margin of the fraction t below the first contact (rounding of the root and of the
#: way-points q + t (p - q)).
CONTACT_MARGIN = 1e-9


def min_distance(positions: np.ndarray) -> float:
    """m: the smallest distance between two of the (U, 2) ``positions`` (inf for U < 2)."""
    q = np.asarray(positions, dtype=float)
    best = math.inf
    for u in range(len(q)):
        for v in range(u + 1, len(q)):
            best = min(best, math.hypot(q[u, 0] - q[v, 0], q[u, 1] - q[v, 1]))
    return best


def check_separated(positions: np.ndarray, d_min: float, name: str) -> None:
    """``ValueError`` naming ``name`` unless every two of the (U, 2) ``positions`` are at least
    ``d_min`` m apart."""
    q = np.asarray(positions, dtype=float)
    for u in range(len(q)):
        for v in range(u + 1, len(q)):
            d = math.hypot(q[u, 0] - q[v, 0], q[u, 1] - q[v, 1])
            if d < d_min:
                raise ValueError(
                    f"{name}: UAVs {u} and {v} are {d:.6g} m apart, closer than min_separation = "
                    f"{d_min:g} m: give points at least min_separation apart"
                )


def _first_contact(c: np.ndarray, w: np.ndarray, d_min: float) -> float:
    """The smallest s >= 0 with |c + s w| = d_min for a pair separated at s = 0 (inf: never)."""
    a = float(w @ w)
    b = float(c @ w)  # half the linear coefficient
    cc = float(c @ c) - d_min * d_min
    if a == 0.0 or b >= 0.0:  # not moving relative to each other, or moving apart
        return math.inf
    disc = b * b - a * cc
    if disc < 0.0:  # the closest approach stays beyond d_min
        return math.inf
    # the smaller root (-b - sqrt(disc)) / a, written without cancellation (b < 0)
    return cc / (-b + math.sqrt(disc)) if cc > 0.0 else 0.0


def _common_fraction(q: np.ndarray, moves: np.ndarray, d_min: float) -> float:
    """The one fraction t of every move that keeps every pair ``d_min`` apart all along: the
    earliest first contact over the pairs, a relative ``CONTACT_MARGIN`` short (1 if none)."""
    t = 1.0
    for u in range(len(q)):
        for v in range(u + 1, len(q)):
            s = _first_contact(q[u] - q[v], moves[u] - moves[v], d_min)
            if s <= 1.0:
                t = min(t, s * (1.0 - CONTACT_MARGIN))
    return max(t, 0.0)


def _pairwise_fractions(q: np.ndarray, moves: np.ndarray, d_min: float) -> np.ndarray | None:
    """Per-UAV fractions t_u: while some pair would meet within the slot, the pair that meets
    first flies only up to that moment (both its fractions scaled by the contact time), the
    others keep theirs; None if that does not settle within U^2 rounds."""
    u_n = len(q)
    t = np.ones(u_n)
    for _ in range(u_n * u_n + 1):
        first = (math.inf, -1, -1)
        for u in range(u_n):
            for v in range(u + 1, u_n):
                s = _first_contact(q[u] - q[v], t[u] * moves[u] - t[v] * moves[v], d_min)
                if s <= 1.0 and s < first[0]:
                    first = (s, u, v)
        s, u, v = first
        if u < 0:
            return t
        scale = max(s * (1.0 - CONTACT_MARGIN), 0.0)
        t[u], t[v] = t[u] * scale, t[v] * scale
    return None


def _separated_all_along(q: np.ndarray, reached: np.ndarray, d_min: float) -> bool:
    return flights_separated(np.stack([q, reached], axis=1), d_min)


def separated_moves(
    positions: np.ndarray, proposed: np.ndarray, d_min: float
) -> tuple[np.ndarray, np.ndarray]:
    """(t, way-points): t (U,) in [0, 1], the fraction of its move ``positions`` -> ``proposed``
    (both (U, 2) m) each UAV flies so that every pair stays ``d_min`` m apart all along (module
    docstring), and the way-points reached, (U, 2) m (a UAV's proposed point itself at t = 1).

    First the pairs that would meet stop at their contact, the other UAVs flying on (checked all
    along); if that does not settle or does not check out, the common fraction of every move
    (provably safe); then, for rounding, halving until the way-points are separated (staying
    put, t = 0, always is). ``positions`` must be separated (the guard keeps them so)."""
    q = np.asarray(positions, dtype=float)
    p = np.asarray(proposed, dtype=float)
    moves = p - q

    def reach(t: np.ndarray) -> np.ndarray:
        return np.where((t == 1.0)[:, None], p, q + t[:, None] * moves)

    t = _pairwise_fractions(q, moves, d_min)
    if t is not None and _separated_all_along(q, reach(t), d_min):
        return t, reach(t)
    common = _common_fraction(q, moves, d_min)
    while True:
        t = np.full(len(q), common)
        reached = reach(t)
        if common == 0.0 or _separated_all_along(q, reached, d_min):
            return t, reached
        common = common / 2.0 if common > 1e-12 else 0.0


def guarded_moves(
    q: np.ndarray, moves: np.ndarray, finals: np.ndarray, d: Any, left: Any, guard: float
) -> tuple[np.ndarray, np.ndarray]:
    """((U, 2) moves / D, (U,) fractions): the UAVs at ``q`` (U, 2) m asked to move ``moves`` (U, 2)
    / D: each projected on the unit disk, then through its arrival guard to its final point
    (``left``: moves left after this one, one for every UAV or one per UAV: its own horizon's),
    then the fleet's separation guard at ``guard`` m (``model.separation.separated_moves``; the
    fractions of the moves it flies). ``d``: D (m), one for every UAV or one per UAV. The UAVs
    given are the ones flying this slot (a UAV past its horizon is no longer guarded)."""
    d = np.broadcast_to(np.asarray(d, dtype=float), (len(q),))
    left = np.broadcast_to(np.asarray(left), (len(q),))
    proposed = np.empty_like(q)
    for u in range(len(q)):
        ax, ay = moves[u, 0], moves[u, 1]
        norm = math.hypot(ax, ay)
        if norm > 1.0:
            ax, ay = ax / norm, ay / norm
        du = float(d[u])
        target = (q[u, 0] + du * ax, q[u, 1] + du * ay)
        own = int(left[u])
        proposed[u] = guarded_position((q[u, 0], q[u, 1]), target, (finals[u, 0], finals[u, 1]), du, own)
    fractions, reached = separated_moves(q, proposed, guard)
    return (reached - q) / d[:, None], fractions


def flights_separated(trajectories: np.ndarray, d_min: float, slots: Any = None) -> bool:
    """Whether the U flights ``trajectories`` (U, N, 2) m, each flown at constant speed in every
    slot, keep every pair at least ``d_min`` m apart all along (way-points and between).
    ``slots``: each UAV's slot count N_u (default N each): a pair is checked while both fly, up
    to the earlier of their last slots (``model.fleet_horizons``)."""
    t = np.asarray(trajectories, dtype=float)
    last = np.full(len(t), t.shape[1]) if slots is None else np.asarray(slots)
    if min_distance(t[:, 0]) < d_min:
        return False
    for n in range(t.shape[1] - 1):
        flying = last > n + 1  # the UAVs that fly the move into slot n + 1
        q, p = t[flying, n], t[flying, n + 1]
        moves = p - q
        for u in range(len(q)):
            for v in range(u + 1, len(q)):
                if _first_contact(q[u] - q[v], moves[u] - moves[v], d_min) < 1.0:
                    return False
        if min_distance(p) < d_min:
            return False
    return True
