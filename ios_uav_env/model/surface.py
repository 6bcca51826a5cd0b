"""Geometry of the IOS and the weighted-node form of its element sum.

Every element lies in the plane x = x_c (``config.ios_center[0]``), so for a UAV at
horizontal position q = (x, y) and altitude z_U the phase-aligned cascaded amplitude of
eq. (14) factorises as

    sum_m a_m = J * s(q) * |x - x_c|^3 * sum_m beta_m / d_Um(q)^4,
    beta_m = |x_G - x_c|^3 / d_mG^4,

with s(q) = 1 on the reflecting side, epsilon (IOS) or 0 (RIS) on the transmitting side.
The sum over m is a weighted sum of the smooth function f(y_m, z_m) = d_Um^-4 over the
element grid. :func:`surface_nodes` replaces it by an equivalent sum over n x n Chebyshev
nodes per axis whose weights are the element weights projected on the Lagrange basis:
exact for f polynomial of degree < n along each axis.

**Accuracy.** Along y, f has poles at a distance c >= z_U - z_top from the surface (z_top its
top row), along z at the UAV altitude; with a the half-size of an axis, Chebyshev
interpolation converges like rho^-n with the Bernstein-ellipse parameter
rho_y = c/a_y + sqrt(1 + (c/a_y)^2) and rho_z = w + sqrt(w^2 - 1), w = (z_U - z_c)/a_z.
:func:`node_count` takes the fewest n >= ``quadrature_nodes`` with (n + 1)^2 rho^-n <=
``quadrature_tol`` (rho the smaller of the two; an a-priori bound, checked against the exact
sum in the tests), and the exact sum once n reaches the grid size: a UAV close above a large
surface gets more nodes, never a silently wrong amplitude. At the paper's geometry n = 8 and
the error is ~1e-16. ``quadrature_nodes = 0`` always sums over the elements;
``quadrature_tol = inf`` uses exactly ``quadrature_nodes`` (the planners' coarse surrogates). A
STAR surface of b-bit phases (``star_bits``) always sums over the elements, whatever the
quadrature fields: its best phases are chosen element by element (``rate_rows.discrete_zeta_row``
reads each element's position and weight from the nodes).

**The ground side.** The node weights ly beta lz^T need the M element weights beta_m of G,
one division each, for every G: a moving node's kernel per slot paid M divisions and an
(n x M) projection. beta is smooth over the grid too: as a function of y_m it has poles at
y_G +- i sqrt((x_G - x_c)^2 + z_m^2), at least z_bottom (the lowest row's height) from the
grid, and as a function of z_m at +- i times G's horizontal distance to the element, in the
worst case (G at the foot of the surface) at z = 0 below it. So the node weights are taken
from beta at p x p Chebyshev points of the grid instead, ly Py^T B Pz lz^T with Py, Pz the
Lagrange interpolation matrices of those points at the elements (``ky = ly Py^T`` and ``kz =
lz Pz^T`` fixed per geometry): p^2 divisions per G. :func:`ground_count` takes the fewest
p >= ``quadrature_nodes`` whose bound of the same form, (p + 1)^2 rho^-p at the worst-case G
(rho_y = c/a_y + sqrt(1 + (c/a_y)^2) with c = z_bottom, rho_z = w + sqrt(w^2 - 1) with
w = z_c / a_z), is <= ``GROUND_TOL_SHARE`` x ``quadrature_tol``, and the element weights
themselves (the exact beta) once p would reach the grid size, with the exact sum
(``quadrature_nodes = 0``, or the nodes reaching the grid) or with ``quadrature_tol = inf``.
At the paper's geometry p = 9 and the bound is ~6e-15. Every G, a configured node's
(:func:`surface_nodes`) or a moving node's (:func:`ground_weights`), goes through the same
arithmetic, point by point, so the two are equal bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ios_uav_env.jit import HAVE_NUMBA, jit
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.weight_kernels import (
    WEIGHT_BLOCK,
    interpolated_weights,
    interpolated_weights_into,
    point_weights,
)

#: Share of ``quadrature_tol`` that the ground side's interpolation of beta may take (module
#: docstring): the amplitude's relative error stays within (1 + this) x ``quadrature_tol``.
GROUND_TOL_SHARE = 0.01


def element_positions(config: ScenarioConfig) -> np.ndarray:
    """(M, 3) element centres (x_m, y_m, z_m): a lambda/2 grid in the plane x = x_c.

    Columns run along y (M_y of them), rows along z (M_z); element m = i * M_z + k.
    """
    ys, zs = _axes(config)
    yy, zz = np.meshgrid(ys, zs, indexing="ij")
    xx = np.full(yy.size, config.ios_center[0])
    return np.column_stack([xx, yy.ravel(), zz.ravel()])


def _axes(config: ScenarioConfig) -> tuple[np.ndarray, np.ndarray]:
    m_y, m_z = config.ios_shape
    step = config.element_spacing
    _, yc, zc = config.ios_center
    ys = yc + (np.arange(m_y) - 0.5 * (m_y - 1)) * step
    zs = zc + (np.arange(m_z) - 0.5 * (m_z - 1)) * step
    return ys, zs


def element_to_ground(config: ScenarioConfig) -> tuple[np.ndarray, np.ndarray]:
    """Per-element distance d_mG to G and |x_G - x_m| / d_mG (the departure cosine), shape (M,)."""
    config.require_single_node("element_to_ground")
    elements = element_positions(config)
    xg, yg = config.ground_node
    diff = np.column_stack([xg - elements[:, 0], yg - elements[:, 1], -elements[:, 2]])
    d_mg = np.linalg.norm(diff, axis=1)
    return d_mg, np.abs(diff[:, 0]) / d_mg


@dataclass(frozen=True)
class SurfaceNodes:
    """The element sum as weighted nodes: sum_m beta_m f(w_m) == sum_k weight_k f(node_k)."""

    y: np.ndarray  # (K,) m, node y coordinates
    z: np.ndarray  # (K,) m, node z coordinates
    weight: np.ndarray  # (K,) beta-weights in m^-1 (|x_G - x_c|^3 / d_mG^4 for real elements)
    exact: bool  # True when the nodes are the elements themselves


def _lagrange_matrix(nodes: np.ndarray, points: np.ndarray) -> np.ndarray:
    """L[a, i] = L_a(points[i]): Lagrange basis on ``nodes`` evaluated at ``points``."""
    diff = points[None, :] - nodes[:, None]  # (n, P)
    # row a: the products over b != a in ascending b (np.prod's order; from 1.0, and x * 1.0 is x),
    # every row's factor b at once: the loop is over the few nodes, not over elements
    num, den = np.ones((nodes.size, points.size)), np.ones(nodes.size)
    for b in range(nodes.size):
        num[:b] *= diff[b]
        num[b + 1 :] *= diff[b]
        den[:b] *= nodes[:b] - nodes[b]
        den[b + 1 :] *= nodes[b + 1 :] - nodes[b]
    return num / den[:, None]


def _chebyshev(lo: float, hi: float, n: int) -> np.ndarray:
    k = np.arange(n)
    return 0.5 * (lo + hi) + 0.5 * (hi - lo) * np.cos((2 * k + 1) * np.pi / (2 * n))[::-1]


def quadrature_error_bound(config: ScenarioConfig, n: int) -> float:
    """A-priori bound (n + 1)^2 rho^-n of the relative error of the n-node compression (see the
    module docstring); 0 when n covers the grid (the sum is then exact)."""
    ys, zs = _axes(config)
    if n >= ys.size and n >= zs.size:
        return 0.0
    a_y, a_z = 0.5 * (ys[-1] - ys[0]), 0.5 * (zs[-1] - zs[0])
    c = config.uav_altitude - zs[-1]
    rho_y = c / a_y + math.sqrt(1.0 + (c / a_y) ** 2) if a_y > 0 else math.inf
    w = (config.uav_altitude - 0.5 * (zs[0] + zs[-1])) / a_z if a_z > 0 else math.inf
    rho_z = w + math.sqrt(w * w - 1.0) if a_z > 0 else math.inf
    rho = min(rho_y if n < ys.size else math.inf, rho_z if n < zs.size else math.inf)
    return (n + 1) ** 2 * rho ** (-n) if rho > 1 else math.inf


def node_count(config: ScenarioConfig) -> int:
    """Nodes per axis of the compression of ``config`` (0: the exact per-element sum, always with
    b-bit phases, ``star_bits``)."""
    n = config.quadrature_nodes
    if config.star_bits is not None:
        return 0
    if n == 0 or math.isinf(config.quadrature_tol):
        return n
    largest = max(config.ios_shape)
    while n < largest and quadrature_error_bound(config, n) > config.quadrature_tol:
        n += 1
    return 0 if n >= largest else n


def ground_error_bound(config: ScenarioConfig, p: int) -> float:
    """A-priori bound (p + 1)^2 rho^-p of the relative error of beta's interpolation at p x p
    Chebyshev points of the grid, for any ground node (the module docstring's worst case); 0
    when p covers the grid."""
    ys, zs = _axes(config)
    if p >= ys.size and p >= zs.size:
        return 0.0
    a_y, a_z = 0.5 * (ys[-1] - ys[0]), 0.5 * (zs[-1] - zs[0])
    c = zs[0]
    if c <= 0.0:  # (a row at or below the ground: G can sit on a pole)
        return math.inf
    rho_y = c / a_y + math.sqrt(1.0 + (c / a_y) ** 2) if a_y > 0 else math.inf
    w = 0.5 * (zs[0] + zs[-1]) / a_z if a_z > 0 else math.inf
    rho_z = w + math.sqrt(w * w - 1.0) if a_z > 0 else math.inf
    rho = min(rho_y if p < ys.size else math.inf, rho_z if p < zs.size else math.inf)
    return (p + 1) ** 2 * rho ** (-p) if rho > 1 else math.inf


def ground_count(config: ScenarioConfig) -> int:
    """Points per axis of the ground side's interpolation of beta (module docstring; 0: the
    element weights themselves, e.g. with the exact sum or ``quadrature_tol = inf``)."""
    n = config.quadrature_nodes
    if n == 0 or math.isinf(config.quadrature_tol) or node_count(config) == 0:
        return 0
    largest, tol = max(config.ios_shape), GROUND_TOL_SHARE * config.quadrature_tol
    p = n
    while p < largest and ground_error_bound(config, p) > tol:
        p += 1
    return 0 if p >= largest else p


@dataclass(frozen=True, eq=False)
class _Projection:
    """The ground-free part of the compression: node coordinates and the Lagrange projections
    (``ly`` (ny, M_y), ``lz`` (nz, M_z); None when the nodes are the elements themselves), and
    the ground side's (module docstring): the interpolation points' y (``gy`` (py,)) and squared
    z (``gz2`` (pz,)), ``ky = ly Py^T`` (ny, py) and ``kz = lz Pz^T`` (nz, pz); None when the
    weights take the element weights themselves."""

    y: np.ndarray
    z: np.ndarray
    ly: np.ndarray | None
    lz: np.ndarray | None
    gy: np.ndarray | None = None
    gz2: np.ndarray | None = None
    ky: np.ndarray | None = None
    kz: np.ndarray | None = None
    ky_t: np.ndarray | None = None  # (py, ny): ky^T, C order (the compiled loops' rows)
    kz_t: np.ndarray | None = None  # (pz, nz)


class _Geometry:
    """``config`` hashed and compared by the fields its :class:`_Projection` depends on (the
    grid: ``ios_shape``, the pitch, ``ios_center``; the node count: ``uav_altitude``, the
    quadrature fields and whether the phases have bits), not by G, T, q0, qF or the surface's kind
    otherwise: the key of the projection's
    cache, so the drawn scenarios of a family share one projection per surface size."""

    __slots__ = ("config", "key")

    def __init__(self, config: ScenarioConfig) -> None:
        self.config = config
        self.key = (
            config.ios_shape, config.element_spacing_wl, config.wavelength, config.ios_center,
            config.uav_altitude, config.quadrature_nodes, config.quadrature_tol, config.star_bits is not None,
        )  # fmt: skip

    def __hash__(self) -> int:
        return hash(self.key)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, _Geometry) and self.key == other.key


def _projection(config: ScenarioConfig) -> _Projection:
    """The :class:`_Projection` of ``config``'s geometry (cached per geometry, :class:`_Geometry`)."""
    return _geometry_projection(_Geometry(config))


@lru_cache(maxsize=128)
def _geometry_projection(geometry: _Geometry) -> _Projection:
    config = geometry.config
    ys, zs = _axes(config)
    n = node_count(config)
    if n == 0 or (n >= ys.size and n >= zs.size):
        yy, zz = np.meshgrid(ys, zs, indexing="ij")
        return _Projection(yy.ravel(), zz.ravel(), None, None)
    ny, nz = min(n, ys.size), min(n, zs.size)
    node_y = ys if ny == ys.size else _chebyshev(ys[0], ys[-1], ny)
    node_z = zs if nz == zs.size else _chebyshev(zs[0], zs[-1], nz)
    ly = np.eye(ny) if ny == ys.size else _lagrange_matrix(node_y, ys)
    lz = np.eye(nz) if nz == zs.size else _lagrange_matrix(node_z, zs)
    yy, zz = np.meshgrid(node_y, node_z, indexing="ij")
    p = ground_count(config)
    if p == 0:
        return _Projection(yy.ravel(), zz.ravel(), ly, lz)
    py, pz = min(p, ys.size), min(p, zs.size)
    gy = ys if py == ys.size else _chebyshev(ys[0], ys[-1], py)
    gz = zs if pz == zs.size else _chebyshev(zs[0], zs[-1], pz)
    ky = ly if py == ys.size else ly @ _lagrange_matrix(gy, ys).T
    kz = lz if pz == zs.size else lz @ _lagrange_matrix(gz, zs).T
    return _Projection(yy.ravel(), zz.ravel(), ly, lz, gy, gz * gz, ky, kz, np.ascontiguousarray(ky.T),
                       np.ascontiguousarray(kz.T))  # fmt: skip


def _weights(projection: _Projection, beta: np.ndarray) -> np.ndarray:
    """The node weights of the (M_y, M_z) element weights ``beta``: ly beta lz^T, flattened."""
    if projection.ly is None:
        return beta.ravel()
    return (projection.ly @ beta @ projection.lz.T).ravel()


def _betas(config: ScenarioConfig, grounds: np.ndarray) -> np.ndarray:
    """(P, M_y, M_z) element weights beta_m = |x_G - x_c|^3 / d_mG^4 of a ground node at each of
    the (P, 2) ``grounds``. Every element lies in the plane x = x_c, so d_mG^2 = (x_G - x_c)^2
    + (y_G - y_m)^2 + z_m^2 is a sum of a y-column term and a z-row term (one outer sum per G)."""
    ys, zs = _axes(config)
    dx2 = (grounds[:, 0] - config.ios_center[0]) ** 2
    dy2 = (grounds[:, 1, None] - ys[None, :]) ** 2  # (P, M_y)
    if HAVE_NUMBA:  # the same IEEE operations in one pass, without the (P, M_y, M_z) temporaries
        return _beta_grid(dx2**1.5, dx2, dy2, zs * zs)
    d2 = dx2[:, None, None] + dy2[:, :, None] + (zs * zs)[None, None, :]
    return (dx2**1.5)[:, None, None] / (d2 * d2)


@jit(fastmath=False)
def _beta_grid(scale: np.ndarray, dx2: np.ndarray, dy2: np.ndarray, z2: np.ndarray) -> np.ndarray:
    """out[p, i, k] = scale[p] / d2^2 with d2 = (dx2[p] + dy2[p, i]) + z2[k]: :func:`_betas`'s
    numpy expression element by element, in IEEE arithmetic (no fused multiply-add, no
    reassociation), so bit for bit the same."""
    out = np.empty((dy2.shape[0], dy2.shape[1], z2.shape[0]))
    for p in range(dy2.shape[0]):
        for i in range(dy2.shape[1]):
            row = dx2[p] + dy2[p, i]
            for k in range(z2.shape[0]):
                d2 = row + z2[k]
                out[p, i, k] = scale[p] / (d2 * d2)
    return out


@lru_cache(maxsize=64)
def surface_nodes(config: ScenarioConfig) -> SurfaceNodes:
    """Weighted nodes of the element sum for ``config`` (cached per config)."""
    config.require_single_node("surface_nodes")
    projection = _projection(config)
    ground = np.array([config.ground_node], dtype=float)
    if projection.ky is not None:
        weight = _ground_weights(config, projection, ground)[0]
    else:
        weight = _weights(projection, _betas(config, ground)[0])
    return SurfaceNodes(projection.y, projection.z, weight, exact=projection.ly is None)


def ground_weights(config: ScenarioConfig, grounds: np.ndarray) -> np.ndarray:
    """(P, n) node weights of :func:`surface_nodes` for a ground node at each of the (P, 2)
    ``grounds`` (m), every other field of ``config`` (one node) kept: the nodes' coordinates do
    not depend on G, so a moving node's per-slot surfaces share one projection. Row p equals
    ``surface_nodes(config.replace(ground_node=grounds[p])).weight`` bit for bit (the same
    arithmetic on each slice)."""
    config.require_single_node("ground_weights")
    projection = _projection(config)
    points = np.asarray(grounds, dtype=float)
    if points.ndim != 2 or points.shape[1] != 2:
        raise ValueError(f"grounds must have shape (P, 2) (m), got {points.shape}")
    if projection.ky is not None:
        return _ground_weights(config, projection, points)
    betas = _betas(config, points)
    if projection.ly is None:
        return betas.reshape(len(points), -1)
    # one stacked product: numpy's matmul runs the same BLAS product on each slice as _weights
    return np.matmul(np.matmul(projection.ly, betas), projection.lz.T).reshape(len(points), -1)


def path_weights_into(config: ScenarioConfig, grounds: np.ndarray, out: np.ndarray) -> bool:
    """Write ``config.J * ground_weights(config, grounds)`` ((P, n), the surface weights of the
    ``channel.path_kernels`` of the (P, 2) ``grounds``) into ``out`` ((P, n), any view: a batched
    row's buffer, the weight rows of a path's kernels), bit for bit, and return True: one
    compiled call that allocates nothing (``weight_kernels.interpolated_weights_into``; the block
    and the point forms give the same bits, so it takes the block form for any P). False, with
    nothing written, where that call does not apply: without numba, on a surface whose weights are
    not interpolated (its elements', or the Lagrange projection of its elements'), or an ``out``
    of another shape."""
    projection = _projection(config)
    if not HAVE_NUMBA or projection.ky is None or out.shape != (len(grounds), projection.y.size):
        return False
    dx2, dy2 = _ground_terms(config, projection, grounds)
    interpolated_weights_into(out, config.J, dx2**1.5, dx2, dy2, projection.gz2, projection.ky_t,
                              projection.kz_t)  # fmt: skip
    return True


def interpolation_terms(
    config: ScenarioConfig,
) -> tuple[float, float, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """What :func:`path_weights_into` computes a path's weights of ``config`` (one node) from:
    (J, x_c, gy (py,), gz2 (pz,), ky_t (py, ny), kz_t (pz, nz)), the arguments of
    ``weight_kernels.interpolated_weights_into`` besides the points' own terms (dx2 = (x - x_c)^2,
    its power 1.5 and dy2 = (y - gy)^2); None where that call does not apply (no numba, a surface
    whose weights are not interpolated). For callers that compute many paths' weights at once
    (``envs.mobile_draws``)."""
    projection = _projection(config)
    if not HAVE_NUMBA or projection.ky is None:
        return None
    assert projection.gy is not None and projection.gz2 is not None
    assert projection.ky_t is not None and projection.kz_t is not None
    return (config.J, float(config.ios_center[0]), projection.gy, projection.gz2, projection.ky_t,
            projection.kz_t)  # fmt: skip


def _ground_terms(
    config: ScenarioConfig, projection: _Projection, grounds: np.ndarray
) -> tuple[np.ndarray, ...]:
    """(dx2 (P,), dy2 (P, py)): the squared distances of the (P, 2) ``grounds`` to the IOS plane and
    to the ground side's interpolation rows (:func:`_ground_weights`)."""
    assert projection.gy is not None
    dx2 = (grounds[:, 0] - config.ios_center[0]) ** 2
    dy2 = (grounds[:, 1, None] - projection.gy[None, :]) ** 2  # (P, py)
    return dx2, dy2


def _ground_weights(config: ScenarioConfig, projection: _Projection, grounds: np.ndarray) -> np.ndarray:
    """(P, ny nz) node weights ky B kz^T of the (P, 2) ``grounds``, B (py, pz) beta at the
    ground side's points (module docstring): :func:`interpolated_weights` compiled (a path of
    points; :func:`point_weights` for fewer than :data:`WEIGHT_BLOCK`), or the same
    IEEE operations in the same order as numpy (without numba), so the same bits either way."""
    assert projection.gy is not None and projection.gz2 is not None
    assert projection.ky is not None and projection.kz is not None
    dx2, dy2 = _ground_terms(config, projection, grounds)
    ky, kz = projection.ky, projection.kz
    if HAVE_NUMBA:
        compiled = interpolated_weights if len(grounds) >= WEIGHT_BLOCK else point_weights
        weights = compiled(dx2**1.5, dx2, dy2, projection.gz2, projection.ky_t, projection.kz_t)
        return weights.reshape(len(grounds), -1)
    d2 = (dx2[:, None, None] + dy2[:, :, None]) + projection.gz2[None, None, :]
    beta = (dx2**1.5)[:, None, None] / (d2 * d2)  # (P, py, pz)
    half = np.zeros((len(grounds), ky.shape[0], kz.shape[1]))
    for c in range(ky.shape[1]):  # (the compiled loops' order: a sum from 0 over c, then over d)
        half += ky[None, :, c, None] * beta[:, None, c, :]
    out = np.zeros((len(grounds), ky.shape[0], kz.shape[0]))
    for d in range(kz.shape[1]):
        out += half[:, :, d, None] * kz[None, None, :, d]
    return out.reshape(len(grounds), -1)
