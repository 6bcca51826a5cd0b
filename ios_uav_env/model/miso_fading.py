"""The multi-antenna UAV's Rician slot channel: the LoS channels of :mod:`ios_uav_env.model.miso`
plus a scattered (NLoS) part drawn per antenna.

Notation as in :mod:`ios_uav_env.model.miso` (``docs/model.md``, "Multi-antenna UAV"): user k's row
h_k(psi) = sum_m v_m c_km g_m^T + d_k^T with v_m = exp(-j psi_m), c_km = sqrt(eta) a_km
exp(-j k_w (d_Um + d_mk)), g_m the UAV-element steering vector, d_k = sqrt(eta) a_Dk
exp(-j k_w d_Uk) a_k; kappa the scenario's Rician factor (``ScenarioConfig.kappa``, eqs. (4)-(5));
z ~ CN(0, I) vectors drawn from the caller's generator. Every LoS term is weighted by
sqrt(kappa / (1 + kappa)) and every scattered term by sqrt(1 / (1 + kappa)), and each scattered
term keeps its LoS path's amplitude (path loss and patterns), as eqs. (4)-(8) do. Two scatterings
(:data:`SCATTERINGS`):

**"link"** (the paper's eqs. (4)-(8), one scattered vector per user link). The paper's NLoS part is
one h_SS ~ CN(0, 1) common to every path of the link, scaled by the aligned amplitude
sum_m a_m + a_D and independent of the phases. Per antenna n it is drawn independently (the
antennas lambda / 2 apart in rich scattering decorrelate):

    h_k(psi) = sqrt(kappa/(1+kappa)) h_k^LoS(psi) + sqrt(1/(1+kappa)) sqrt(eta) (sum_m a_km + a_Dk) z_k^T,

z_k ~ CN(0, I_{N_t}). As a :class:`~ios_uav_env.model.miso.SlotChannel` this scales ``coef`` and
``direct`` by sqrt(kappa/(1+kappa)) and adds the scattered row to ``direct``; the UAV-surface
channel keeps its LoS structure (rank one for ``steering="centre"``, where the single-user optimum
stays the closed form: aligned phases and MRT on the faded row). For N_t = 1 this is
``channel.channel`` exactly: z_k is h_SS, drawn the same way (``rng.standard_normal`` for the real
parts of every draw, then for the imaginary parts, divided by sqrt(2)), so with one user the
generator's stream is consumed identically and h equals ``sqrt(eta) channel.channel`` to rounding.
E ||h_k||^2 = kappa/(1+kappa) ||h_k^LoS||^2 + 1/(1+kappa) eta N_t (sum_m a_km + a_Dk)^2.

**"element"** (the standard IRS-MISO Rician model, Wu & Zhang, IEEE TWC 2019: i.i.d. scattering
per element and per antenna). The UAV-surface matrix G (M x N_t) and each direct row are Rician:

    g_m -> sqrt(kappa/(1+kappa)) g_m + sqrt(1/(1+kappa)) z_m,   z_m ~ CN(0, I_{N_t}) i.i.d. over m,
    d_k -> sqrt(kappa/(1+kappa)) d_k + sqrt(1/(1+kappa)) sqrt(eta) a_Dk z_Dk,   z_Dk ~ CN(0, I_{N_t}),

the surface-user links staying LoS (``coef``, the patterns of each user's side). A CN(0, I) vector
times a fixed phase is CN(0, I), so the LoS propagation phases exp(-j k_w d_Um) (in ``coef``) and
exp(-j k_w d_Uk) need no scattered counterpart. G is then full rank: ``rank_one`` is False, the
aligned phases are a feasible point only, and ``miso.user_gain_bound``'s
(sum_m |c_km| ||g_m|| + ||d_k||)^2 (the triangle inequality, valid for any G) is the bound. For N_t = 1
this is not eqs. (4)-(8): its scattered power is 1/(1+kappa) eta (sum_m a_km^2 + a_Dk^2), the
incoherent sum, where the paper's is the coherent (sum_m a_km + a_Dk)^2.
E ||h_k(psi)||^2 = kappa/(1+kappa) ||h_k^LoS(psi)||^2 + 1/(1+kappa) eta N_t (sum_m a_km^2 + a_Dk^2).

Draw order of :func:`rician_slot_channels` over P positions: "link" draws the real parts of a
(P, K, N_t) array of standard normals, then its imaginary parts; "element" those of a
(P, M + K, N_t) array, rows 0..M-1 the UAV-element rows z_m, rows M..M+K-1 the direct rows z_Dk.
"""

from __future__ import annotations

import math

import numpy as np

from ios_uav_env.model import channel as ch
from ios_uav_env.model.array import ArrayConfig
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.miso import SlotChannel, one_position, slot_channels

#: The scattered parts (the module docstring): the paper's one vector per user link, or i.i.d.
#: per surface element and antenna.
SCATTERINGS: tuple[str, ...] = ("link", "element")


def check_scattering(scattering: str) -> None:
    """``ValueError`` unless ``scattering`` is one of :data:`SCATTERINGS`."""
    if scattering not in SCATTERINGS:
        raise ValueError(
            f"scattering must be one of {SCATTERINGS} (one scattered vector per user link, as eqs. "
            f"(4)-(8), or i.i.d. per element and antenna), got {scattering!r}"
        )


def standard_complex(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """CN(0, 1) entries of ``shape``: ``rng``'s standard normals for the real parts of every entry,
    then for the imaginary parts, over sqrt(2) (the draw of ``channel.channel``'s h_SS)."""
    return (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2.0)


def _weights(config: ScenarioConfig) -> tuple[float, float]:
    k = config.kappa
    return math.sqrt(k / (1 + k)), math.sqrt(1 / (1 + k))


def _users(config: ScenarioConfig) -> list[ScenarioConfig]:
    return [config.node_config(k) for k in range(config.K)]


def _link_amplitudes(config: ScenarioConfig, q: np.ndarray) -> np.ndarray:
    """sqrt(eta) (sum_m a_km + a_Dk) of each position and user, shape (P, K)."""
    amp = [ch.element_amplitudes(u, q).sum(axis=1) + ch.direct_amplitude(u, q) for u in _users(config)]
    return math.sqrt(config.eta) * np.stack(amp, axis=1)


def _direct_amplitudes(config: ScenarioConfig, q: np.ndarray) -> np.ndarray:
    """sqrt(eta) a_Dk of each position and user, shape (P, K)."""
    amp = [ch.direct_amplitude(u, q) for u in _users(config)]
    return math.sqrt(config.eta) * np.stack(amp, axis=1)


def rician_slot_channels(
    config: ScenarioConfig,
    array: ArrayConfig,
    trajectory: np.ndarray,
    rng: np.random.Generator,
    scattering: str = "link",
) -> list[SlotChannel]:
    """One Rician draw of the :class:`~ios_uav_env.model.miso.SlotChannel` at each horizontal position
    of ``trajectory`` (P, 2) m, drawn from ``rng`` in the order of the module docstring, with
    ``config.kappa`` and the ``scattering`` of :data:`SCATTERINGS`. The LoS channels are
    :func:`~ios_uav_env.model.miso.slot_channels`' (kappa -> infinity recovers them)."""
    check_scattering(scattering)
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy Generator (np.random.default_rng(seed)), got {rng!r}")
    los = slot_channels(config, array, trajectory)
    q = ch.as_positions(trajectory, "trajectory")
    P, K, M, n_t = len(q), config.K, config.M, array.n_t
    a, b = _weights(config)
    if scattering == "link":
        scattered = _link_amplitudes(config, q)[:, :, None] * standard_complex(rng, (P, K, n_t))
        return [
            SlotChannel(a * c.coef, c.to_elements, a * c.direct + b * scattered[p], rank_one=c.rank_one)
            for p, c in enumerate(los)
        ]
    z = standard_complex(rng, (P, M + K, n_t))
    direct = _direct_amplitudes(config, q)[:, :, None] * z[:, M:]
    return [
        SlotChannel(c.coef, a * c.to_elements + b * z[p, :M], a * c.direct + b * direct[p], rank_one=False)
        for p, c in enumerate(los)
    ]


def rician_slot_channel(
    config: ScenarioConfig,
    array: ArrayConfig,
    position: np.ndarray,
    rng: np.random.Generator,
    scattering: str = "link",
) -> SlotChannel:
    """One Rician draw of the :class:`~ios_uav_env.model.miso.SlotChannel` at the horizontal
    ``position`` (2,) m: :func:`rician_slot_channels` of one position."""
    return rician_slot_channels(config, array, one_position(position), rng, scattering)[0]


def mean_gains(
    config: ScenarioConfig,
    array: ArrayConfig,
    position: np.ndarray,
    phases: np.ndarray,
    scattering: str = "link",
) -> np.ndarray:
    """E ||h_k(psi)||^2 over the draws of :func:`rician_slot_channel` at ``position`` with the
    surface's ``phases`` psi (M,) rad, shape (K,) (SNR units; the module docstring's formulas): the
    LoS power weighted by kappa / (1 + kappa) plus the scattered power, the cross terms having
    mean zero."""
    check_scattering(scattering)
    q = one_position(position)
    los = slot_channels(config, array, q)[0]
    a, b = _weights(config)
    power = np.sum(np.abs(los.matrix(phases)) ** 2, axis=1)
    if scattering == "link":
        scattered = _link_amplitudes(config, q)[0] ** 2
    else:
        surface = np.array([np.sum(ch.element_amplitudes(u, q) ** 2) for u in _users(config)])
        scattered = config.eta * surface + _direct_amplitudes(config, q)[0] ** 2
    return a * a * power + b * b * array.n_t * scattered
