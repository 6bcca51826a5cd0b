"""The channel and rate model of the paper: pure numpy functions of (config, positions).

Every function takes horizontal UAV positions as a (K, 2) array (a single (2,) position
is accepted too and gives shape (1,) results) and is vectorised over them. Nothing here
knows about Gymnasium. The env, every planner and every report call these functions.

Notation (model.md): d_Um UAV-element, d_mG element-G, d_UG UAV-G distances; K^A, K^D
the arrival/departure power patterns (1)-(2); J the element constant; a_m the LoS
amplitude via element m (6); a_D the direct LoS amplitude; zeta = sum_m a_m + a_D the
phase-aligned amplitude (14); rate r(q) = log2(1 + eta zeta^2) (25).
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ios_uav_env.jit import jit
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.surface import element_positions, element_to_ground, ground_weights, surface_nodes


def as_positions(positions: np.ndarray, name: str = "positions") -> np.ndarray:
    """Validate and return positions as a float (K, 2) array."""
    arr = np.asarray(positions, dtype=float)
    if arr.ndim == 1:
        arr = arr.reshape(1, -1)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"{name} must have shape (K, 2) (horizontal x, y in m), got {np.shape(positions)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return arr


def side_factor(config: ScenarioConfig, x: np.ndarray) -> np.ndarray:
    """Power-pattern side factor s(x): 1 when the UAV is on G's side of the surface plane
    (reflection), ``config.transmit_factor`` on the other side (transmission), 0 in the
    plane or without a surface."""
    k = rate_kernel(config)
    dx = np.asarray(x, dtype=float) - k.x_c
    if not k.has_surface:
        return np.zeros_like(dx)
    return np.where(dx * k.g_side > 0, 1.0, np.where(dx == 0, 0.0, k.t_factor))


#: Layout of ``RateKernel.params`` (the scalars of :func:`zeta_point`), by name.
PARAMS = (
    "x_c", "g_side", "t_factor", "has_surface", "gx", "gy", "z_u2", "k_direct", "d_exp", "eta",
    "wavelength", "los_gain", "nlos_gain",
)  # fmt: skip
# Its columns by name, as the env's kernels name theirs (``envs.single_kernels``' docstring):
# plain ints, constants in the compiled code.
PARAM_X_C = PARAMS.index("x_c")
PARAM_G_SIDE = PARAMS.index("g_side")
PARAM_T_FACTOR = PARAMS.index("t_factor")
PARAM_HAS_SURFACE = PARAMS.index("has_surface")
PARAM_GX = PARAMS.index("gx")
PARAM_GY = PARAMS.index("gy")
PARAM_Z_U2 = PARAMS.index("z_u2")
PARAM_K_DIRECT = PARAMS.index("k_direct")
PARAM_D_EXP = PARAMS.index("d_exp")
PARAM_ETA = PARAMS.index("eta")
PARAM_WAVELENGTH = PARAMS.index("wavelength")
PARAM_LOS_GAIN = PARAMS.index("los_gain")
PARAM_NLOS_GAIN = PARAMS.index("nlos_gain")


@jit(inline=True)
def zeta_row(x: float, y: float, nodes: np.ndarray, params: np.ndarray, i: int) -> float:
    """zeta at one position: the formula of :func:`zeta` as a loop over the surface nodes, for
    row ``i`` of a batch of rate kernels (``nodes`` (B, 3, K): y_k, (z_U - z_k)^2, J w_k;
    ``params`` (B, P): the scalars of :data:`PARAMS`). Inlined into the compiled kernels that
    call it (the env's hot path) and indexed in place: no per-row array views, which cost more
    than the sum itself."""
    dxg, dyg = x - params[i, PARAM_GX], y - params[i, PARAM_GY]
    direct = (
        params[i, PARAM_K_DIRECT] * (dxg * dxg + dyg * dyg + params[i, PARAM_Z_U2]) ** params[i, PARAM_D_EXP]
    )
    dx = x - params[i, PARAM_X_C]
    if params[i, PARAM_HAS_SURFACE] == 0.0 or dx == 0.0:
        return direct
    side = 1.0 if dx * params[i, PARAM_G_SIDE] > 0.0 else params[i, PARAM_T_FACTOR]
    dx2, total = dx * dx, 0.0
    for k in range(nodes.shape[2]):
        dy = y - nodes[i, 0, k]
        d2 = dy * dy + nodes[i, 1, k] + dx2
        total += nodes[i, 2, k] / (d2 * d2)
    return side * abs(dx) ** 3 * total + direct


@jit(inline=True)
def rate_row(x: float, y: float, nodes: np.ndarray, params: np.ndarray, i: int) -> float:
    """Expected-gain rate log2(1 + eta zeta^2) at one position, row ``i`` (see :func:`zeta_row`)."""
    z = zeta_row(x, y, nodes, params, i)
    return math.log2(1.0 + params[i, PARAM_ETA] * z * z)


@jit(inline=True)
def faded_row(
    x: float, y: float, n_re: float, n_im: float, nodes: np.ndarray, params: np.ndarray, i: int
) -> float:
    """One faded-rate sample log2(1 + eta |h|^2) at one position, row ``i``, given the two
    standard normal draws of h_SS (real, then imaginary part): the scalar form of :func:`faded_rates`."""
    z = zeta_row(x, y, nodes, params, i)
    dxg, dyg = x - params[i, PARAM_GX], y - params[i, PARAM_GY]
    phase = (
        2.0 * math.pi * math.sqrt(dxg * dxg + dyg * dyg + params[i, PARAM_Z_U2]) / params[i, PARAM_WAVELENGTH]
    )
    re = params[i, PARAM_LOS_GAIN] * math.cos(phase) + params[i, PARAM_NLOS_GAIN] * n_re
    im = -params[i, PARAM_LOS_GAIN] * math.sin(phase) + params[i, PARAM_NLOS_GAIN] * n_im
    return math.log2(1.0 + params[i, PARAM_ETA] * z * z * (re * re + im * im))


@jit
def zeta_point(x: float, y: float, nodes: np.ndarray, params: np.ndarray) -> float:
    """zeta at one position for one rate kernel (``nodes`` (3, K), ``params`` (P,)): :func:`zeta_row`."""
    return zeta_row(x, y, nodes[np.newaxis], params[np.newaxis], 0)


@jit
def rate_point(x: float, y: float, nodes: np.ndarray, params: np.ndarray) -> float:
    """Expected-gain rate log2(1 + eta zeta^2) at one position: :func:`rate_row` of one kernel."""
    return rate_row(x, y, nodes[np.newaxis], params[np.newaxis], 0)


@jit
def rates_at(points: np.ndarray, nodes: np.ndarray, params: np.ndarray) -> np.ndarray:
    """:func:`rate_point` at each of the (n, 2) ``points`` (one compiled loop): the
    expected-gain rates of :func:`slot_rates` for the kernel's config, without its (n, nodes)
    numpy temporaries."""
    out = np.empty(points.shape[0])
    for i in range(points.shape[0]):
        out[i] = rate_point(points[i, 0], points[i, 1], nodes, params)
    return out


@jit
def faded_point(x: float, y: float, n_re: float, n_im: float, nodes: np.ndarray, params: np.ndarray) -> float:
    """One faded-rate sample at one position: :func:`faded_row` of one kernel."""
    return faded_row(x, y, n_re, n_im, nodes[np.newaxis], params[np.newaxis], 0)


@dataclass(frozen=True, eq=False)
class RateKernel:
    """Per-config constants of zeta(q) (the surface's weighted nodes and the rest), with the
    scalar form of :func:`zeta` for hot loops: hold one and call :meth:`zeta` / :meth:`rate`."""

    node_y: np.ndarray  # (K,) m, node y coordinates
    dz2: np.ndarray  # (K,) m^2, (z_U - z_node)^2
    jw: np.ndarray  # (K,) J * node weight
    x_c: float  # m, surface plane x = x_c
    g_side: float  # sign(x_G - x_c): the reflecting side
    t_factor: float  # side factor on the transmitting side
    has_surface: bool
    ground: np.ndarray  # (2,) m, w_G
    gx: float  # m, x_G
    gy: float  # m, y_G
    z_u2: float  # m^2, z_U^2
    k_direct: float  # sqrt(G_tx G_rx)
    d_exp: float  # -alpha / 4 (applied to d_UG^2)
    eta: float  # P / sigma^2
    wavelength: float  # m, lambda
    los_gain: float  # sqrt(kappa / (1 + kappa))
    nlos_gain: float  # sqrt(1 / (1 + kappa)) / sqrt(2): per real/imaginary part of h_SS

    nodes: np.ndarray  # (3, K): node_y, dz2, jw stacked (the arrays of zeta_point)
    params: np.ndarray  # (10,): the scalars of zeta_point, in the order of PARAMS

    def zeta(self, x: float, y: float) -> float:
        """zeta at one position (x, y): :func:`zeta_point`, tested equal to :func:`zeta`."""
        return zeta_point(float(x), float(y), self.nodes, self.params)

    def rate(self, x: float, y: float) -> float:
        """Expected-gain rate log2(1 + eta zeta^2) at one position (x, y)."""
        return rate_point(float(x), float(y), self.nodes, self.params)

    def rates(self, points: np.ndarray) -> np.ndarray:
        """Expected-gain rates at the (n, 2) ``points``: :func:`rates_at` (equal to :func:`slot_rates`)."""
        return rates_at(np.ascontiguousarray(points, dtype=np.float64), self.nodes, self.params)

    def faded_rate(self, x: float, y: float, rng: np.random.Generator) -> float:
        """One faded-rate sample log2(1 + eta |h|^2) at (x, y): :func:`faded_point` with h_SS
        drawn from ``rng`` in the order of :func:`faded_rates` (real, then imaginary part)."""
        n_re, n_im = rng.standard_normal(2)
        return faded_point(float(x), float(y), float(n_re), float(n_im), self.nodes, self.params)


@lru_cache(maxsize=64)
def rate_kernel(config: ScenarioConfig) -> RateKernel:
    """The (cached) :class:`RateKernel` of ``config`` (one ground node: ``ValueError`` if K > 1)."""
    config.require_single_node("the single-node rate model (slot_rates, average_rate, rate_peak, the env)")
    nodes = surface_nodes(config)
    fields = dict(
        node_y=nodes.y,
        dz2=(config.uav_altitude - nodes.z) ** 2,
        jw=config.J * nodes.weight,
        x_c=config.ios_center[0],
        g_side=float(np.sign(config.ground_node[0] - config.ios_center[0])),
        t_factor=config.transmit_factor,
        has_surface=config.surface != "none",
        ground=np.asarray(config.ground_node, dtype=float),
        gx=config.ground_node[0],
        gy=config.ground_node[1],
        z_u2=config.uav_altitude**2,
        k_direct=float(np.sqrt(config.g_tx * config.g_rx)),
        d_exp=-config.alpha / 4.0,
        eta=config.eta,
        wavelength=config.wavelength,
        los_gain=math.sqrt(config.kappa / (1.0 + config.kappa)),
        nlos_gain=math.sqrt(1.0 / (1.0 + config.kappa)) / math.sqrt(2.0),
    )
    packed = np.vstack([fields["node_y"], fields["dz2"], fields["jw"]])
    params = np.array([float(fields[name]) for name in PARAMS])
    return RateKernel(**fields, nodes=packed, params=params)


class HeldKernels:
    """A path's kernels, which :func:`path_kernels` copies while this object lives."""

    __slots__ = ("__weakref__", "nodes", "params")

    def __init__(self, nodes: np.ndarray, params: np.ndarray) -> None:
        self.nodes, self.params = nodes, params


#: (config, the path's bytes) -> the kernels some live object holds (weak: gone with their holder)
_HELD: weakref.WeakValueDictionary[tuple[ScenarioConfig, bytes], HeldKernels] = weakref.WeakValueDictionary()


def hold_path_kernels(
    config: ScenarioConfig, grounds: np.ndarray, nodes: np.ndarray, params: np.ndarray
) -> HeldKernels:
    """Let :func:`path_kernels` of ``config`` and ``grounds`` return copies of ``nodes`` and ``params``
    (its own result, which the caller keeps, e.g. in a moving-node episode's track; views are fine)
    instead of computing them again, as long as the returned object lives (e.g. the multi-node env's
    score of an episode builds the kernels of the paths its track holds)."""
    held = HeldKernels(nodes, params)
    _HELD[(config, as_positions(grounds, "grounds").tobytes())] = held
    return held


def path_kernels(config: ScenarioConfig, grounds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rate kernels of one ground node at each of the (P, 2) ``grounds`` (m): ``nodes``
    (P, 3, n) and ``params`` (P, len(PARAMS)), row p equal bit for bit to
    ``rate_kernel(config.replace(ground_node=grounds[p]))``'s ``nodes`` and ``params``. A
    moving node's kernel per slot (``ios_uav_env.model.motion``) without a config per slot:
    only the surface weights and G's coordinates and side depend on G
    (:func:`~ios_uav_env.model.surface.ground_weights`). ``config`` has one node (K = 1).
    New arrays: copies of the held ones when the path's kernels are held (:func:`hold_path_kernels`)."""
    points = as_positions(grounds, "grounds")
    held = _HELD.get((config, points.tobytes()))
    if held is not None:
        return held.nodes.copy(), held.params.copy()
    base = rate_kernel(config)
    nodes = np.repeat(base.nodes[None], len(points), axis=0)
    nodes[:, 2] = config.J * ground_weights(config, points)
    params = np.repeat(base.params[None], len(points), axis=0)
    params[:, PARAMS.index("g_side")] = np.sign(points[:, 0] - config.ios_center[0])
    params[:, PARAMS.index("gx")], params[:, PARAMS.index("gy")] = points[:, 0], points[:, 1]
    return nodes, params


@jit
def rates_of_rows(points: np.ndarray, nodes: np.ndarray, params: np.ndarray) -> np.ndarray:
    """Expected-gain rate at each of the (n, 2) ``points``, point i under kernel row i
    (:func:`rate_row`; ``nodes`` (n, 3, K), ``params`` (n, P), e.g. :func:`path_kernels`)."""
    out = np.empty(points.shape[0])
    for i in range(points.shape[0]):
        out[i] = rate_row(points[i, 0], points[i, 1], nodes, params, i)
    return out


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
    """Phase-aligned channel amplitude zeta = sum_m a_m + a_D of eq. (14), shape (K,)."""
    return surface_amplitude(config, positions) + direct_amplitude(config, positions)


def slot_rates(config: ScenarioConfig, positions: np.ndarray) -> np.ndarray:
    """Expected-gain rate log2(1 + eta zeta^2) (bps/Hz) at each position, shape (K,).

    The objective the paper optimises (eq. (25)). No feasibility check is made.
    """
    z = zeta(config, positions)
    return np.log2(1.0 + config.eta * z * z)


def phased_rates(config: ScenarioConfig, positions: np.ndarray, phases: np.ndarray) -> np.ndarray:
    """Expected-gain rate (bps/Hz) at each position with the surface's ``phases`` (K, M) given:
    E|h|^2 = kappa/(1+kappa) |h^LoS(psi)|^2 + 1/(1+kappa) (sum_m a_m + a_D)^2 (eqs. (4)-(8)), which
    is zeta^2, and the rate ``slot_rates``, at the closed-form phases; shape (K,)."""
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
    """One faded-rate sample log2(1 + eta |h|^2) per position under the closed-form phases."""
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
