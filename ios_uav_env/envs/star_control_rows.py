"""The STAR control's action and observation over rows: what the single env (one row) and its
batched form (B rows) both call, so a row of the batch is the single env's step bit for bit.

:class:`ControlMap` maps actions (B, A) and the slots' channels (``model.star_rows.StarRows``,
(B, M)) to settings of ``star_slot.evaluate_rows`` (the action table is
``STARControlEnv``'s docstring) and to observations, and back (:meth:`ControlMap.actions_of`).

**Controls** (``CONTROLS``). ``"direct"``: the action is the setting (theta = pi a, the TDMA share
tau = (a + 1) / 2). ``"residual"``: the action is an offset to the closed form of the slot, so that
a zero action is the aligned surface: theta_m^s = phi_m^s + pi a_k (element m of group k;
phi^s the phases that line every element up with user s, each side's optimum with continuous
phases) and, under TDMA, tau = tau* + a / 2 clipped to [0, 1], tau* = c_t / (c_r + c_t) the
aligned sides' max-min share. Under TDMA with continuous phases a zero action is the slot's
optimum; with b bits it is the aligned phases rounded to the grid (the policy learns the grid's
correction); under NOMA it sets the aligned phases, the amplitude split and power split staying
direct (their optimum has no closed form). The observation is the same under both controls.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ios_uav_env.model.star import quantise
from ios_uav_env.model.star_rows import StarRows, rates_of, tdma_maxmin_rows

#: The values of the ``control`` keyword.
CONTROLS = ("direct", "residual")


def unphase(theta: Any) -> np.ndarray:
    """theta (rad) as an action in [-1, 1): the angle wrapped to [-pi, pi), / pi."""
    return (np.mod(np.asarray(theta, dtype=np.float64) + np.pi, 2 * np.pi) - np.pi) / np.pi


def aligned_rates(base: StarRows) -> tuple[np.ndarray, np.ndarray]:
    """(c_r, c_t) per row: each user's rate served alone by the whole surface, phases aligned."""
    c_r = rates_of(base.eta, base.direct_r + base.a_r.sum(axis=-1))
    c_t = rates_of(base.eta, base.direct_t + base.a_t.sum(axis=-1))
    return c_r, c_t


def aligned_share(base: StarRows) -> np.ndarray:
    """tau* per row: the TDMA max-min share of the aligned sides (continuous phases), c_t / (c_r + c_t)."""
    return tdma_maxmin_rows(*aligned_rates(base))[1]


@dataclass(frozen=True)
class ControlMap:
    """The action <-> setting and observation maps of one env's keywords (checked by the env)."""

    M: int  # elements
    group: int  # elements per group
    access: str  # "tdma" or "noma"
    protocol: str  # "es" or "ms"
    bits: int | None  # phase bits (None: continuous)
    control: str  # one of CONTROLS
    channel_phases: bool  # whether the per-group channel phases are observed

    @property
    def G(self) -> int:
        return self.M // self.group

    @property
    def width(self) -> int:
        """A: the action's length."""
        return 2 * self.G + 1 if self.access == "tdma" else 3 * self.G + 1

    def _grow(self, a: np.ndarray) -> np.ndarray:
        """(B, G) per group -> (B, M) per element (group k: elements k group ... (k + 1) group - 1)."""
        return np.repeat(a, self.group, axis=-1)

    def settings(self, actions: np.ndarray, base: StarRows) -> dict[str, np.ndarray]:
        """The settings of ``actions`` ((B, A), float64, finite) at the slots ``base`` ((B, M)):
        ``evaluate_rows``' keys, phases quantised. Actions are clipped to [-1, 1]."""
        a = np.clip(actions, -1.0, 1.0)
        G = self.G
        offset_r = offset_t = 0.0
        if self.control == "residual":
            offset_r, offset_t = base.phi_r, base.phi_t
        theta_r = quantise(offset_r + np.pi * self._grow(a[:, :G]), self.bits)
        theta_t = quantise(offset_t + np.pi * self._grow(a[:, G : 2 * G]), self.bits)
        if self.access == "tdma":
            ones = np.ones(theta_r.shape)
            if self.control == "residual":
                share = np.clip(aligned_share(base) + a[:, 2 * G] / 2, 0.0, 1.0)
            else:
                share = (a[:, 2 * G] + 1) / 2
            return dict(u_r=ones, u_t=ones.copy(), theta_r=theta_r, theta_t=theta_t, share=share)
        if self.protocol == "es":
            gamma = self._grow((a[:, 2 * G : 3 * G] + 1) * (np.pi / 4))
            u_r, u_t = np.cos(gamma), np.sin(gamma)
        else:
            u_t = self._grow(a[:, 2 * G : 3 * G] > 0).astype(np.float64)
            u_r = 1.0 - u_t
        return dict(u_r=u_r, u_t=u_t, theta_r=theta_r, theta_t=theta_t, split=(a[:, 3 * G] + 1) / 2)

    def actions_of(self, setting: dict[str, Any], base: StarRows) -> np.ndarray:
        """The actions (B, A) that give ``setting`` (arrays over the B rows of ``base``; one value
        per group: its first element's), the inverse of :meth:`settings` on the settings it can
        express (e.g. ``slot_optimum``'s at group 1)."""
        pick = (Ellipsis, slice(None, None, self.group))
        theta_r, theta_t = (np.asarray(setting[k], dtype=np.float64) for k in ("theta_r", "theta_t"))
        if self.control == "residual":
            theta_r, theta_t = theta_r - base.phi_r, theta_t - base.phi_t
        parts = [unphase(theta_r[pick]), unphase(theta_t[pick])]
        if self.access == "tdma":
            share = np.asarray(setting["share"], dtype=np.float64)
            a = 2 * (share - aligned_share(base)) if self.control == "residual" else 2 * share - 1
            parts.append(a[..., None])
        else:
            u_r, u_t = np.asarray(setting["u_r"])[pick], np.asarray(setting["u_t"])[pick]
            if self.protocol == "es":
                parts.append(np.arctan2(u_t, u_r) * (4 / np.pi) - 1)
            else:
                parts.append(np.where(u_t > 0.5, 1.0, -1.0))
            parts.append(2 * np.asarray(setting["split"], dtype=np.float64)[..., None] - 1)
        return np.clip(np.concatenate(parts, axis=-1), -1.0, 1.0)

    def observations(self, base: StarRows, head: np.ndarray) -> np.ndarray:
        """The observations (B, 8 [+ 2G]) float32 at the slots ``base`` ((B, M)): ``head`` (B, 7)
        (the UAV position, the users, the slot index, scaled), user r's share c_r / (c_r + c_t)
        of the aligned sides' rates (1/2 where both are 0) and the per-group channel phases
        (``STARControlEnv``'s docstring)."""
        c_r, c_t = aligned_rates(base)
        total = c_r + c_t
        share_r = np.divide(c_r, total, out=np.full_like(total, 0.5), where=total > 0)
        parts = [head, share_r[:, None]]
        if self.channel_phases:
            for a, phi in ((base.a_r, base.phi_r), (base.a_t, base.phi_t)):
                summed = (a * np.exp(1j * phi)).reshape(head.shape[0], self.G, self.group).sum(axis=-1)
                parts.append(unphase(np.angle(summed)))
        return np.clip(np.concatenate(parts, axis=-1), -1.0, 1.0).astype(np.float32)
