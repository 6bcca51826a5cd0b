"""The UAV's antenna array: a uniform linear array (ULA) of N_t antennas and its far-field response.

The array lies in the horizontal plane at the UAV's altitude z_U, centred on the UAV's position
q = (x, y, z_U), along the unit axis u = (cos phi, sin phi, 0) (``orientation_rad`` phi, from the
x axis towards y). Antenna n (n = 0, ..., N_t - 1) sits at q + delta_n d u with the centred index
delta_n = n - (N_t - 1) / 2 and the spacing d = ``spacing_wl`` lambda. One antenna (N_t = 1) is the
single-antenna UAV of the paper, at q itself.

**Far field per link.** A link from the UAV to a point p (a surface element, the surface's centre
or a ground node) leaves along the unit direction e = (p - q) / |p - q|; with psi the angle between
the array axis and e, cos psi = u . e. The array aperture (N_t - 1) d is a few wavelengths, far
smaller than any link (tens of metres or more), so antenna n's path is longer than the centre's by
-delta_n d cos psi, and in the channel's convention exp(-j 2 pi d / lambda) of
:mod:`ios_uav_env.model.channel` the link's per-antenna factor is the steering vector

    a(psi)_n = exp(j 2 pi (d / lambda) delta_n cos psi),   n = 0, ..., N_t - 1,

with |a(psi)_n| = 1, so ||a(psi)|| = sqrt(N_t): all ones at broadside (cos psi = 0),
alternating signs (exp(j pi delta_n) up to a common phase) at endfire for d = lambda / 2. The
centred index makes N_t = 1 exactly a = (1,), the paper's channel.

**The UAV-surface link.** ``steering="centre"`` (the default) treats the surface as one far-field
link, at the angle of its centre: every element's path then shares the steering vector
a(psi_c), and the UAV-surface channel is rank one (the LoS model of Wu & Zhang, IEEE TWC 2019,
under which the single-user optimum is closed form, :mod:`ios_uav_env.model.miso`).
``steering="element"`` uses each element's own angle psi_m, the exact far-field response of
every antenna-element pair: closer physics for a surface that subtends more than the array's
beamwidth (about 2 / N_t rad), and the UAV-surface channel is no longer rank one.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any

import numpy as np

#: How the UAV-surface link is steered (:class:`ArrayConfig` ``steering``).
STEERINGS: tuple[str, ...] = ("centre", "element")
#: The largest array this model accepts (the far-field assumption wants a small aperture).
MAX_ANTENNAS = 64
#: The widest spacing accepted, in wavelengths.
MAX_SPACING_WL = 4.0


def _is_real(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


@dataclass(frozen=True)
class ArrayConfig:
    """The UAV's ULA: N_t antennas, their spacing and the array's axis (see the module docstring).

    The total transmit power P is the scenario's ``ScenarioConfig.power_w`` (shared by all
    beams), the noise sigma^2 its ``noise_dbm``; the array adds no gain of its own beyond N_t.
    """

    n_t: int = 1  # N_t, number of antennas (1: the paper's single-antenna UAV)
    spacing_wl: float = 0.5  # d / lambda, antenna spacing in wavelengths (lambda/2)
    orientation_rad: float = 0.0  # rad, phi: the array axis u = (cos phi, sin phi, 0), horizontal
    steering: str = "centre"  # UAV-surface link: "centre" (one angle, rank one) or "element"

    def __post_init__(self) -> None:
        n = self.n_t
        if not (isinstance(n, numbers.Integral) and not isinstance(n, bool) and 1 <= n <= MAX_ANTENNAS):
            raise ValueError(f"n_t must be an integer in [1, {MAX_ANTENNAS}] (antennas N_t), got {n!r}")
        s = self.spacing_wl
        if not (_is_real(s) and math.isfinite(s) and 0 < s <= MAX_SPACING_WL):
            raise ValueError(
                f"spacing_wl must be a number in (0, {MAX_SPACING_WL:g}] (wavelengths, d / lambda), got {s!r}"
            )
        phi = self.orientation_rad
        if not (_is_real(phi) and math.isfinite(phi)):
            raise ValueError(f"orientation_rad must be a finite number (rad, phi), got {phi!r}")
        if self.steering not in STEERINGS:
            raise ValueError(f"steering must be one of {STEERINGS}, got {self.steering!r}")
        object.__setattr__(self, "n_t", int(n))
        object.__setattr__(self, "spacing_wl", float(s))
        object.__setattr__(self, "orientation_rad", float(phi))

    @property
    def axis(self) -> np.ndarray:
        """The array's unit axis u = (cos phi, sin phi, 0), shape (3,)."""
        return np.array([math.cos(self.orientation_rad), math.sin(self.orientation_rad), 0.0])

    @property
    def offsets(self) -> np.ndarray:
        """Centred antenna positions along u in wavelengths, delta_n d / lambda, shape (N_t,)."""
        return (np.arange(self.n_t) - 0.5 * (self.n_t - 1)) * self.spacing_wl


def scenario_array(config: Any) -> ArrayConfig:
    """The UAV's array of a scenario (a ``ScenarioConfig``): ``config.antennas`` antennas at this
    class's defaults (lambda / 2 apart, along the x axis, the surface steered at its centre), the
    array of every rate of ``ios_uav_env.model.channel`` and of the env."""
    return ArrayConfig(n_t=config.antennas)


def steering_vector(array: ArrayConfig, cos_psi: np.ndarray) -> np.ndarray:
    """a(psi) = exp(j 2 pi (d / lambda) delta_n cos psi) for each cos psi, shape (..., N_t).

    ``cos_psi``: the cosine of the angle between the array axis and each link (any shape, values
    in [-1, 1]; 0 broadside, +-1 endfire)."""
    c = np.asarray(cos_psi, dtype=float)
    if not np.all(np.isfinite(c)) or np.any(np.abs(c) > 1.0 + 1e-12):
        raise ValueError(
            "cos_psi must be finite and in [-1, 1] (the cosine of a link's angle to the array axis)"
        )
    return np.exp(2j * np.pi * c[..., None] * array.offsets)


def link_cosines(array: ArrayConfig, origin: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """cos psi = u . (p - o) / |p - o| of the links from ``origin`` o (3,) to each of the (..., 3)
    ``targets`` p (m), shape (...). A target at the origin has no direction: ``ValueError``."""
    diff = np.asarray(targets, dtype=float) - np.asarray(origin, dtype=float)
    dist = np.linalg.norm(diff, axis=-1)
    if np.any(dist <= 0):
        raise ValueError("a link's target coincides with the array's centre: its angle is undefined")
    return (diff @ array.axis) / dist


def link_response(array: ArrayConfig, origin: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """The steering vectors of the links from ``origin`` (3,) to the (..., 3) ``targets``, shape
    (..., N_t): :func:`steering_vector` of :func:`link_cosines`."""
    return steering_vector(array, np.clip(link_cosines(array, origin, targets), -1.0, 1.0))
