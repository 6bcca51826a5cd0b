"""The rate model of one ground node as compiled scalar kernels, and the kernels of a moving node.

:func:`rate_kernel` packs a config's constants of zeta(q) (the surface's weighted nodes, G's
coordinates and side, the path-loss and power terms) into two arrays, ``nodes`` (3, Q) and
``params`` (columns :data:`PARAMS`), and the compiled functions here evaluate the rate model of
:mod:`ios_uav_env.model.channel` on them one position at a time: :func:`zeta_row`,
:func:`rate_row` and :func:`faded_row` inlined into the env's kernels, :func:`rate_point` and
:func:`rates_at` for one kernel, :func:`rates_of_rows` for one kernel per point (equal to
``channel.zeta`` / ``channel.slot_rates`` / ``channel.faded_rates`` to rounding; tested).
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

from ios_uav_env.jit import jit
from ios_uav_env.model.array import scenario_array
from ios_uav_env.model.config import ScenarioConfig
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


#: Layout of ``RateKernel.params`` (the scalars of :func:`zeta_point`), by name.
PARAMS = (
    "x_c", "g_side", "t_factor", "has_surface", "gx", "gy", "z_u2", "k_direct", "d_exp", "eta",
    "wavelength", "los_gain", "nlos_gain", "antennas", "array_k", "axis_x", "axis_y", "y_c", "dz_c2", "bits",
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
PARAM_ANTENNAS = PARAMS.index("antennas")
PARAM_ARRAY_K = PARAMS.index("array_k")
PARAM_AXIS_X = PARAMS.index("axis_x")
PARAM_AXIS_Y = PARAMS.index("axis_y")
PARAM_Y_C = PARAMS.index("y_c")
PARAM_DZ_C2 = PARAMS.index("dz_c2")
PARAM_BITS = PARAMS.index("bits")


@jit(inline=True)
def amplitudes_row(x: float, y: float, nodes: np.ndarray, params: np.ndarray, i: int) -> tuple[float, float]:
    """The phase-aligned surface amplitude sum_m a_m and the direct amplitude a_D at one position
    (``channel.surface_amplitude``, ``channel.direct_amplitude``) as a loop over the surface nodes,
    for row ``i`` of a batch of rate kernels (``nodes`` (B, 3, K): y_k, (z_U - z_k)^2, J w_k;
    ``params`` (B, P): the scalars of :data:`PARAMS`). Inlined into the compiled kernels that
    call it (the env's hot path) and indexed in place: no per-row array views, which cost more
    than the sum itself."""
    dxg, dyg = x - params[i, PARAM_GX], y - params[i, PARAM_GY]
    direct = (
        params[i, PARAM_K_DIRECT] * (dxg * dxg + dyg * dyg + params[i, PARAM_Z_U2]) ** params[i, PARAM_D_EXP]
    )
    dx = x - params[i, PARAM_X_C]
    if params[i, PARAM_HAS_SURFACE] == 0.0 or dx == 0.0:
        return 0.0, direct
    side = 1.0 if dx * params[i, PARAM_G_SIDE] > 0.0 else params[i, PARAM_T_FACTOR]
    dx2, total = dx * dx, 0.0
    for k in range(nodes.shape[2]):
        dy = y - nodes[i, 0, k]
        d2 = dy * dy + nodes[i, 1, k] + dx2
        total += nodes[i, 2, k] / (d2 * d2)
    return side * abs(dx) ** 3 * total, direct


#: Bucket size above which :func:`offset_order` sorts a bucket by merge sort (else by insertion).
_INSERTION_MAX = 32


@jit(fastmath=False)
def offset_order(offset: np.ndarray, m: int, width: float) -> np.ndarray:
    """The indices of ``offset[:m]``, numbers in [0, ``width``], in increasing order, ties by index
    (a stable sort): a bucket sort, m buckets of equal width (monotone in the offset, so the
    buckets in turn are in order), each sorted by insertion, or by merge sort when larger than
    :data:`_INSERTION_MAX`. Linear time for offsets spread over [0, width] (element phases are),
    where the compiled ``np.argsort`` (quicksort) of M numbers costs most of the search."""
    count = np.zeros(m + 1, dtype=np.int64)
    bucket = np.empty(m, dtype=np.int64)
    for k in range(m):
        b = min(max(int(offset[k] / width * m), 0), m - 1)
        bucket[k] = b
        count[b + 1] += 1
    for b in range(m):
        count[b + 1] += count[b]
    fill = count[:m].copy()
    order = np.empty(m, dtype=np.int64)
    for k in range(m):
        order[fill[bucket[k]]] = k
        fill[bucket[k]] += 1
    for b in range(m):
        lo, hi = count[b], count[b + 1]
        if hi - lo > _INSERTION_MAX:
            part = order[lo:hi].copy()
            order[lo:hi] = part[np.argsort(offset[part], kind="mergesort")]
            continue
        for p in range(lo + 1, hi):
            k, value = order[p], offset[order[p]]
            q = p - 1
            while q >= lo and offset[order[q]] > value:
                order[q + 1] = order[q]
                q -= 1
            order[q + 1] = k
    return order


@jit(fastmath=False)
def discrete_zeta_row(x: float, y: float, nodes: np.ndarray, params: np.ndarray, i: int) -> float:
    """The channel amplitude of the node served at its exact b-bit phases, b = ``params[i,
    PARAM_BITS]`` >= 1, at one position, row ``i``: max over theta in {0, 2 pi / 2^b, ...}^M of
    |a_D + sum_m a_m e^{j (phi_m - theta_m)}|, the element amplitudes a_m of :func:`amplitudes_row`
    and phi_m = 2 pi / lambda (d_UG - d_Um - d_mG) the phase that lines element m up with the direct
    path (``channel.phase_shifts``). ``nodes`` must be the elements themselves (a config with
    ``star_bits`` has no compression: ``surface.node_count``); an element is read from its node
    (y_m, (z_U - z_m)^2, J beta_m), its distance to G from the node and G's coordinates, and a node
    of zero weight (a batch's padding) is skipped.

    The search is ``star_rows.discrete_phases``' (exact; the derivation is its docstring's): for a
    direction psi of the sum, each element's best level is the one nearest phi_m - psi, and the
    optimum's own direction gives a setting at least as good as the optimum, so scanning psi over
    [0, 2 pi) visits it. Element m's level changes at psi = f_m + c 2 pi / 2^b, c = 0 .. 2^b - 1,
    with f_m in [0, 2 pi / 2^b], so the M 2^b breakpoints in order are the M offsets f_m sorted,
    passed 2^b times: one sort of M numbers (:func:`offset_order`; the row function sorts all
    M 2^b). The amplitude returned is summed again at the best setting found, element by element
    (not the running sum's). IEEE arithmetic (``fastmath=False``): the same bits whichever kernel
    calls it."""
    dxg, dyg = x - params[i, PARAM_GX], y - params[i, PARAM_GY]
    dug2 = dxg * dxg + dyg * dyg + params[i, PARAM_Z_U2]
    direct = params[i, PARAM_K_DIRECT] * dug2 ** params[i, PARAM_D_EXP]
    dx = x - params[i, PARAM_X_C]
    if params[i, PARAM_HAS_SURFACE] == 0.0 or dx == 0.0:
        return direct
    side = 1.0 if dx * params[i, PARAM_G_SIDE] > 0.0 else params[i, PARAM_T_FACTOR]
    levels = 2 ** int(params[i, PARAM_BITS])
    step = 2.0 * math.pi / levels
    wave = 2.0 * math.pi / params[i, PARAM_WAVELENGTH]
    d_ug, z_u = math.sqrt(dug2), math.sqrt(params[i, PARAM_Z_U2])
    gx_c, gy = params[i, PARAM_GX] - params[i, PARAM_X_C], params[i, PARAM_GY]
    scale, dx2 = side * abs(dx) ** 3, dx * dx
    n = nodes.shape[2]
    t_re, t_im, offset = np.empty(n), np.empty(n), np.empty(n)
    m = 0  # elements read (nodes of nonzero weight)
    s_re, s_im = direct, 0.0
    for k in range(n):
        weight = nodes[i, 2, k]
        if weight == 0.0:
            continue
        dy = y - nodes[i, 0, k]
        d2 = dy * dy + nodes[i, 1, k] + dx2  # d_Um^2
        amp = scale * weight / (d2 * d2)
        z_m = z_u - math.sqrt(nodes[i, 1, k])
        gy_m = gy - nodes[i, 0, k]
        phi = wave * (d_ug - math.sqrt(d2) - math.sqrt(gx_c * gx_c + gy_m * gy_m + z_m * z_m))
        r = phi - math.floor(phi / step + 0.5) * step  # phi_m - its nearest level, in [-step/2, step/2]
        t_re[m], t_im[m] = amp * math.cos(r), amp * math.sin(r)
        offset[m] = r + 0.5 * step  # f_m: the element's first breakpoint
        s_re += t_re[m]
        s_im += t_im[m]
        m += 1
    order = offset_order(offset, m, step)
    turn_re, turn_im = np.empty(levels + 1), np.empty(levels + 1)  # e^{j c step}
    for c in range(levels + 1):
        turn_re[c], turn_im[c] = math.cos(c * step), math.sin(c * step)
    best, best_pass, best_rank = s_re * s_re + s_im * s_im, 0, -1  # (no breakpoint passed)
    for c in range(levels):  # the c-th breakpoint of each element turns its term by one more level
        f_re, f_im = turn_re[c + 1] - turn_re[c], turn_im[c + 1] - turn_im[c]
        for p in range(m):
            k = order[p]
            s_re += t_re[k] * f_re - t_im[k] * f_im
            s_im += t_re[k] * f_im + t_im[k] * f_re
            value = s_re * s_re + s_im * s_im
            if value > best:
                best, best_pass, best_rank = value, c, p
    a_re, a_im = direct, 0.0
    for p in range(m):
        k = order[p]
        c = best_pass + 1 if p <= best_rank else best_pass
        a_re += t_re[k] * turn_re[c] - t_im[k] * turn_im[c]
        a_im += t_re[k] * turn_im[c] + t_im[k] * turn_re[c]
    return math.sqrt(a_re * a_re + a_im * a_im)


@jit(inline=True)
def zeta_row(x: float, y: float, nodes: np.ndarray, params: np.ndarray, i: int) -> float:
    """The channel amplitude of the node served at one position, the formula of ``channel.zeta``:
    zeta = sum_m a_m + a_D at its aligned phases (:func:`amplitudes_row`), or with b-bit phases
    (``params[i, PARAM_BITS]`` = b > 0, ``ScenarioConfig.star_bits``) at its exact b-bit phases
    (:func:`discrete_zeta_row`)."""
    if params[i, PARAM_BITS] != 0.0:
        return discrete_zeta_row(x, y, nodes, params, i)
    surface, direct = amplitudes_row(x, y, nodes, params, i)
    return surface + direct


@jit(inline=True)
def array_factor_row(x: float, y: float, params: np.ndarray, i: int) -> float:
    """|a_c^T conj(a_G)| at one position, row ``i``: the UAV array's steering vectors towards the
    surface's centre and towards G (``channel.array_factor``), sum_n cos(k delta_n (cos psi_c -
    cos psi_G)) with the centred indices delta_n and k = 2 pi d / lambda (the vectors' product is real)."""
    n_t = params[i, PARAM_ANTENNAS]
    ux, uy = params[i, PARAM_AXIS_X], params[i, PARAM_AXIS_Y]
    cx, cy = params[i, PARAM_X_C] - x, params[i, PARAM_Y_C] - y
    gx, gy = params[i, PARAM_GX] - x, params[i, PARAM_GY] - y
    cos_c = (ux * cx + uy * cy) / math.sqrt(cx * cx + cy * cy + params[i, PARAM_DZ_C2])
    cos_g = (ux * gx + uy * gy) / math.sqrt(gx * gx + gy * gy + params[i, PARAM_Z_U2])
    step, total = params[i, PARAM_ARRAY_K] * (cos_c - cos_g), 0.0
    for n in range(int(n_t)):
        total += math.cos(step * (n - 0.5 * (n_t - 1.0)))
    return abs(total)


@jit(inline=True)
def gain_row(x: float, y: float, nodes: np.ndarray, params: np.ndarray, i: int) -> float:
    """The slot's SNR at one position, row ``i``: eta zeta^2 for one antenna, and for N_t the
    closed-form optimum of ``model.miso`` (aligned phases and MRT), eta (N_t (S^2 + a_D^2) +
    2 S a_D |a_c^T conj(a_G)|) with S = sum_m a_m (``channel.aligned_gain``)."""
    n_t = params[i, PARAM_ANTENNAS]
    if n_t <= 1.0:  # (one antenna; a row of zeros, as hand-built or padding rows, reads as one too)
        z = zeta_row(x, y, nodes, params, i)
        return params[i, PARAM_ETA] * z * z
    surface, direct = amplitudes_row(x, y, nodes, params, i)
    cross = 2.0 * surface * direct * array_factor_row(x, y, params, i)
    return params[i, PARAM_ETA] * (n_t * (surface * surface + direct * direct) + cross)


@jit(inline=True)
def rate_row(x: float, y: float, nodes: np.ndarray, params: np.ndarray, i: int) -> float:
    """Expected-gain rate log2(1 + eta zeta^2) at one position, row ``i`` (see :func:`zeta_row`);
    for N_t antennas log2(1 + G), the closed-form optimum of ``model.miso`` (:func:`gain_row`)."""
    return math.log2(1.0 + gain_row(x, y, nodes, params, i))


@jit(inline=True)
def faded_row(
    x: float, y: float, n_re: float, n_im: float, nodes: np.ndarray, params: np.ndarray, i: int
) -> float:
    """One faded-rate sample log2(1 + eta |h|^2) at one position, row ``i``, given the two
    standard normal draws of h_SS (real, then imaginary part): the scalar form of ``channel.faded_rates``."""
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
def zetas_at(points: np.ndarray, nodes: np.ndarray, params: np.ndarray) -> np.ndarray:
    """:func:`zeta_point` at each of the (n, 2) ``points`` (one compiled loop)."""
    out = np.empty(points.shape[0])
    for i in range(points.shape[0]):
        out[i] = zeta_point(points[i, 0], points[i, 1], nodes, params)
    return out


@jit
def rates_at(points: np.ndarray, nodes: np.ndarray, params: np.ndarray) -> np.ndarray:
    """:func:`rate_point` at each of the (n, 2) ``points`` (one compiled loop): the
    expected-gain rates of ``channel.slot_rates`` for the kernel's config, without its (n, nodes)
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
    g_side = float(np.sign(gx - config.ios_center[0]))
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


@jit
def rates_of_rows(points: np.ndarray, nodes: np.ndarray, params: np.ndarray) -> np.ndarray:
    """Expected-gain rate at each of the (n, 2) ``points``, point i under kernel row i
    (:func:`rate_row`; ``nodes`` (n, 3, K), ``params`` (n, P), e.g. :func:`path_kernels`)."""
    out = np.empty(points.shape[0])
    for i in range(points.shape[0]):
        out[i] = rate_row(points[i, 0], points[i, 1], nodes, params, i)
    return out
