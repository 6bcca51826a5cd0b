"""The rate model of one ground node as compiled scalar functions of rate-kernel rows.

A rate kernel (``rate_kernels.RateKernel``, ``rate_kernels.path_kernels``) is two arrays:
``nodes`` (3, Q), the surface's weighted nodes (y_k, (z_U - z_k)^2, J w_k), and ``params``,
the scalars of zeta(q) in the columns :data:`PARAMS` (G's coordinates and side, the path-loss
and power terms, the UAV's array, the phase bits), named by the ``PARAM_*`` constants. The
functions here evaluate the rate model of :mod:`ios_uav_env.model.channel` on such arrays one
position at a time: the row functions (:func:`zeta_row`, :func:`gain_row`, :func:`rate_row`,
:func:`faded_row`, row ``i`` of a batch of kernels) are inlined into the env's kernels;
:func:`discrete_zeta_row` is the node's exact b-bit phases; :func:`rate_point` and
:func:`rates_at` evaluate one kernel, :func:`rates_of_rows` one kernel per point (equal to
``channel.zeta`` / ``channel.slot_rates`` / ``channel.faded_rates`` to rounding; tested).
Every name here is importable from :mod:`ios_uav_env.model.rate_kernels` too.
"""

from __future__ import annotations

import math

import numpy as np

from ios_uav_env.jit import copy_into, jit

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
def merge_order(part: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """The indices ``part`` ordered by ``offset[part]``, ties in ``part``'s order: a bottom-up
    merge sort (stable, so the order ``np.argsort(offset[part], kind="stable")`` gives). Written
    out rather than numba's ``np.argsort(kind="mergesort")``, which costs about a second more to
    compile, in every process that compiles the b-bit search (each single-node env's reset)."""
    n = part.size
    src, dst = part.copy(), np.empty(n, dtype=np.int64)
    width = 1
    while width < n:
        for start in range(0, n, 2 * width):
            mid, end = min(start + width, n), min(start + 2 * width, n)
            a, b = start, mid
            for o in range(start, end):
                if b >= end or (a < mid and offset[src[a]] <= offset[src[b]]):
                    dst[o] = src[a]
                    a += 1
                else:
                    dst[o] = src[b]
                    b += 1
        src, dst = dst, src
        width *= 2
    return src


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
            copy_into(order[lo:hi], merge_order(order[lo:hi], offset))  # (no slice assignment)
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
def fading_row(x: float, y: float, n_re: float, n_im: float, params: np.ndarray, i: int) -> float:
    """|h|^2 of one fading sample at one position, row ``i``, given the two standard normal draws
    of h_SS (real, then imaginary part): the LoS term of the UAV-G distance's phase plus the
    scattered term, of mean 1 (the kernel's ``los_gain`` and ``nlos_gain``)."""
    dxg, dyg = x - params[i, PARAM_GX], y - params[i, PARAM_GY]
    phase = (
        2.0 * math.pi * math.sqrt(dxg * dxg + dyg * dyg + params[i, PARAM_Z_U2]) / params[i, PARAM_WAVELENGTH]
    )
    re = params[i, PARAM_LOS_GAIN] * math.cos(phase) + params[i, PARAM_NLOS_GAIN] * n_re
    im = -params[i, PARAM_LOS_GAIN] * math.sin(phase) + params[i, PARAM_NLOS_GAIN] * n_im
    return re * re + im * im


@jit(inline=True)
def faded_row(
    x: float, y: float, n_re: float, n_im: float, nodes: np.ndarray, params: np.ndarray, i: int
) -> float:
    """One faded-rate sample log2(1 + eta zeta^2 |h|^2) at one position, row ``i``, given the two
    standard normal draws of h_SS (real, then imaginary part, :func:`fading_row`): the scalar form of
    ``channel.faded_rates``."""
    z = zeta_row(x, y, nodes, params, i)
    return math.log2(1.0 + params[i, PARAM_ETA] * z * z * fading_row(x, y, n_re, n_im, params, i))


#: ln 2, the factor of 2^r - 1 = expm1(r ln 2) in :func:`faded_of_rate`.
LN2 = math.log(2.0)


@jit(fastmath=False)
def faded_of_rate(
    rate: float, x: float, y: float, n_re: float, n_im: float, params: np.ndarray, i: int
) -> float:
    """:func:`faded_row` of a position whose expected-gain rate ``rate`` = log2(1 + eta zeta^2) is
    known (one antenna, continuous phases): eta zeta^2 = 2^rate - 1, so the sample is
    log2(1 + (2^rate - 1) |h|^2), with no sum over the surface. Equal to :func:`faded_row` to the
    rounding of the carrier phase 2 pi d / lambda, which IEEE and fast-math round differently
    (~1e-11 relative; tested). IEEE arithmetic, a function of its own: the same bits from a
    kernel's loop and from Python, given the same ``rate``."""
    return math.log2(1.0 + math.expm1(rate * LN2) * fading_row(x, y, n_re, n_im, params, i))


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


@jit
def rates_of_rows(points: np.ndarray, nodes: np.ndarray, params: np.ndarray) -> np.ndarray:
    """Expected-gain rate at each of the (n, 2) ``points``, point i under kernel row i
    (:func:`rate_row`; ``nodes`` (n, 3, K), ``params`` (n, P), e.g. ``rate_kernels.path_kernels``)."""
    out = np.empty(points.shape[0])
    for i in range(points.shape[0]):
        out[i] = rate_row(points[i, 0], points[i, 1], nodes, params, i)
    return out
