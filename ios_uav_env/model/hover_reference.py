"""The hover plan's flight and its energy efficiency in compiled kernels: the energy reward's
default lambda_ref at every new scenario.

``ios_uav_env.envs.observation.reference_efficiency`` is the EE (``score_plan``) of the flight
"fly to the reachable rate peak P at full speed and hover there" through the arrival guard
(``observation.hover_flight``, which is :func:`hover_path`). A randomised energy env needs it at
every reset, so both steps are compiled (numba; plain Python without it):

- :func:`hover_path`: its own arithmetic is IEEE (``fastmath=False``) and its lengths are
  sqrt(dx^2 + dy^2) (not ``math.hypot``, which Python and the C library round differently), so
  compiled or not it computes the same way-points from the same guard answers; the guard
  (``guard.guarded_position``) is the compiled one with numba and Python's without, which differ
  by rounding, as every kernel of the env does;
- :func:`flight_efficiency`: ``score_plan``'s EE of one node's flight, EE = B T R / E (bits/J),
  with R = (1/N) sum_n r(q[n]) the flight's average rate (eq. (9), the compiled rate kernel
  ``channel.rate_point``) and E = dt sum_n P(|q[n+1] - q[n]| / dt) its propulsion energy (eq.
  (12), ``propulsion.propulsion_power``'s expression, :func:`move_power`). Its sums run in order
  (numpy's are pairwise) on the compiled rates (``slot_rates`` is numpy's), so it equals
  ``score_plan``'s EE to rounding, ~1e-15 relative (tested), at a tenth of its cost.
"""

from __future__ import annotations

import math

import numpy as np

from ios_uav_env.jit import jit
from ios_uav_env.model.channel import rate_point
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


@jit(fastmath=False)
def move_power(speed: float, p0: float, u_tip: float, p_i: float, v0: float, drag: float) -> float:
    """P(V) (W) of eq. (12) at ``speed`` V (m/s): ``propulsion.propulsion_power``'s expression
    (blade profile + induced + parasite) for one speed."""
    v2 = speed * speed
    x = v2 / (2.0 * v0**2)
    blade = p0 * (1.0 + 3.0 * v2 / u_tip**2)
    induced = p_i / math.sqrt(math.sqrt(1.0 + x * x) + x)
    parasite = drag * v2 * speed
    return blade + induced + parasite


@jit
def flight_efficiency(
    path: np.ndarray, nodes: np.ndarray, params: np.ndarray, dt: float, bandwidth: float, horizon: float,
    propulsion: np.ndarray,
) -> float:  # fmt: skip
    """EE = B T R / E (bits/J) of the (N, 2) flight ``path`` on one rate kernel (``nodes``,
    ``params``: ``RateKernel``'s), ``dt`` (s), B = ``bandwidth`` (Hz), T = ``horizon`` (s) and
    ``propulsion`` = (P0, U_tip, P_i, v0, drag coefficient) (the module's docstring)."""
    slots = path.shape[0]
    total = 0.0
    for n in range(slots):
        total += rate_point(path[n, 0], path[n, 1], nodes, params)
    rate = total / slots
    energy = 0.0
    for n in range(slots - 1):
        dx, dy = path[n + 1, 0] - path[n, 0], path[n + 1, 1] - path[n, 1]
        speed = math.sqrt(dx * dx + dy * dy) / dt
        energy += move_power(speed, propulsion[0], propulsion[1], propulsion[2], propulsion[3], propulsion[4])
    return bandwidth * horizon * rate / (dt * energy)
