r"""The weighted-sum slot optimum of a STAR surface serving two users by NOMA, at many UAV positions
at once: the maps a trajectory planner rewards its grid with.

The surface is ``star_regions``' NOMA case: energy splitting, independent continuous phases. At a
UAV position q the two users' rate pairs with time sharing inside the slot form conv(C(q)), and
the weighted sum (weights w = (w_0, w_1) on the simplex, users in a fixed order 0, 1)

    f_w(q) = max_{R in C(q)} w_0 R_0 + w_1 R_1

is what ``star_regions.star_pricer`` answers slot by slot with a branch and bound. Here the same
quantity is evaluated on a whole grid of positions and many w, for which the pricer's per-point
search would be too slow, with the work that does not depend on w done once.

**The frontier, once.** With independent phases each side aligns to its user, so user k's
amplitude is A_k = a_D^k + sum_m u_m^k a_m^k (``star``'s notation, unit elements, side factor 1
on either side: :func:`~ios_uav_env.model.star.unit_amplitudes`; which user reflects does not
enter). The reachable (A_0, A_1) form a convex set whose Pareto frontier is traced by
u_m = (cos phi a_m^0, sin phi a_m^1) / norm, phi in [0, pi/2] (``star_frontier.frontier_point``
with w = sin phi / (sin phi + cos phi)), A_0 nonincreasing and A_1 nondecreasing in phi
(``star_slot``'s derivation). :func:`frontier_maps` evaluates the frontier at ``points`` angles
phi_0 = 0 < ... < phi_{V-1} = pi/2, equally spaced, for every position: a table independent of w.

**Each w, from the table.** F_w(A_0, A_1) = max over the power split of w_0 R_0 + w_1 R_1
(``regions.weighted_noma_array``) is nondecreasing in both amplitudes (the degraded broadcast
channel's region grows with either SNR), so :meth:`FrontierMaps.weighted_sum` returns per position

- ``value`` = max_i F_w(A(phi_i)): the weighted sum of a setting of the surface and a split, so
  value <= f_w(q), with that setting's rates ``rates`` (w . rates = value);
- ``upper`` = max_i F_w(A_0(phi_i), A_1(phi_{i+1})) >= f_w(q): every frontier point with an angle
  in [phi_i, phi_{i+1}] has A_0 <= A_0(phi_i) and A_1 <= A_1(phi_{i+1}), and f_w is reached on the
  frontier (``star_frontier.es_frontier_bb``'s box bound, on a fixed partition).

The gap upper - value is first order in the angle step; the value itself is a maximum over a
grid of a smooth function of phi, off by a second-order amount (tested against the pricer).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.regions import weighted_noma_array
from ios_uav_env.model.star import unit_amplitudes

__all__ = ["FRONTIER_POINTS", "FrontierMaps", "frontier_maps"]

#: Frontier angles of :func:`frontier_maps` by default.
FRONTIER_POINTS = 65
_CHUNK = 1 << 22  # positions x angles x elements per block of the frontier's sums


@dataclass(frozen=True, eq=False)
class FrontierMaps:
    """The ES frontier of every position (module docstring): ``amps`` (2, P, V), user k's amplitude
    A_k at angle ``angles[i]`` (rad) of position p; ``eta`` the transmit SNR P / sigma^2."""

    amps: np.ndarray
    angles: np.ndarray
    eta: float

    @property
    def full_snr(self) -> np.ndarray:
        """(2, P): each user's SNR with the whole surface on its side, eta (a_D + sum_m a_m)^2."""
        return self.eta * np.stack([self.amps[0, :, 0], self.amps[1, :, -1]]) ** 2

    def weighted_sum(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(value (P,), upper (P,), rates (2, P)) of f_w at every position, w = (w_0, w_1) >= 0
        summing to 1 (module docstring: value <= f_w <= upper, w . rates = value)."""
        w = np.asarray(w, dtype=float)
        if w.shape != (2,) or not np.all(np.isfinite(w)) or np.any(w < 0) or abs(w.sum() - 1) > 1e-9:
            raise ValueError(f"w must be two weights >= 0 summing to 1, got {w!r}")
        g = self.eta * self.amps**2
        value, r_0, r_1 = weighted_noma_array(g[0], g[1], w[0])  # (P, V)
        best = np.argmax(value, axis=1)
        rows = np.arange(value.shape[0])
        upper = weighted_noma_array(g[0][:, :-1], g[1][:, 1:], w[0])[0].max(axis=1)
        top = value[rows, best]
        return top, np.maximum(upper, top), np.stack([r_0[rows, best], r_1[rows, best]])


def frontier_maps(
    config: ScenarioConfig, positions: np.ndarray, users: np.ndarray, points: int = FRONTIER_POINTS
) -> FrontierMaps:
    """The :class:`FrontierMaps` of the UAV at ``positions`` (P, 2) m (altitude
    ``config.uav_altitude``) and the two ``users`` (2, 2) m, one on each side of the surface plane,
    over ``points`` >= 2 frontier angles; ``config``'s surface grid and radio are used."""
    q = np.asarray(positions, dtype=float)
    u = np.asarray(users, dtype=float)
    if q.ndim != 2 or q.shape[1] != 2 or not np.all(np.isfinite(q)):
        raise ValueError(f"positions must be a finite (P, 2) array in m, got shape {q.shape}")
    if u.shape != (2, 2) or not np.all(np.isfinite(u)):
        raise ValueError(f"users must be two finite (x, y) points in m, shape (2, 2), got {u.shape}")
    x_c = config.ios_center[0]
    if (u[0, 0] - x_c) * (u[1, 0] - x_c) >= 0:
        raise ValueError(
            f"users must lie on opposite sides of the surface plane x = {x_c:g} m (off it), got x = "
            f"{u[0, 0]:g} and {u[1, 0]:g} m"
        )
    if isinstance(points, bool) or not isinstance(points, (int, np.integer)) or points < 2:
        raise ValueError(f"points (frontier angles) must be an integer >= 2, got {points!r}")
    angles = np.linspace(0.0, np.pi / 2, int(points))
    cos, sin = np.cos(angles), np.sin(angles)
    amps = np.empty((2, len(q), len(angles)))
    step = max(1, _CHUNK // (len(angles) * config.M))
    for start in range(0, len(q), step):
        block = slice(start, start + step)
        (a_0, d_0), (a_1, d_1) = (unit_amplitudes(config, q[block], tuple(user)) for user in u)
        s_0, s_1 = a_0 * a_0, a_1 * a_1  # (B, M)
        # u_m = (cos a_0, sin a_1) / norm, so A_0 = a_D^0 + cos sum_m a_0^2 / norm (A_1 alike); an
        # element with a_0 = a_1 = 0 adds nothing to either sum
        norm = np.sqrt(cos[None, :, None] ** 2 * s_0[:, None, :] + sin[None, :, None] ** 2 * s_1[:, None, :])
        inv = np.divide(1.0, norm, out=np.zeros_like(norm), where=norm > 0)  # (B, V, M)
        amps[0, block] = d_0[:, None] + cos * np.matmul(inv, s_0[:, :, None])[..., 0]
        amps[1, block] = d_1[:, None] + sin * np.matmul(inv, s_1[:, :, None])[..., 0]
    return FrontierMaps(amps, angles, float(config.eta))
