"""The hover plan's flight, compiled: the flight of the energy reward's default lambda_ref.

``ios_uav_env.envs.observation.reference_efficiency`` is the EE (``score_plan``) of the flight
"fly to the reachable rate peak P at full speed and hover there" through the arrival guard
(``observation.hover_flight``, which is :func:`hover_path`). A randomised energy env flies it at
every reset, so the loop is compiled (numba; plain Python without it). Its own arithmetic is
IEEE (``fastmath=False``) and its lengths are sqrt(dx^2 + dy^2) (not ``math.hypot``, which Python
and the C library round differently), so compiled or not it computes the same way-points from the
same guard answers; the guard (``guard.guarded_position``) is the compiled one with numba and
Python's without, which differ by rounding (~1e-13 m), as every kernel of the env does.
"""

from __future__ import annotations

import math

import numpy as np

from ios_uav_env.jit import jit
from ios_uav_env.model.guard import guarded_position

#: :func:`hover_path` skips the guard where qF is within (moves left) D / HOVER_SLACK: a relative
#: 2e-9 inside the guard's reach disk ((moves left) D (1 - 1e-12)), far beyond any rounding of its
#: distances (a few ulps), so the guard's answer (the target itself) is certain.
HOVER_SLACK = (1.0 + 1e-9) / (1.0 - 1e-9)


@jit(fastmath=False)
def hover_path(
    x: float, y: float, fx: float, fy: float, px: float, py: float, d: float, slots: int
) -> np.ndarray:  # fmt: skip
    """The (``slots``, 2) flight (m) from q0 = (x, y) towards P = (px, py) at full speed D = ``d``
    per move, then hovering on P, each move through the arrival guard towards qF = (fx, fy) with
    the moves left, which brings it to qF at the last slot. While it hovers on P with qF well
    within reach (:data:`HOVER_SLACK`) the guard would return its target, so it is not called."""
    path = np.empty((slots, 2))
    path[0, 0], path[0, 1] = x, y
    final = (fx, fy)
    for n in range(1, slots):
        dx, dy = px - x, py - y
        left = slots - 1 - n
        if dx == 0.0 and dy == 0.0 and left > 0:
            ex, ey = x - fx, y - fy
            if HOVER_SLACK * math.sqrt(ex * ex + ey * ey) < left * d:
                path[n, 0], path[n, 1] = x, y  # hovering on P, qF well within reach
                continue
        norm = math.sqrt(dx * dx + dy * dy)
        if norm > d:  # full speed towards P, then stop on it
            dx, dy = dx * d / norm, dy * d / norm
        x, y = guarded_position((x, y), (x + dx, y + dy), final, d, left)
        path[n, 0], path[n, 1] = x, y
    return path
