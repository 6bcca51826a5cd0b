"""The reachable rate peak: the best point to hover at, found on a grid of the one rate model.

A fly-hover-fly trajectory through a point P exists iff the UAV can fly from q0 to P and on
to qF in the N - 1 moves of D: ``moves_needed(|P - q0|) + moves_needed(|qF - P|) <= N - 1``
(:func:`reachable`). :func:`rate_peak` is the point of highest expected-gain rate
(``channel.slot_rates``) among those, searched on an absolute grid of ``resolution`` metres
around G and the IOS and along the straight line q0 -> qF (always reachable), then refined
on a ``refine`` metre grid around the best point; ``side`` restricts it to G's side of the
surface plane or the other one. Rate peaks lie near G and the IOS: the direct link peaks
above G, and each element's UAV-side factor |dx|^3 / d^4 peaks at |dx| = sqrt(3) h, h the
UAV's height above the element; the default ``margin`` is max(200 m, 2 sqrt(3) h_max), h_max
above the lowest element (210 m at the paper's 100 m altitude), and the box is clipped to
the bounding box of the reachable ellipse |P - q0| + |qF - P| <= (N - 1) D (so a far-away
G does not blow the grid up). It is the hover point of the planners' starts, of the
heuristic baselines and of the env's ``peak_hint`` features.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ios_uav_env.jit import HAVE_NUMBA, jit
from ios_uav_env.model.channel import rate_kernel, slot_rates
from ios_uav_env.model.config import ScenarioConfig, moves_needed, scene_box
from ios_uav_env.model.peak_search import candidate, search_grids

#: Least metres searched around G and the IOS centre (see :func:`search_margin`).
PEAK_MARGIN = 200.0


class Peak(NamedTuple):
    """A hover point (m) and its expected-gain rate (bps/Hz)."""

    x: float
    y: float
    rate: float


def reachable(config: ScenarioConfig, points: np.ndarray) -> np.ndarray:
    """Mask of the (n, 2) ``points`` that a fly-hover-fly trajectory of ``config`` can visit."""
    q0, qf = np.asarray(config.q0, float), np.asarray(config.qF, float)
    out = moves_needed(np.linalg.norm(points - q0, axis=1), config.D)
    back = moves_needed(np.linalg.norm(qf - points, axis=1), config.D)
    return out + back <= config.N - 1


def search_margin(config: ScenarioConfig) -> float:
    """The default margin (m) of the search box: max(200 m, 2 sqrt(3) h_max), with h_max the
    UAV's height above the lowest surface element (twice where an element's link peaks). The
    lowest element is the first row of ``surface._axes``, z_c + (0 - (M_z - 1) / 2) s, in its
    operations (tested equal)."""
    if config.surface == "none":
        return PEAK_MARGIN
    lowest = config.ios_center[2] + (0 - 0.5 * (config.ios_shape[1] - 1)) * config.element_spacing
    return max(PEAK_MARGIN, 2.0 * math.sqrt(3.0) * (config.uav_altitude - lowest))


def _ellipse_box(config: ScenarioConfig) -> tuple[tuple[float, float], tuple[float, float]]:
    """(lo, hi) corners of the bounding box of the reachable ellipse (plus one move), each (x, y)."""
    (x0, y0), (xf, yf) = config.q0, config.qF
    dx, dy = xf - x0, yf - y0
    a = 0.5 * (config.N - 1) * config.D + config.D  # semi-major axis, one move of slack
    c = 0.5 * float(np.linalg.norm((dx, dy)))
    b = math.sqrt(max(a * a - c * c, 0.0))
    ux, uy = (dx / (2.0 * c), dy / (2.0 * c)) if c > 0 else (1.0, 0.0)
    (ax, ay), (bx, by) = (a * ux, a * uy), (b * uy, b * ux)  # (numpy's square of an array is x * x)
    hx, hy = math.sqrt(ax * ax + bx * bx), math.sqrt(ay * ay + by * by)
    cx, cy = 0.5 * (x0 + xf), 0.5 * (y0 + yf)
    return (cx - hx, cy - hy), (cx + hx, cy + hy)


def _axis(lo: float, hi: float, step: float) -> np.ndarray:
    return np.arange(math.floor(lo / step), math.ceil(hi / step) + 1) * step


#: Values of ``rate_peak``'s ``side``: anywhere, G's side of the surface plane, the other side.
SIDES = (None, "front", "behind")


def _on_side(config: ScenarioConfig, points: np.ndarray, side: str | None) -> np.ndarray:
    if side is None:
        return np.ones(len(points), dtype=bool)
    x_c = config.ios_center[0]
    facing = np.sign(points[:, 0] - x_c) * config.ground_side
    return facing > 0 if side == "front" else facing < 0


@jit(fastmath=False)
def _candidates(
    points: np.ndarray, q0: np.ndarray, qf: np.ndarray, d: float, moves: int, x_c: float, g_x: float,
    side: int,
) -> np.ndarray:  # fmt: skip
    """``reachable(...) & _on_side(...)`` in one compiled pass (``side``: 0 anywhere, 1 G's side,
    -1 the other one): the same IEEE operations as their numpy forms (the norms' two squares
    summed, then the square root), so the same mask bit for bit."""
    out = np.empty(points.shape[0], dtype=np.bool_)
    g_sign = np.sign(g_x - x_c)
    for i in range(points.shape[0]):
        out[i] = candidate(points[i, 0], points[i, 1], q0, qf, d, moves, x_c, g_sign, side)
    return out


def _mask(config: ScenarioConfig, points: np.ndarray, side: str | None) -> np.ndarray:
    """The points of ``points`` that a fly-hover-fly trajectory can visit on ``side``."""
    if not HAVE_NUMBA:
        return reachable(config, points) & _on_side(config, points, side)
    code = 0 if side is None else 1 if side == "front" else -1
    q0, qf = np.asarray(config.q0, float), np.asarray(config.qF, float)
    x_c, g_x = config.ios_center[0], config.ground_node[0]
    return _candidates(
        np.ascontiguousarray(points, dtype=float), q0, qf, config.D, config.N - 1, x_c, g_x, code
    )


def _best(config: ScenarioConfig, points: np.ndarray, side: str | None, compiled: bool) -> Peak | None:
    points = points[_mask(config, points, side)]
    if len(points) == 0:
        return None
    rates = rate_kernel(config).rates(points) if compiled else slot_rates(config, points)
    i = int(np.argmax(rates))
    return Peak(float(points[i, 0]), float(points[i, 1]), float(rates[i]))


_NO_LINE = np.zeros((0, 2))
#: ``side`` as the compiled searches take it: 0 anywhere, 1 G's side, -1 the other one.
_SIDE_CODES = {None: 0, "front": 1, "behind": -1}
#: Points a side of ``peak_search``'s blocks on the coarse grid and on the fine one (measured
#: fastest: one bound per block, then the points of the blocks that could hold the peak).
_BLOCKS = (8, 4)


def _exhaustive(
    config: ScenarioConfig,
    xs: np.ndarray,
    ys: np.ndarray,
    line: np.ndarray,
    side: str | None,
    compiled: bool,
) -> Peak | None:
    """The best reachable point on ``side`` of the grid ``xs`` x ``ys`` (``np.meshgrid``'s order)
    and the ``line``, every point's rate evaluated."""
    xx, yy = np.meshgrid(xs, ys)
    return _best(config, np.vstack([np.column_stack([xx.ravel(), yy.ravel()]), line]), side, compiled)


def rate_peak(
    config: ScenarioConfig,
    resolution: float = 10.0,
    refine: float = 1.0,
    margin: float | None = None,
    side: str | None = None,
    compiled: bool = False,
) -> Peak | None:
    """The reachable point of highest expected-gain rate (see the module docstring).

    ``resolution`` (m): the coarse grid; ``refine`` (m): the fine grid within one coarse
    step of the coarse optimum (0: none); ``margin`` (m): the search box around G and the
    IOS centre (default :func:`search_margin`); ``side``: None (anywhere; never returns
    None), ``"front"`` (G's side of the surface plane) or ``"behind"`` (the other side; None
    if no reachable point of the grid lies there); ``compiled``: evaluate the grids with the
    compiled rate kernel (``RateKernel.rates``, several times faster with numba; the rates
    agree with ``slot_rates`` to rounding, so only an exact tie between two grid points could
    pick the other one; with numba both grids are searched in one compiled call by branch and
    bound, ``peak_search.search_grids``, which returns the exhaustive search's point and rate
    while evaluating a few percent of the points). Deterministic.
    """
    if side not in SIDES:
        raise ValueError(f"side must be one of {SIDES}, got {side!r}")
    margin = search_margin(config) if margin is None else margin
    for name, value in (("resolution", resolution), ("margin", margin)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a finite number > 0 (m), got {value!r}")
    if not (isinstance(refine, (int, float)) and math.isfinite(refine) and 0 <= refine < resolution):
        raise ValueError(f"refine must be a number in [0, resolution) (m), got {refine!r}")
    x0, x1, y0, y1 = scene_box(config, margin, ends=False)
    box_lo, box_hi = _ellipse_box(config)
    lo = np.maximum((x0, y0), box_lo)
    hi = np.minimum((x1, y1), box_hi)
    xs, ys = _axis(lo[0], hi[0], resolution), _axis(lo[1], hi[1], resolution)
    if compiled and HAVE_NUMBA:  # both grids in one compiled call, by branch and bound
        half = math.floor(resolution / refine) if refine > 0 else 0
        kernel = rate_kernel(config)
        x, y, rate = search_grids(
            xs, ys, np.asarray(config.q0, float), np.asarray(config.qF, float), config.D, config.N,
            config.ios_center[0], config.ground_node[0], _SIDE_CODES[side], kernel.nodes, kernel.params, half,
            float(refine), *_BLOCKS,
        )  # fmt: skip
        return None if rate == -math.inf else Peak(float(x), float(y), float(rate))
    line = np.linspace(config.q0, config.qF, config.N)  # a straight flight: every point reachable
    best = _exhaustive(config, xs, ys, line, side, compiled)
    if best is not None and refine > 0:
        offsets = np.arange(-math.floor(resolution / refine), math.floor(resolution / refine) + 1) * refine
        fine = _exhaustive(config, best.x + offsets, best.y + offsets, _NO_LINE, side, compiled)
        if fine is not None and fine.rate > best.rate:
            best = fine
    return best
