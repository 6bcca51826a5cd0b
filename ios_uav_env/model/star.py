"""STAR surfaces: the IOS generalised to simultaneously transmitting and reflecting elements.

The model of Mu, Liu, Guo, Zhu, Wang and Ding, *Simultaneously transmitting and reflecting (STAR)
RIS aided wireless communications* (IEEE Trans. Wireless Commun. 21(5), 2022), on the geometry of
the paper's IOS (``ios_uav_env.model.channel``). Element m has a reflection coefficient
sqrt(beta_m^r) e^{j theta_m^r} and a transmission coefficient sqrt(beta_m^t) e^{j theta_m^t}; we
write u_m^s = sqrt(beta_m^s) for the amplitudes. One UAV at q serves two ground users: user r on
the UAV's side of the surface plane (reflection) and user t on the other side (transmission).

**Channel.** With a_m^s the LoS amplitude via element m of a unit element (side factor 1:
``channel.element_amplitudes`` of user s with the transmissive pattern factor set to 1), a_D^s
the direct amplitude and phi_m^s = 2 pi / lambda (d_UG^s - d_Um - d_mG^s) the phase that lines
element m up with the direct path (``channel.phase_shifts``, eq. (13)), the LoS channel of user s
is, up to a common phase e^{-j 2 pi d_UG^s / lambda},

    h_s = a_D^s + sum_m u_m^s a_m^s e^{j (phi_m^s - theta_m^s)},        (|h_s| = |los_channel|)

and its SNR at full power g_s = eta |h_s|^2 (the paper's expected-gain rate uses |h|^2 = zeta^2,
the value at the aligned phases theta^s = phi^s).

**Protocols** (``PROTOCOLS``): energy splitting ``"es"`` ((u^r)^2 + (u^t)^2 <= 1 per element),
mode switching ``"ms"`` ((u^r, u^t) in {(1, 0), (0, 1)}), time switching ``"ts"`` (every element
transmits for a fraction lam of the slot and reflects for the rest) and ``"fixed"``: the
configured surface's own split, (u^r, u^t) = (1, s_t) with s_t = ``config.transmit_factor``
(epsilon for the IOS, eq. (2): the paper's pattern factor enters the amplitude linearly, eq. (6),
and is not energy-normalised; 0 for a RIS), (0, 0) without a surface. **Phase models**
(``PHASE_MODELS``): ``"independent"`` (theta^t, theta^r free), ``"coupled"`` (theta_m^t -
theta_m^r = +-pi/2 per element: Liu, Mu, Schober and Poor, *Simultaneously transmitting and
reflecting (STAR)-RISs: a coupled phase-shift model*, IEEE ICC 2022) and ``"shared"``
(theta^t = theta^r, the paper's IOS). **Discrete phases**: ``bits`` = b, theta in {0, 2 pi / 2^b,
...}; None for continuous phases.

**Access** (``ACCESS``): ``"tdma"`` gives user r a share tau of the slot and user t the rest, the
surface set for the served user in each part (as the paper's IOS is for its one node);
``"noma"`` serves both at once with one surface setting and superposition coding: user r gets a
fraction p of the power, and the user with the larger g decodes and removes the other's signal
(SIC). The paper's IOS is the ``"fixed"``/``"shared"``/TDMA case: :func:`fixed_tdma_rates`
equals ``channel.slot_rates`` at each user. The per-slot optima are in
``ios_uav_env.model.star_slot``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ios_uav_env.model import channel
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.star_rows import (
    discrete_phases,
    side_amplitudes,
    tdma_maxmin_rows,
    tdma_rates_rows,
)

PROTOCOLS = ("es", "ms", "ts", "fixed")
PHASE_MODELS = ("independent", "coupled", "shared")
ACCESS = ("tdma", "noma")
OBJECTIVES = ("maxmin", "sum")
#: Most phase bits: the exact discrete search (:func:`best_discrete_phases`) sorts M 2^b angles.
MAX_BITS = 8
#: Slack of the coefficient checks (energy split, coupling, the phase grid), in absolute units.
CHECK_TOL = 1e-9


@dataclass(frozen=True)
class StarSurface:
    """One member of the STAR family: a protocol, a phase model and a phase resolution."""

    protocol: str = "es"  # one of PROTOCOLS
    phases: str = "independent"  # one of PHASE_MODELS
    bits: int | None = None  # phase bits b in [1, MAX_BITS]; None: continuous phases

    def __post_init__(self) -> None:
        if self.protocol not in PROTOCOLS:
            raise ValueError(f"protocol must be one of {PROTOCOLS}, got {self.protocol!r}")
        if self.phases not in PHASE_MODELS:
            raise ValueError(f"phases must be one of {PHASE_MODELS}, got {self.phases!r}")
        if self.bits is not None and (
            isinstance(self.bits, (bool, np.bool_))
            or not isinstance(self.bits, (int, np.integer))
            or not 1 <= self.bits <= MAX_BITS
        ):
            raise ValueError(
                f"bits must be None (continuous) or an integer in [1, {MAX_BITS}], got {self.bits!r}"
            )
        if self.protocol == "fixed" and self.phases != "shared":
            raise ValueError(
                f"phases must be 'shared' with protocol='fixed' (the paper's IOS), got {self.phases!r}"
            )
        if self.phases == "coupled" and self.bits == 1:
            raise ValueError(
                "bits must be >= 2 with phases='coupled' (+-pi/2 is not on the 1-bit grid {0, pi}), got 1"
            )


@dataclass(frozen=True, eq=False)
class StarChannels:
    """The two users' per-element channels at one UAV position (see the module docstring)."""

    a_r: np.ndarray  # (M,) LoS amplitude via each unit element, reflection user
    a_t: np.ndarray  # (M,) the same, transmission user
    phi_r: np.ndarray  # (M,) rad, aligning phases of user r, in [0, 2 pi)
    phi_t: np.ndarray  # (M,) rad, aligning phases of user t
    direct_r: float  # direct LoS amplitude a_D^r
    direct_t: float  # direct LoS amplitude a_D^t
    eta: float  # transmit SNR P / sigma^2
    fixed_r: float  # the configured surface's reflection amplitude (1, or 0 without a surface)
    fixed_t: float  # its transmission amplitude (config.transmit_factor)

    @property
    def M(self) -> int:
        return int(self.a_r.size)


def _point(value: object, name: str) -> tuple[float, float]:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (2,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be a finite horizontal (x, y) pair in m, got {value!r}")
    return float(arr[0]), float(arr[1])


def _unit_config(config: ScenarioConfig, user: tuple[float, float]) -> ScenarioConfig:
    """``config`` for one user with a unit transmissive factor: the element amplitudes of a unit
    element on either side (``element_amplitudes`` then has side factor 1 on both sides)."""
    return config.replace(ground_nodes=None, ground_node=user, surface="ios", epsilon=1.0)


def unit_amplitudes(
    config: ScenarioConfig, positions: np.ndarray, user: tuple[float, float]
) -> tuple[np.ndarray, np.ndarray]:
    """(a (P, M), a_D (P,)): the LoS amplitude via each unit element (side factor 1 on either side of
    the plane) and the direct amplitude of ``user`` from the UAV at each of ``positions`` (P, 2) m
    (altitude ``config.uav_altitude``), the amplitudes of :class:`StarChannels` at many positions."""
    cfg = _unit_config(config, user)
    return channel.element_amplitudes(cfg, positions), channel.direct_amplitude(cfg, positions)


def star_channels(config: ScenarioConfig, position: object, user_r: object, user_t: object) -> StarChannels:
    """The :class:`StarChannels` of a UAV at ``position`` (m, horizontal; altitude
    ``config.uav_altitude``) serving ``user_r`` on its side of the plane x = x_c and ``user_t``
    on the other; every other field of ``config`` (the surface's grid, the radio) is kept.
    :func:`path_channels` of one position."""
    return path_channels(config, [_point(position, "position")], user_r, user_t)[0]


def path_channels(
    config: ScenarioConfig, positions: object, user_r: object, user_t: object
) -> list[StarChannels]:
    """:func:`star_channels` at each of ``positions`` ((P, 2) m), the geometry computed once for
    all of them (each position's row is the same arithmetic as alone). Built from
    ``channel.element_amplitudes``, ``channel.direct_amplitude`` and ``channel.phase_shifts``: no
    second copy of the geometry."""
    pos = np.asarray(positions, dtype=float)
    if pos.ndim != 2 or pos.shape[1] != 2 or not np.all(np.isfinite(pos)):
        raise ValueError(
            f"positions must be finite horizontal (x, y) pairs in m, shape (P, 2), got {positions!r}"
        )
    ur, ut = _point(user_r, "user_r"), _point(user_t, "user_t")
    x_c = config.ios_center[0]
    if (ur[0] - x_c) * (ut[0] - x_c) >= 0:
        raise ValueError(
            f"user_r and user_t must lie on opposite sides of the surface plane x = {x_c:g} m (off it), "
            f"got x = {ur[0]:g} and {ut[0]:g} m"
        )
    for x in pos[:, 0]:
        if (x - x_c) * (ur[0] - x_c) < 0:
            raise ValueError(
                f"user_r must be on the UAV's side of the plane x = {x_c:g} m (the reflection side), got "
                f"user_r x = {ur[0]:g} m with the UAV at x = {x:g} m (swap the users)"
            )
    per_user = []
    for user in (ur, ut):
        amps, direct = unit_amplitudes(config, pos, user)
        per_user.append((amps, channel.phase_shifts(_unit_config(config, user), pos), direct))
    (a_r, phi_r, d_r), (a_t, phi_t, d_t) = per_user
    fixed_r = 0.0 if config.surface == "none" else 1.0
    return [
        StarChannels(
            a_r[i],
            a_t[i],
            phi_r[i],
            phi_t[i],
            float(d_r[i]),
            float(d_t[i]),
            config.eta,
            fixed_r=fixed_r,
            fixed_t=config.transmit_factor,
        )  # fmt: skip
        for i in range(pos.shape[0])
    ]


def side_amplitude(amps: np.ndarray, phi: np.ndarray, direct: float, theta: np.ndarray) -> float:
    """|h| = |a_D + sum_m amps_m e^{j (phi_m - theta_m)}| of one side (``amps`` = u^s a^s):
    ``star_rows.side_amplitudes`` on one row."""
    return float(side_amplitudes(amps, phi, direct, theta))


def phase_grid(bits: int) -> np.ndarray:
    """The 2^b phase levels {0, 2 pi / 2^b, ...} of b-bit elements (rad)."""
    return 2 * np.pi * np.arange(2**bits) / 2**bits


def quantise(theta: np.ndarray, bits: int | None) -> np.ndarray:
    """Each phase rounded to the nearest b-bit level, in [0, 2 pi) (unchanged mod 2 pi when bits is None)."""
    theta = np.mod(np.asarray(theta, dtype=float), 2 * np.pi)
    if bits is None:
        return theta
    levels = 2**bits
    return np.mod(np.round(theta * levels / (2 * np.pi)), levels) * (2 * np.pi / levels)


def best_discrete_phases(
    amps: np.ndarray, phi: np.ndarray, direct: float, bits: int
) -> tuple[np.ndarray, float]:
    """The b-bit phases maximising |a_D + sum_m amps_m e^{j (phi_m - theta_m)}|, exactly, and that |h|:
    ``star_rows.discrete_phases`` on one row (its docstring has the derivation: the optimum's own
    direction psi* makes every element's nearest level optimal, and the M 2^b breakpoints of psi,
    sorted, visit every candidate in O(M 2^b log))."""
    theta, amp = discrete_phases(amps, phi, direct, bits)
    return theta, float(amp)


def noma_rates(g_r: np.ndarray, g_t: np.ndarray, split: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rates (R_r, R_t) (bps/Hz) of two-user NOMA with SNRs g_s = eta |h_s|^2 and a fraction
    ``split`` = p in [0, 1] of the power to user r; the user with the larger g decodes the other's
    message first and removes it (SIC), the other treats it as noise:
    R_strong = log2(1 + p_s g_s), R_weak = log2(1 + p_w g_w / (p_s g_w + 1))."""
    g_r, g_t, p = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (g_r, g_t, split)))
    if np.any(~np.isfinite(p)) or np.any((p < 0) | (p > 1)):
        raise ValueError(f"split (the power fraction of user r) must be in [0, 1], got {split!r}")
    r_strong = g_r >= g_t
    rate_r = np.where(r_strong, np.log2(1 + p * g_r), np.log2(1 + p * g_r / ((1 - p) * g_r + 1)))
    rate_t = np.where(r_strong, np.log2(1 + (1 - p) * g_t / (p * g_t + 1)), np.log2(1 + (1 - p) * g_t))
    return rate_r, rate_t


def noma_maxmin(g_r: np.ndarray, g_t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The max-min NOMA rate of SNRs (g_r, g_t) and the split p (power fraction of user r) that
    reaches it, in closed form. With g_s >= g_w the rates are equal when the strong user's power
    fraction x solves (1 + x g_s)(1 + x g_w) = 1 + g_w, i.e. g_s g_w x^2 + (g_s + g_w) x - g_w = 0,
    x = 2 g_w / ((g_s + g_w) + sqrt((g_s + g_w)^2 + 4 g_s g_w^2)) (the stable root); the rate is
    log2(1 + x g_s). R_s grows and R_w falls with x, so the crossing is the max-min. Nondecreasing
    in each SNR (the degraded broadcast channel's region grows with either gain)."""
    g_r, g_t = np.broadcast_arrays(np.asarray(g_r, dtype=float), np.asarray(g_t, dtype=float))
    g_s, g_w = np.maximum(g_r, g_t), np.minimum(g_r, g_t)
    b = g_s + g_w
    root = np.sqrt(b * b + 4 * g_s * g_w * g_w)
    x = np.divide(2 * g_w, b + root, out=np.zeros_like(b), where=(b + root) > 0)
    return np.log2(1 + x * g_s), np.where(g_r >= g_t, x, 1 - x)


def tdma_rates(c_r: float, c_t: float, share: float) -> tuple[float, float]:
    """TDMA rates (share c_r, (1 - share) c_t): user r served for a fraction ``share`` of the slot
    at its rate c_r, user t for the rest at c_t (bps/Hz); ``star_rows.tdma_rates_rows`` of one pair."""
    if not (math.isfinite(share) and 0 <= share <= 1):
        raise ValueError(f"share (the time fraction of user r) must be in [0, 1], got {share!r}")
    rate_r, rate_t = tdma_rates_rows(c_r, c_t, share)
    return float(rate_r), float(rate_t)


def tdma_maxmin(c_r: float, c_t: float) -> tuple[float, float]:
    """Max-min TDMA rate c_r c_t / (c_r + c_t) and its share c_t / (c_r + c_t) (equal rates):
    ``star_rows.tdma_maxmin_rows`` of one pair."""
    value, share = tdma_maxmin_rows(c_r, c_t)
    return float(value), float(share)


def ts_rates(
    reflect: tuple[float, float],
    transmit: tuple[float, float],
    lam: float,
    split_reflect: float,
    split_transmit: float,
) -> tuple[float, float]:
    """Rates (R_r, R_t) of time switching with NOMA: the surface reflects for a fraction 1 - lam of
    the slot (SNRs ``reflect`` = (g_r, g_t)) and transmits for lam (``transmit``), each period a
    NOMA period with its own power split (the fraction of user r)."""
    if not (math.isfinite(lam) and 0 <= lam <= 1):
        raise ValueError(f"lam (the fraction of the slot spent transmitting) must be in [0, 1], got {lam!r}")
    r1, t1 = noma_rates(*reflect, split_reflect)
    r2, t2 = noma_rates(*transmit, split_transmit)
    return float((1 - lam) * r1 + lam * r2), float((1 - lam) * t1 + lam * t2)


def check_setting(
    surface: StarSurface, u_r: np.ndarray, u_t: np.ndarray, theta_r: np.ndarray, theta_t: np.ndarray,
    fixed: tuple[float, float] = (1.0, 0.0), simultaneous: bool = True,
) -> None:  # fmt: skip
    """Raise ``ValueError`` naming the field unless (u, theta) is a setting of ``surface``: the
    protocol's amplitudes (``fixed``: the configured split; with ``simultaneous`` False, TDMA,
    only the served side's amplitude counts, each at most 1), the phase model and the grid."""
    u_r, u_t = np.asarray(u_r, dtype=float), np.asarray(u_t, dtype=float)
    if np.any(~np.isfinite(u_r)) or np.any(~np.isfinite(u_t)) or np.any(u_r < 0) or np.any(u_t < 0):
        raise ValueError("u_r and u_t (element amplitudes sqrt(beta)) must be finite and >= 0")
    if surface.protocol == "fixed":
        if np.any(np.abs(u_r - fixed[0]) > CHECK_TOL) or np.any(np.abs(u_t - fixed[1]) > CHECK_TOL):
            raise ValueError(f"u_r, u_t must equal the configured split {fixed} with protocol='fixed'")
    elif surface.protocol == "ms" and simultaneous:
        if np.any(np.minimum(np.abs(u_r), np.abs(u_r - 1)) > CHECK_TOL) or np.any(
            np.abs(u_r + u_t - 1) > CHECK_TOL
        ):
            raise ValueError("u_r, u_t must be (1, 0) or (0, 1) per element with protocol='ms'")
    elif simultaneous and surface.protocol in ("es", "ts"):
        if np.any(u_r * u_r + u_t * u_t > 1 + CHECK_TOL):
            raise ValueError(f"u_r^2 + u_t^2 must be <= 1 per element with protocol={surface.protocol!r}")
    elif np.any(u_r > 1 + CHECK_TOL) or np.any(u_t > 1 + CHECK_TOL):
        raise ValueError("u_r and u_t must be <= 1 (beta <= 1)")
    th_r, th_t = np.asarray(theta_r, dtype=float), np.asarray(theta_t, dtype=float)
    if np.any(~np.isfinite(th_r)) or np.any(~np.isfinite(th_t)):
        raise ValueError("theta_r and theta_t must be finite (rad)")
    # the phase model binds only where both sides carry power at once (not across TDMA's parts)
    both = (u_r > 0) & (u_t > 0) & simultaneous
    diff = np.mod(th_t - th_r, 2 * np.pi)
    if surface.phases == "shared" and np.any(np.minimum(diff, 2 * np.pi - diff)[both] > CHECK_TOL):
        raise ValueError("theta_t must equal theta_r (mod 2 pi) with phases='shared'")
    if surface.phases == "coupled" and np.any(np.abs(np.abs(diff - np.pi) - np.pi / 2)[both] > CHECK_TOL):
        raise ValueError("theta_t - theta_r must be +-pi/2 (mod 2 pi) with phases='coupled'")
    if surface.bits is not None:
        for name, th in (("theta_r", th_r), ("theta_t", th_t)):
            off = np.abs(th - quantise(th, surface.bits))
            if np.any(np.minimum(off, 2 * np.pi - off) > CHECK_TOL):
                raise ValueError(f"{name} must lie on the {surface.bits}-bit grid 2 pi k / {2**surface.bits}")


def fixed_tdma_rates(
    config: ScenarioConfig, position: object, user_r: object, user_t: object
) -> tuple[float, float]:
    """The paper's surface serving each user alone (the ``"fixed"`` split, shared phases aligned to
    the served user): (c_r, c_t) = log2(1 + eta (a_D^s + u^s sum_m a_m^s)^2), equal to
    ``channel.slot_rates`` of ``config`` at the position with G = the user."""
    ch = star_channels(config, position, user_r, user_t)
    amp_r = ch.direct_r + ch.fixed_r * ch.a_r.sum()
    amp_t = ch.direct_t + ch.fixed_t * ch.a_t.sum()
    return math.log2(1 + ch.eta * amp_r * amp_r), math.log2(1 + ch.eta * amp_t * amp_t)
