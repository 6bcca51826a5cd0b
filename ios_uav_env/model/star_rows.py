"""The STAR slot's arithmetic over rows: several slots' channels as arrays, one call for all.

The scalar functions of ``ios_uav_env.model.star`` (:func:`~ios_uav_env.model.star.side_amplitude`,
:func:`~ios_uav_env.model.star.best_discrete_phases`, :func:`~ios_uav_env.model.star.tdma_maxmin`)
and the TDMA cases of ``star_slot`` (``evaluate``, ``slot_optimum``) are these functions on one
row, so a row of a batch and the same slot computed alone are the same arithmetic: every
function here works along the last axis (the M elements) and treats the leading axes as
independent rows (no reduction mixes two rows).

:class:`StarRows` holds the :class:`~ios_uav_env.model.star.StarChannels` of several slots
stacked: the element arrays with shape (..., M), the scalars with shape (...). This module knows
nothing of ``star`` (which imports it): it reads ``StarChannels`` by its fields.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "StarRows", "discrete_phases", "rates_of", "side_amplitudes", "tdma_maxmin_rows", "tdma_rates_rows",
    "tdma_sides",
]  # fmt: skip

_FIELDS = ("a_r", "a_t", "phi_r", "phi_t", "direct_r", "direct_t", "eta", "fixed_r", "fixed_t")


@dataclass(frozen=True, eq=False)
class StarRows:
    """The channels of several slots (rows): ``StarChannels``' fields stacked, (..., M) and (...)."""

    a_r: np.ndarray  # (..., M) LoS amplitude via each unit element, reflection user
    a_t: np.ndarray  # (..., M) the same, transmission user
    phi_r: np.ndarray  # (..., M) rad, aligning phases of user r
    phi_t: np.ndarray  # (..., M) rad, aligning phases of user t
    direct_r: np.ndarray  # (...) direct LoS amplitude a_D^r
    direct_t: np.ndarray  # (...) direct LoS amplitude a_D^t
    eta: np.ndarray  # (...) transmit SNR P / sigma^2
    fixed_r: np.ndarray  # (...) the configured surface's reflection amplitude
    fixed_t: np.ndarray  # (...) its transmission amplitude

    @classmethod
    def of(cls, channels: Sequence[Any]) -> StarRows:
        """The rows of ``channels`` (``star.StarChannels``, one slot each, all of one M), in order:
        shape (len, M)."""
        sizes = {ch.M for ch in channels}
        if len(sizes) != 1:
            raise ValueError(
                f"channels must be a non-empty sequence of one surface size M, got sizes {sizes}"
            )
        return cls(
            *(np.asarray([getattr(ch, name) for ch in channels], dtype=np.float64) for name in _FIELDS)
        )

    @property
    def M(self) -> int:
        return int(self.a_r.shape[-1])

    def take(self, index: Any) -> StarRows:
        """The rows at ``index`` of the leading axes (numpy indexing: an int, a slice, an index
        array, or a tuple of them, e.g. ``(rows, slots)`` to gather one slot per row)."""
        return StarRows(*(np.asarray(getattr(self, name)[index]) for name in _FIELDS))


def side_amplitudes(amps: np.ndarray, phi: np.ndarray, direct: Any, theta: np.ndarray) -> np.ndarray:
    """|h| = |a_D + sum_m amps_m e^{j (phi_m - theta_m)}| of one side, per row (``amps`` = u^s a^s)."""
    return np.abs(direct + np.sum(amps * np.exp(1j * (phi - theta)), axis=-1))


def rates_of(eta: Any, amp: Any) -> np.ndarray:
    """log2(1 + eta |h|^2) (bps/Hz) of an amplitude |h| at transmit SNR eta, elementwise."""
    amp = np.asarray(amp, dtype=np.float64)
    return np.log2(1 + eta * amp * amp)


def tdma_rates_rows(c_r: Any, c_t: Any, share: Any) -> tuple[np.ndarray, np.ndarray]:
    """TDMA rates (share c_r, (1 - share) c_t) elementwise: user r served for a fraction ``share``
    of the slot at its rate c_r, user t for the rest at c_t (bps/Hz)."""
    share = np.asarray(share, dtype=np.float64)
    if np.any(~np.isfinite(share)) or np.any((share < 0) | (share > 1)):
        raise ValueError(f"share (the time fraction of user r) must be in [0, 1], got {share!r}")
    return share * c_r, (1 - share) * c_t


def tdma_maxmin_rows(c_r: Any, c_t: Any) -> tuple[np.ndarray, np.ndarray]:
    """Max-min TDMA rate c_r c_t / (c_r + c_t) and its share c_t / (c_r + c_t) (0 and 1/2 where
    both rates are 0), elementwise."""
    c_r, c_t = np.broadcast_arrays(np.asarray(c_r, dtype=np.float64), np.asarray(c_t, dtype=np.float64))
    total = c_r + c_t
    some = total > 0
    value = np.divide(c_r * c_t, total, out=np.zeros_like(total), where=some)
    share = np.divide(c_t, total, out=np.full_like(total, 0.5), where=some)
    return value, share


def discrete_phases(
    amps: np.ndarray, phi: np.ndarray, direct: Any, bits: int
) -> tuple[np.ndarray, np.ndarray]:
    """The b-bit phases maximising |a_D + sum_m amps_m e^{j (phi_m - theta_m)}| exactly, per row,
    and that |h| (derivation: ``star.best_discrete_phases``).

    For a direction psi of the sum, the best level of each element is the one nearest to
    phi_m - psi; the optimum's own direction psi* gives a setting at least as good as the
    optimum (|s| >= Re(s e^{-j psi*})), so scanning psi over [0, 2 pi) finds it. Element m's level
    changes at 2^b breakpoints of psi, each change a known increment of the sum: the M 2^b
    breakpoints sorted and the increments summed in order visit every candidate (O(M 2^b log)).
    """
    amps = np.asarray(amps, dtype=float)
    phi = np.mod(np.asarray(phi, dtype=float), 2 * np.pi)
    amps, phi = np.broadcast_arrays(amps, phi)
    lead, m = amps.shape[:-1], amps.shape[-1]
    direct = np.broadcast_to(np.asarray(direct, dtype=float), lead)
    levels = 2**bits
    step = 2 * np.pi / levels
    l0 = np.round(phi / step)  # the levels at psi = 0
    t0 = amps * np.exp(1j * (phi - l0 * step))
    s0 = direct + t0.sum(axis=-1)
    first = phi - l0 * step + step / 2  # in [0, step]: the first breakpoint of each element
    k = np.arange(levels)
    psi = (first[..., None] + k * step).reshape(*lead, m * levels)
    delta = (t0[..., None] * np.exp(1j * k * step) * (np.exp(1j * step) - 1)).reshape(*lead, m * levels)
    order = np.argsort(psi, axis=-1, kind="stable")
    steps = np.cumsum(np.take_along_axis(delta, order, axis=-1), axis=-1)
    sums = s0[..., None] + np.concatenate([np.zeros((*lead, 1)), steps], axis=-1)
    best = np.argmax(np.abs(sums), axis=-1)  # candidate best: the first `best` breakpoints applied
    applied = np.arange(m * levels) < best[..., None]
    rows = np.broadcast_to(np.arange(int(np.prod(lead)))[:, None], (int(np.prod(lead)), m * levels))
    changes = np.zeros((int(np.prod(lead)), m), dtype=np.int64)  # level decrements per element
    flat = applied.reshape(-1, m * levels)
    np.add.at(changes, (rows[flat], (order.reshape(-1, m * levels) // levels)[flat]), 1)
    theta = np.mod(l0 - changes.reshape(*lead, m), levels) * step
    return theta, side_amplitudes(amps, phi, direct, theta)


def tdma_sides(rows: StarRows, protocol: str, bits: int | None) -> tuple[np.ndarray, ...]:
    """Each side served alone, per row: (amp_r, u_r, theta_r, amp_t, u_t, theta_t), the whole
    surface on the side (u = 1; the configured split with protocol ``"fixed"``), its phases
    aligned (theta = phi: amplitude a_D + sum_m u_m a_m) or, with ``bits``, its exact b-bit ones."""
    out: list[np.ndarray] = []
    for a, phi, direct, fixed in (
        (rows.a_r, rows.phi_r, rows.direct_r, rows.fixed_r),
        (rows.a_t, rows.phi_t, rows.direct_t, rows.fixed_t),
    ):
        if protocol == "fixed":
            u = np.broadcast_to(np.asarray(fixed)[..., None], a.shape).copy()
        else:
            u = np.ones_like(a)
        amps = u * a
        if bits is None:
            amp, theta = direct + amps.sum(axis=-1), phi.copy()
        else:
            theta, amp = discrete_phases(amps, phi, direct, bits)
        out += [np.asarray(amp, dtype=np.float64), u, theta]
    return tuple(out)
