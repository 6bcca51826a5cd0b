"""The arrival guard: keep every move within D and the final point within reach.

Eq. (10) asks for |q[n+1] - q[n]| <= D and q[N] = qF. A position is still able to reach qF
iff it lies within (moves left) x D of qF, so projecting each proposed next position onto
the intersection of the disk of radius D around the current position and the disk of radius
(moves left after this one) x D around qF keeps both limits at once, whatever was proposed:
by induction the intersection is never empty, and the last move lands exactly on qF.
The projection is the exact Euclidean one, in closed form (:func:`project_to_disks`);
compiled with numba when installed (the envs' steps and ``flights``' loiter flight call it).
"""

from __future__ import annotations

import math

from ios_uav_env.jit import jit

# Relative inward margin of the reach disk, so that rounding never leaves qF out of reach
# and the last move (onto qF exactly) is at most D. The step disk has none: its projections
# are exact to rounding (|step| <= D + ~1e-13 m), and a margin there would add up over a
# horizon that leaves no spare move (every move exactly D).
REACH_MARGIN = 1e-12


@jit
def project_to_disks(
    t: tuple[float, float], a: tuple[float, float], ra: float, b: tuple[float, float], rb: float
) -> tuple[float, float]:
    """Euclidean projection of the point ``t`` onto disk(a, ra) ∩ disk(b, rb), in closed form.

    Inside both: ``t``. Else the projection onto one disk if it lies in the other; else the
    nearer of the two circle-intersection points. If the intersection is empty (only through
    rounding when the disks just touch), the point of disk a nearest to disk b.
    """
    tx, ty = t
    ax, ay = a
    bx, by = b
    da, db = math.hypot(tx - ax, ty - ay), math.hypot(tx - bx, ty - by)
    if da <= ra and db <= rb:
        return tx, ty
    if da > ra:
        px, py = ax + (tx - ax) * (ra / da), ay + (ty - ay) * (ra / da)
        if math.hypot(px - bx, py - by) <= rb:
            return px, py
    if db > rb:
        px, py = bx + (tx - bx) * (rb / db), by + (ty - by) * (rb / db)
        if math.hypot(px - ax, py - ay) <= ra:
            return px, py
    ux, uy = bx - ax, by - ay
    d = math.hypot(ux, uy)
    if d <= abs(ra - rb):  # one disk inside the other (reached only through rounding)
        (cx, cy), r, dc = ((ax, ay), ra, da) if ra < rb else ((bx, by), rb, db)
        return (cx + (tx - cx) * (r / dc), cy + (ty - cy) * (r / dc)) if dc > r else (tx, ty)
    ux, uy = ux / d, uy / d
    if d >= ra + rb:  # touching (or, by rounding, apart): the point of disk a towards b
        return ax + ra * ux, ay + ra * uy
    along = (ra * ra - rb * rb + d * d) / (2.0 * d)
    h = math.sqrt(max(0.0, ra * ra - along * along))
    cx, cy = ax + along * ux, ay + along * uy
    p1, p2 = (cx - h * uy, cy + h * ux), (cx + h * uy, cy - h * ux)
    return p1 if math.hypot(p1[0] - tx, p1[1] - ty) <= math.hypot(p2[0] - tx, p2[1] - ty) else p2


@jit
def guarded_position(
    position: tuple[float, float],
    target: tuple[float, float],
    final: tuple[float, float],
    D: float,
    moves_left: int,
) -> tuple[float, float]:
    """The point nearest to ``target`` within D of ``position`` and within ``moves_left`` x D
    of ``final`` (``moves_left``: moves left after this one); exactly ``final`` when it is 0.

    Assumes ``position`` is within (moves_left + 1) x D of ``final`` (true by induction from
    a feasible start, which ``ScenarioConfig`` guarantees for q0).
    """
    if moves_left <= 0:
        return float(final[0]), float(final[1])
    return project_to_disks(target, position, D, final, moves_left * D * (1 - REACH_MARGIN))
