"""Propulsion power of a rotary-wing UAV: the physics of a plan's energy.

The model is eq. (12) of Zeng, Xu and Zhang, "Energy Minimization for Wireless Communication
With Rotary-Wing UAV", IEEE TWC 18(4), 2019, with the acceleration neglected as there: at
horizontal speed V (m/s) the UAV draws

    P(V) = P0 (1 + 3 V^2 / U_tip^2)                                   blade profile
         + P_i (sqrt(1 + V^4 / (4 v0^4)) - V^2 / (2 v0^2))^(1/2)       induced
         + (1/2) d0 rho s A V^3                                        parasite (fuselage drag)

watts, so P(0) = P0 + P_i (hover). The induced term is evaluated in the cancellation-free
form P_i / (sqrt(1 + x^2) + x)^(1/2), x = V^2 / (2 v0^2) (the same value: multiply
sqrt(1 + x^2) - x by its conjugate).

For the Table I constants (the defaults of :class:`PropulsionModel`) P falls from hover, has
its minimum at the *minimum-power speed* V_mp (the speed of the longest endurance) and rises
again; P(V) / V, the energy per metre, has its minimum at the *maximum-range speed* V_mr > V_mp.
Both are found by :func:`min_power_speed` and :func:`max_range_speed`, a golden-section search
on [0, U_tip] (the model describes speeds well below the blade tip speed) to 1e-10 m/s. The
search assumes each function is unimodal there, as it is for physical constants (tested for
the defaults).

This module knows nothing of a scenario: the energy of a trajectory, E = dt sum P(|move| / dt),
is :func:`ios_uav_env.energy` (``model.trajectory``), its bits per joule
:func:`ios_uav_env.energy_efficiency` (``model.score``).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

#: Golden-section tolerance (m/s) of :func:`min_power_speed` and :func:`max_range_speed`.
SPEED_TOL = 1e-10


@dataclass(frozen=True)
class PropulsionModel:
    """The constants of the rotary-wing power model (defaults: Zeng, Xu, Zhang 2019, Table I).

    Every field must be a finite number > 0 (``ValueError`` naming the field otherwise).
    """

    P0: float = 79.8563  # W, blade profile power in hover P_0
    P_i: float = 88.6279  # W, induced power in hover P_i
    U_tip: float = 120.0  # m/s, tip speed of the rotor blade U_tip
    v0: float = 4.03  # m/s, mean rotor induced velocity in hover v_0
    d0: float = 0.6  # fuselage drag ratio d_0 (dimensionless)
    rho: float = 1.225  # kg/m^3, air density rho
    s: float = 0.05  # rotor solidity s (dimensionless)
    A: float = 0.503  # m^2, rotor disc area A

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
            if not (ok and math.isfinite(value) and value > 0):
                raise ValueError(f"PropulsionModel.{f.name} must be a finite number > 0, got {value!r}")
            object.__setattr__(self, f.name, float(value))  # plain floats: hashing, equality, JSON

    @property
    def hover_power(self) -> float:
        """P(0) = P0 + P_i (W)."""
        return self.P0 + self.P_i

    @property
    def drag_coefficient(self) -> float:
        """(1/2) d0 rho s A (kg/m): the parasite power is this times V^3."""
        return 0.5 * self.d0 * self.rho * self.s * self.A

    def to_dict(self) -> dict[str, float]:
        """Plain-JSON dictionary of the constants (round-trips through ``PropulsionModel(**d)``)."""
        return dataclasses.asdict(self)


#: The Table I constants.
DEFAULT_PROPULSION = PropulsionModel()


def propulsion_power(speed: Any, model: PropulsionModel = DEFAULT_PROPULSION) -> Any:
    """Propulsion power P(V) (W) of eq. (12) at horizontal speed ``speed`` (m/s, >= 0).

    Vectorised: an array of speeds gives an array of powers, a number a float. ``ValueError``
    for a negative or non-finite speed.
    """
    v = np.asarray(speed, dtype=np.float64)
    if not np.all(np.isfinite(v)) or np.any(v < 0):
        raise ValueError(f"speed must be finite and >= 0 (m/s), got {speed!r}")
    v2 = v * v
    x = v2 / (2.0 * model.v0**2)
    blade = model.P0 * (1.0 + 3.0 * v2 / model.U_tip**2)
    induced = model.P_i / np.sqrt(np.sqrt(1.0 + x * x) + x)
    parasite = model.drag_coefficient * v2 * v
    power = blade + induced + parasite
    return float(power) if power.ndim == 0 else power


def _golden_section(f: Callable[[float], float], lo: float, hi: float, tol: float = SPEED_TOL) -> float:
    """The minimiser of a unimodal ``f`` on [lo, hi], to ``tol``, by golden-section search."""
    inv_phi = (math.sqrt(5.0) - 1.0) / 2.0
    a, b = lo, hi
    c, d = b - inv_phi * (b - a), a + inv_phi * (b - a)
    fc, fd = f(c), f(d)
    while b - a > tol:
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - inv_phi * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + inv_phi * (b - a)
            fd = f(d)
    return 0.5 * (a + b)


@lru_cache(maxsize=64)
def min_power_speed(model: PropulsionModel = DEFAULT_PROPULSION) -> float:
    """The minimum-power speed V_mp = argmin_V P(V) (m/s), V in [0, U_tip] (module docstring)."""
    return _golden_section(lambda v: propulsion_power(v, model), 0.0, model.U_tip)


@lru_cache(maxsize=64)
def max_range_speed(model: PropulsionModel = DEFAULT_PROPULSION) -> float:
    """The maximum-range speed V_mr = argmin_V P(V) / V (m/s, the least energy per metre), V in
    (0, U_tip] (module docstring)."""
    return _golden_section(lambda v: propulsion_power(v, model) / v, 1e-9 * model.U_tip, model.U_tip)


def flight_energy(trajectory: np.ndarray, dt: float, model: PropulsionModel = DEFAULT_PROPULSION) -> Any:
    """E = dt sum_{n=1}^{N-1} P(|q[n+1] - q[n]| / dt) (J): each move flown at constant speed over
    one slot of ``dt`` s. ``trajectory`` (N, 2) m, or a batch (B, N, 2) (then E is (B,))."""
    q = np.asarray(trajectory, dtype=np.float64)
    speeds = np.linalg.norm(np.diff(q, axis=-2), axis=-1) / dt
    total = dt * np.sum(propulsion_power(speeds, model), axis=-1)
    return float(total) if np.ndim(total) == 0 else total


def least_energy_speed(distance: float, moves: int, dt: float, v_max: float, model: PropulsionModel) -> float:
    """The speed (m/s) of the least-energy flight of ``moves`` constant-speed moves of ``dt`` s
    covering at least ``distance`` m at no more than ``v_max``: clip(V_mp, distance / (moves dt),
    v_max) (``ScenarioConfig.least_energy``)."""
    needed = distance / (moves * dt)
    return min(max(min_power_speed(model), needed), max(v_max, needed))
