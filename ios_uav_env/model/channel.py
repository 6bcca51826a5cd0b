"""The channel and rate model of the paper: pure numpy functions of (config, positions).

Every function takes horizontal UAV positions as a (K, 2) array (a single (2,) position
is accepted too and gives shape (1,) results) and is vectorised over them. Nothing here
knows about Gymnasium. The env, every planner and every report call these functions.

Notation (model.md): d_Um UAV-element, d_mG element-G, d_UG UAV-G distances; K^A, K^D
the arrival/departure power patterns (1)-(2); J the element constant; a_m the LoS
amplitude via element m (6); a_D the direct LoS amplitude; zeta = sum_m a_m + a_D the
phase-aligned amplitude (14); rate r(q) = log2(1 + eta zeta^2) (25).

The closed-form functions (:func:`zeta`, :func:`slot_rates`, :func:`faded_rates`, ...) come
first, then the per-element model. The same rate one position at a time, compiled (the
``RateKernel`` of a config, the kernels the envs step on, a moving node's kernels per slot),
is :mod:`ios_uav_env.model.rate_kernels` (its compiled functions of a kernel's rows:
:mod:`ios_uav_env.model.rate_rows`); their names are importable from here too.
"""

from __future__ import annotations

import numpy as np

from ios_uav_env.model.array import link_response, scenario_array
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.rate_kernels import (  # noqa: F401 (the compiled kernels, re-exported)
    PARAM_ANTENNAS,
    PARAM_BITS,
    PARAM_D_EXP,
    PARAM_ETA,
    PARAM_G_SIDE,
    PARAM_GX,
    PARAM_GY,
    PARAM_HAS_SURFACE,
    PARAM_K_DIRECT,
    PARAM_LOS_GAIN,
    PARAM_NLOS_GAIN,
    PARAM_T_FACTOR,
    PARAM_WAVELENGTH,
    PARAM_X_C,
    PARAM_Z_U2,
    PARAMS,
    HeldKernels,
    RateKernel,
    as_positions,
    faded_of_rate,
    faded_point,
    faded_row,
    fading_row,
    hold_path_kernels,
    path_kernels,
    rate_kernel,
    rate_point,
    rate_row,
    rates_at,
    rates_of_rows,
    require_bits_model,
    zeta_point,
    zeta_row,
    zetas_at,
)
from ios_uav_env.model.surface import element_positions, element_to_ground


def side_factor(config: ScenarioConfig, x: np.ndarray) -> np.ndarray:
    """Power-pattern side factor s(x): 1 when the UAV is on G's side of the surface plane
    (reflection), ``config.transmit_factor`` on the other side (transmission), 0 in the
    plane or without a surface."""
    k = rate_kernel(config)
    dx = np.asarray(x, dtype=float) - k.x_c
    if not k.has_surface:
        return np.zeros_like(dx)
    return np.where(dx * k.g_side > 0, 1.0, np.where(dx == 0, 0.0, k.t_factor))


def surface_terms(config: ScenarioConfig, positions: np.ndarray) -> np.ndarray:
    """Per-node terms of the phase-aligned surface amplitude, shape (K, nodes).

    Entry [i, k] is J s(q_i) |x_i - x_c|^3 w_k / d_k(q_i)^4 for the nodes of
    :func:`~ios_uav_env.model.surface.surface_nodes` (``config.quadrature_nodes``); rows sum to
    :func:`surface_amplitude`. All zero without a surface. Planners that need the
    structure of the element sum (e.g. SCA's per-tile slacks) use this, not a copy.
    """
    q = as_positions(positions)
    k = rate_kernel(config)
    if not k.has_surface:
        return np.zeros((len(q), k.jw.size))
    dx = q[:, 0] - k.x_c
    d2 = (q[:, 1:2] - k.node_y) ** 2 + k.dz2 + (dx * dx)[:, None]  # (K, nodes): d_Um^2
    return (side_factor(config, q[:, 0]) * np.abs(dx) ** 3)[:, None] * (k.jw / (d2 * d2))


def surface_amplitude(config: ScenarioConfig, positions: np.ndarray) -> np.ndarray:
    """Phase-aligned cascaded amplitude sum_m a_m via the surface, shape (K,)."""
    return surface_terms(config, positions).sum(axis=1)


def direct_amplitude(config: ScenarioConfig, positions: np.ndarray) -> np.ndarray:
    """Direct LoS amplitude a_D = sqrt(G_tx G_rx) d_UG^(-alpha/2), shape (K,)."""
    q = as_positions(positions)
    k = rate_kernel(config)
    return k.k_direct * (((q - k.ground) ** 2).sum(axis=1) + k.z_u2) ** k.d_exp


def zeta(config: ScenarioConfig, positions: np.ndarray) -> np.ndarray:
    """Phase-aligned channel amplitude zeta = sum_m a_m + a_D of eq. (14), shape (K,).

    A STAR surface of b-bit phases (``config.star_bits`` = b): the amplitude at the node's exact
    b-bit phases instead, max over theta on the grid {0, 2 pi / 2^b, ...} of
    |a_D + sum_m a_m e^{j (phi_m - theta_m)}| with phi_m = :func:`phase_shifts` (the aligned
    phases), computed element by element by the compiled ``rate_rows.discrete_zeta_row`` (the
    search of ``star_rows.discrete_phases``, which ``star_slot.slot_optimum``'s TDMA rate takes)."""
    if config.star_bits is not None:
        return rate_kernel(config).zetas(as_positions(positions))
    return surface_amplitude(config, positions) + direct_amplitude(config, positions)


def array_factor(config: ScenarioConfig, positions: np.ndarray) -> np.ndarray:
    """|a_c^T conj(a_G)| at each position, shape (K,): the product of the UAV array's steering
    vectors (``model.array``, ``config.antennas`` antennas) towards the surface's centre and
    towards G, in [0, N_t]; 1 for one antenna."""
    q = as_positions(positions)
    array = scenario_array(config)
    uav = np.column_stack([q, np.full(len(q), config.uav_altitude)])
    centre = link_response(array, uav, np.asarray(config.ios_center, dtype=float))
    ground = link_response(array, uav, np.array([*config.ground_node, 0.0]))
    return np.abs(np.sum(centre * ground.conj(), axis=1))


def aligned_gain(config: ScenarioConfig, positions: np.ndarray) -> np.ndarray:
    """The slot's SNR at each position with the surface's phases and the UAV's beam at their joint
    optimum, shape (K,): eta zeta^2 (eq. (14)) for one antenna; for ``config.antennas`` = N_t > 1
    the closed form of ``model.miso`` (aligned phases and MRT; its module docstring derives it),
    G = eta (N_t (S^2 + a_D^2) + 2 S a_D |a_c^T conj(a_G)|) with S = sum_m a_m
    (:func:`surface_amplitude`), a_D (:func:`direct_amplitude`) and :func:`array_factor`."""
    if config.antennas == 1:
        z = zeta(config, positions)
        return config.eta * z * z
    require_bits_model(config)
    s, a_d = surface_amplitude(config, positions), direct_amplitude(config, positions)
    cross = 2.0 * s * a_d * array_factor(config, positions)
    return config.eta * (config.antennas * (s * s + a_d * a_d) + cross)


def slot_rates(config: ScenarioConfig, positions: np.ndarray) -> np.ndarray:
    """Expected-gain rate log2(1 + eta zeta^2) (bps/Hz) at each position, shape (K,); with
    ``config.antennas`` > 1, log2(1 + G) of :func:`aligned_gain`; with b-bit phases
    (``config.star_bits``), log2(1 + eta |h_b|^2) of the amplitude |h_b| at the node's exact
    b-bit phases (:func:`zeta`).

    The objective the paper optimises (eq. (25)). No feasibility check is made.
    """
    if config.antennas > 1:
        return np.log2(1.0 + aligned_gain(config, positions))
    z = zeta(config, positions)
    return np.log2(1.0 + config.eta * z * z)


def require_single_antenna(config: ScenarioConfig, what: str) -> None:
    """``ValueError`` when ``config.antennas`` > 1: ``what`` models the single-antenna channel."""
    if config.antennas > 1:
        raise ValueError(
            f"{what} models the single-antenna UAV, but this config has antennas={config.antennas}: its "
            "rate at the optimal phases and beam is slot_rates (aligned_gain), any other setting "
            "ios_uav_env.model.miso (SlotChannel), a Rician draw ios_uav_env.model.miso_fading"
        )


def phased_rates(config: ScenarioConfig, positions: np.ndarray, phases: np.ndarray) -> np.ndarray:
    """Expected-gain rate (bps/Hz) at each position with the surface's ``phases`` (K, M) given:
    E|h|^2 = kappa/(1+kappa) |h^LoS(psi)|^2 + 1/(1+kappa) (sum_m a_m + a_D)^2 (eqs. (4)-(8)), which
    is zeta^2, and the rate ``slot_rates``, at the closed-form phases; shape (K,). One antenna."""
    require_single_antenna(config, "phased_rates")
    k = config.kappa
    gain = k / (1 + k) * np.abs(los_channel(config, positions, phases)) ** 2
    amp = element_amplitudes(config, positions).sum(axis=1) + direct_amplitude(config, positions)
    return np.log2(1.0 + config.eta * (gain + amp**2 / (1 + k)))


def small_scale_term(config: ScenarioConfig, positions: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """sqrt(kappa/(1+kappa)) exp(-j 2 pi d_UG / lambda) + sqrt(1/(1+kappa)) h_SS, h_SS ~ CN(0, 1)."""
    config.require_single_node("small_scale_term")
    q = as_positions(positions)
    d_ug = np.sqrt(((q - np.asarray(config.ground_node)) ** 2).sum(axis=1) + config.uav_altitude**2)
    h_ss = (rng.standard_normal(len(q)) + 1j * rng.standard_normal(len(q))) / np.sqrt(2.0)
    k = config.kappa
    return np.sqrt(k / (1 + k)) * np.exp(-2j * np.pi * d_ug / config.wavelength) + np.sqrt(1 / (1 + k)) * h_ss


def faded_rates(config: ScenarioConfig, positions: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One faded-rate sample log2(1 + eta |h|^2) per position under the closed-form phases (one antenna)."""
    require_single_antenna(config, "faded_rates")
    h = zeta(config, positions) * small_scale_term(config, positions, rng)
    return np.log2(1.0 + config.eta * np.abs(h) ** 2)


# --- per-element model: (K, M) arrays, for checks and for arbitrary phase shifts ----------


def _element_geometry(config: ScenarioConfig, positions: np.ndarray) -> dict[str, np.ndarray]:
    q = as_positions(positions)
    w = element_positions(config)
    d_um = np.sqrt(
        (q[:, 0:1] - w[:, 0]) ** 2 + (q[:, 1:2] - w[:, 1]) ** 2 + (config.uav_altitude - w[:, 2]) ** 2
    )
    d_mg, cos_d = element_to_ground(config)
    d_ug = np.sqrt(((q - np.asarray(config.ground_node)) ** 2).sum(axis=1) + config.uav_altitude**2)
    return {"q": q, "w": w, "d_um": d_um, "d_mg": d_mg, "cos_d": cos_d, "d_ug": d_ug}


def radiation_patterns(config: ScenarioConfig, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Power patterns (K^A, K^D) of eqs. (1)-(2) with the reflect/transmit rule, each (K, M).

    K^D includes the side factor (1, epsilon or 0) of the UAV's side in each row.
    """
    g = _element_geometry(config, positions)
    k_a = np.abs((g["q"][:, 0:1] - g["w"][:, 0]) / g["d_um"]) ** 3
    # every element lies in the plane x = x_c, so the side (and factor) is one per row
    return k_a, side_factor(config, g["q"][:, 0])[:, None] * g["cos_d"] ** 3


def element_amplitudes(config: ScenarioConfig, positions: np.ndarray) -> np.ndarray:
    """LoS amplitude via each element a_m = J K^A K^D / (d_Um d_mG), shape (K, M)."""
    g = _element_geometry(config, positions)
    k_a, k_d = radiation_patterns(config, positions)
    return config.J * k_a * k_d / (g["d_um"] * g["d_mg"])


def phase_shifts(config: ScenarioConfig, positions: np.ndarray) -> np.ndarray:
    """Closed-form optimal phase shifts psi_m = 2 pi / lambda (d_UG - d_Um - d_mG) mod 2 pi, eq. (13)."""
    g = _element_geometry(config, positions)
    psi = 2 * np.pi / config.wavelength * (g["d_ug"][:, None] - g["d_um"] - g["d_mg"])
    return np.mod(psi, 2 * np.pi)


def los_channel(
    config: ScenarioConfig, positions: np.ndarray, phases: np.ndarray | None = None
) -> np.ndarray:
    """LoS channel sum_m h_m^LoS + h_D^LoS under ``phases`` (K, M) (default: eq. (13)), shape (K,)."""
    g = _element_geometry(config, positions)
    psi = phase_shifts(config, positions) if phases is None else np.asarray(phases, dtype=float)
    if psi.shape != g["d_um"].shape:
        raise ValueError(f"phases must have shape {g['d_um'].shape} (K, M), got {psi.shape}")
    a_m = element_amplitudes(config, positions)
    k = 2 * np.pi / config.wavelength
    via = (a_m * np.exp(-1j * (k * (g["d_um"] + g["d_mg"]) + psi))).sum(axis=1)
    return via + direct_amplitude(config, positions) * np.exp(-1j * k * g["d_ug"])


def channel(
    config: ScenarioConfig,
    positions: np.ndarray,
    rng: np.random.Generator,
    phases: np.ndarray | None = None,
) -> np.ndarray:
    """Full Rician channel h of eqs. (4)-(8), one draw of h_SS per position, shape (K,).

    h = sqrt(k/(1+k)) h^LoS(psi) + sqrt(1/(1+k)) (sum_m a_m + a_D) h_SS; with the closed-form
    phases this is zeta (sqrt(k/(1+k)) e^{-j 2 pi d_UG / lambda} + sqrt(1/(1+k)) h_SS).
    """
    q = as_positions(positions)
    k = config.kappa
    amp = element_amplitudes(config, q).sum(axis=1) + direct_amplitude(config, q)
    h_ss = (rng.standard_normal(len(q)) + 1j * rng.standard_normal(len(q))) / np.sqrt(2.0)
    return np.sqrt(k / (1 + k)) * los_channel(config, q, phases) + np.sqrt(1 / (1 + k)) * amp * h_ss
