"""The rate kernel of one ground node, and the kernels of a moving node.

:func:`rate_kernel` packs a config's constants of zeta(q) (the surface's weighted nodes, G's
coordinates and side, the path-loss and power terms) into two arrays, ``nodes`` (3, Q) and
``params`` (columns :data:`PARAMS`), held by a :class:`RateKernel`; the compiled functions that
evaluate the rate model of :mod:`ios_uav_env.model.channel` on them one position at a time
(:func:`zeta_row`, :func:`rate_row` and :func:`faded_row` inlined into the env's kernels,
:func:`rate_point` and :func:`rates_at` for one kernel, :func:`rates_of_rows` for one kernel per
point) are :mod:`ios_uav_env.model.rate_rows`', importable from here too.
:func:`path_kernels` builds a moving node's kernel per slot from one surface projection, and
:func:`hold_path_kernels` lets a caller that keeps such kernels (a moving-node episode's track)
have :func:`path_kernels` return copies of them instead of projecting again. Every name here
is importable from :mod:`ios_uav_env.model.channel` too.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import operator
import weakref
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ios_uav_env.model.array import scenario_array
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.rate_rows import (  # noqa: F401 (the compiled rate model, re-exported)
    PARAM_ANTENNAS,
    PARAM_ARRAY_K,
    PARAM_AXIS_X,
    PARAM_AXIS_Y,
    PARAM_BITS,
    PARAM_D_EXP,
    PARAM_DZ_C2,
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
    PARAM_Y_C,
    PARAM_Z_U2,
    PARAMS,
    amplitudes_row,
    array_factor_row,
    discrete_zeta_row,
    faded_of_rate,
    faded_point,
    faded_row,
    fading_row,
    gain_row,
    offset_order,
    rate_point,
    rate_row,
    rates_at,
    rates_of_rows,
    zeta_point,
    zeta_row,
    zetas_at,
)
from ios_uav_env.model.surface import ground_weights, path_weights_into, surface_nodes


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


@dataclass(frozen=True, eq=False)
class RateKernel:
    """Per-config constants of zeta(q) (the surface's weighted nodes and the rest), with the
    scalar form of ``channel.zeta`` for hot loops: hold one and call :meth:`zeta` / :meth:`rate`."""

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
    antennas: int  # N_t, the UAV's antennas (``config.antennas``)
    array_k: float  # 2 pi d / lambda, the array's spacing d as a phase per unit of cos psi
    axis_x: float  # the array's axis u, x component
    axis_y: float  # the array's axis u, y component (u is horizontal)
    y_c: float  # m, the surface centre's y
    dz_c2: float  # m^2, (z_U - z_c)^2 of the surface's centre
    bits: int  # b of the node's exact b-bit phases (``star_bits``); 0: continuous (aligned) phases

    nodes: np.ndarray  # (3, K): node_y, dz2, jw stacked (the arrays of zeta_point)
    params: np.ndarray  # (len(PARAMS),): the scalars of zeta_point and of the array, in the order of PARAMS

    def zeta(self, x: float, y: float) -> float:
        """zeta at one position (x, y): :func:`zeta_point`, tested equal to ``channel.zeta``."""
        return zeta_point(float(x), float(y), self.nodes, self.params)

    def rate(self, x: float, y: float) -> float:
        """Expected-gain rate log2(1 + eta zeta^2) at one position (x, y)."""
        return rate_point(float(x), float(y), self.nodes, self.params)

    def zetas(self, points: np.ndarray) -> np.ndarray:
        """zeta at the (n, 2) ``points``: :func:`zetas_at` (``channel.zeta``)."""
        return zetas_at(np.ascontiguousarray(points, dtype=np.float64), self.nodes, self.params)

    def rates(self, points: np.ndarray) -> np.ndarray:
        """Expected-gain rates at the (n, 2) ``points``: :func:`rates_at` (``channel.slot_rates``)."""
        return rates_at(np.ascontiguousarray(points, dtype=np.float64), self.nodes, self.params)

    def faded_rate(self, x: float, y: float, rng: np.random.Generator) -> float:
        """One faded-rate sample log2(1 + eta |h|^2) at (x, y): :func:`faded_point` with h_SS
        drawn from ``rng`` in the order of ``channel.faded_rates`` (real, then imaginary part)."""
        n_re, n_im = rng.standard_normal(2)
        return faded_point(float(x), float(y), float(n_re), float(n_im), self.nodes, self.params)


#: The ``ScenarioConfig`` fields no rate kernel reads and a scenario draw changes: a kernel's
#: rows and scalars other than G's (its surface weights, coordinates and side) depend on none.
DRAWN_FIELDS: frozenset[str] = frozenset({"ground_node", "ground_nodes", "T", "q0", "qF"})
_KERNEL_FIELDS: tuple[str, ...] = tuple(
    f.name for f in dataclasses.fields(ScenarioConfig) if f.name not in DRAWN_FIELDS
)
#: Kernel geometries whose base kernel :func:`rate_kernel` and :func:`path_kernels` hold at most.
BASES_HELD = 256
_BASES: dict[tuple, RateKernel] = {}


#: reads the fields of :data:`_KERNEL_FIELDS` in one C call (a drawn scenario's key is read at every reset)
_KERNEL_GETTER = operator.attrgetter(*_KERNEL_FIELDS)


def _kernel_key(config: ScenarioConfig) -> tuple:
    """``config``'s kernel geometry: its fields outside :data:`DRAWN_FIELDS`."""
    return _KERNEL_GETTER(config)


@lru_cache(maxsize=64)
def rate_kernel(config: ScenarioConfig) -> RateKernel:
    """The (cached) :class:`RateKernel` of ``config`` (one ground node: ``ValueError`` if K > 1).

    Built from the kernel of the first config seen with ``config``'s kernel geometry
    (:func:`_base_kernel`) with G's parts (the surface weights, G's coordinates and side) its
    own: the arrays and scalars of :func:`_own_kernel`, bit for bit (tested), without building
    the rest again (a randomised env's reset draws a config per episode)."""
    config.require_single_node("the single-node rate model (slot_rates, average_rate, rate_peak, the env)")
    key = _kernel_key(config)
    base = _BASES.get(key)
    if base is None:
        if len(_BASES) >= BASES_HELD:
            _BASES.clear()
        base = _BASES[key] = _own_kernel(config)
        return base
    jw = config.J * surface_nodes(config).weight
    gx, gy = config.ground_node
    g_side = config.ground_side
    nodes, params = base.nodes.copy(), base.params.copy()
    nodes[2] = jw
    params[PARAM_G_SIDE], params[PARAM_GX], params[PARAM_GY] = g_side, gx, gy
    ground = np.asarray(config.ground_node, dtype=float)
    # base's fields with G's parts replaced (what dataclasses.replace gives: RateKernel checks nothing)
    kernel = copy.copy(base)
    vars(kernel).update(jw=jw, g_side=g_side, ground=ground, gx=gx, gy=gy, nodes=nodes, params=params)
    return kernel


def require_bits_model(config: ScenarioConfig) -> None:
    """``ValueError`` for b-bit phases (``star_bits``) on a multi-antenna UAV (``antennas`` > 1): its
    rate is the closed form of the aligned phases and MRT (``model.miso``), and b-bit phases are
    modelled for one antenna (a scenario may hold both, as a NOMA one may hold several antennas: the
    rate model refuses them, and the envs by ``World.check``)."""
    if config.star_bits is not None and config.antennas > 1:
        raise ValueError(
            f"antennas={config.antennas} with star_bits={config.star_bits}: the multi-antenna UAV's rate is "
            "the closed form of its aligned phases and MRT (model.miso), and b-bit phases are modelled for "
            "a single-antenna UAV: use antennas=1, or star_bits=None"
        )


def _own_kernel(config: ScenarioConfig) -> RateKernel:
    """The :class:`RateKernel` of the single-node ``config`` built from its fields alone
    (:func:`require_bits_model` first)."""
    require_bits_model(config)
    nodes, array = surface_nodes(config), scenario_array(config)
    fields = dict(
        node_y=nodes.y,
        dz2=(config.uav_altitude - nodes.z) ** 2,
        jw=config.J * nodes.weight,
        x_c=config.ios_center[0],
        g_side=config.ground_side,
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
        antennas=array.n_t,
        array_k=2.0 * math.pi * array.spacing_wl,
        axis_x=float(array.axis[0]),
        axis_y=float(array.axis[1]),
        y_c=config.ios_center[1],
        dz_c2=(config.uav_altitude - config.ios_center[2]) ** 2,
        bits=0 if config.star_bits is None else config.star_bits,
    )
    packed = np.vstack([fields["node_y"], fields["dz2"], fields["jw"]])
    params = np.array([float(fields[name]) for name in PARAMS])
    return RateKernel(**fields, nodes=packed, params=params)


def _base_kernel(config: ScenarioConfig) -> RateKernel:
    """A single-node config's :class:`RateKernel` of ``config``'s kernel geometry: what
    :func:`rate_kernel` and :func:`path_kernels` copy besides G's parts, the first config's seen
    with those fields, so a new config per scenario (e.g. each node's of a drawn multi-node
    scenario) builds no kernel of its own."""
    base = _BASES.get(_kernel_key(config))
    return rate_kernel(config) if base is None else base


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


def path_kernels(
    config: ScenarioConfig, grounds: np.ndarray, out: tuple[np.ndarray, np.ndarray] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The rate kernels of one ground node at each of the (P, 2) ``grounds`` (m): ``nodes``
    (P, 3, n) and ``params`` (P, len(PARAMS)), row p equal bit for bit to
    ``rate_kernel(config.replace(ground_node=grounds[p]))``'s ``nodes`` and ``params``. A
    moving node's kernel per slot (``ios_uav_env.model.motion``) without a config per slot:
    only the surface weights and G's coordinates and side depend on G
    (:func:`~ios_uav_env.model.surface.ground_weights`). ``config`` has one node (K = 1).
    New arrays (copies of the held ones when the path's kernels are held, :func:`hold_path_kernels`),
    or written into ``out``, a (``nodes``, ``params``) pair of those shapes (e.g. views of a
    track's arrays), and returned."""
    points = as_positions(grounds, "grounds")
    config.require_single_node("path_kernels")
    base = _base_kernel(config)
    shapes = ((len(points), *base.nodes.shape), (len(points), base.params.size))
    if out is None:
        nodes, params = np.empty(shapes[0]), np.empty(shapes[1])
    else:
        nodes, params = out
        if (nodes.shape, params.shape) != shapes:
            raise ValueError(f"out must hold arrays of shapes {shapes[0]} and {shapes[1]}, got "
                             f"{nodes.shape} and {params.shape}")  # fmt: skip
    held = _HELD.get((config, points.tobytes()))
    if held is not None:
        nodes[:], params[:] = held.nodes, held.params
        return nodes, params
    nodes[:, :2] = base.nodes[:2]
    if not path_weights_into(config, points, nodes[:, 2]):  # (written in place: the same numbers)
        nodes[:, 2] = config.J * ground_weights(config, points)
    params[:] = base.params
    params[:, PARAM_G_SIDE] = np.sign(points[:, 0] - config.ios_center[0])
    params[:, PARAM_GX], params[:, PARAM_GY] = points[:, 0], points[:, 1]
    return nodes, params
