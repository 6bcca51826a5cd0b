"""The peak search's grids in one compiled pass: branch and bound over blocks of grid points.

:func:`~ios_uav_env.model.peak.rate_peak` looks for the reachable point of highest
expected-gain rate among a coarse grid (and the straight line q0 -> qF), then among a fine grid
around the best one. Evaluating the rate at every point costs one sum over the surface nodes per
point; :func:`grid_argmax` returns the same point (the first, in the grid's order, of the
highest rate) after evaluating only the points of the blocks that could hold it:

- the points are cut into blocks (``block`` x ``block`` neighbours of a grid, runs of ``block``
  consecutive points of the line), and each block gets an upper bound of the rate over the
  bounding box [x_a, x_b] x [y_a, y_b] of its reachable points (:func:`block_bound`);
- the blocks are visited by decreasing bound, and the search stops at the first block whose
  bound is below the best rate found so far: no point of it, nor of any later block, can reach
  that rate, let alone beat it. Every point that ties the maximum lies in a visited block, so
  the tie rule (the lowest index wins) is ``np.argmax``'s.

The bound (symbols of ``channel``; r = log2(1 + eta zeta^2) grows with zeta >= 0). The rate is
zeta = a_D(d_UG) + s(x) |dx|^3 sum_k J w_k / (dy_k^2 + c_k + dx^2)^2, with dx = x - x_c,
dy_k = y - y_k, c_k = (z_U - z_k)^2, J w_k >= 0, s the side factor. Over the box:

- the direct term k (d^2 + z_U^2)^(-alpha/4) decreases with the distance to G, so it is at most
  its value at the box's point nearest to G;
- node k's term is at most J w_k g_k(u), u = |dx| in [u_min, u_max] (the box's distances to the
  plane), with dy_k^2 at its least over [y_a, y_b] (m_k = min dy_k^2 + c_k) and
  g_k(u) = u^3 / (u^2 + m_k)^2, which rises up to u* = sqrt(3 m_k) and falls after: its maximum
  over the interval is g_k(clip(u*, u_min, u_max));
- s is 1 on G's side, ``t_factor`` on the other, and at most max(1, t_factor) for a box across
  the plane (a point in the plane has no surface term at all).

The bound is widened by a relative 1e-9 (far beyond the rounding of either side, ~1e-15) before
it is compared. Without a nonnegative weight (a node weight J w_k < 0 or t_factor < 0: no model
here gives one) nothing is pruned: every point is evaluated. The rates are those of
``channel.rates_at`` (``RateKernel.rates``, the exhaustive search's kernel), so the result equals
the exhaustive search's (tested, with and without numba).
"""

from __future__ import annotations

import math

import numpy as np

from ios_uav_env.jit import copy_into, jit
from ios_uav_env.model.channel import (
    PARAM_ANTENNAS,
    PARAM_D_EXP,
    PARAM_ETA,
    PARAM_G_SIDE,
    PARAM_GX,
    PARAM_GY,
    PARAM_HAS_SURFACE,
    PARAM_K_DIRECT,
    PARAM_T_FACTOR,
    PARAM_X_C,
    PARAM_Z_U2,
    rates_at,
)
from ios_uav_env.model.rate_rows import merge_order

#: Relative widening of every block's bound (the module's docstring).
BOUND_SLACK = 1e-9


@jit(inline=True)
def _gap(lo: float, hi: float, v: float) -> float:
    """Distance from ``v`` to the interval [lo, hi] (0 inside)."""
    if v < lo:
        return lo - v
    if v > hi:
        return v - hi
    return 0.0


@jit
def block_bound(xa: float, xb: float, ya: float, yb: float, nodes: np.ndarray, params: np.ndarray) -> float:
    """An upper bound of the expected-gain rate over the box [xa, xb] x [ya, yb] (m) for one rate
    kernel (``nodes`` (3, K), ``params``: ``channel.PARAMS``), widened by :data:`BOUND_SLACK`;
    inf when the node weights are not all >= 0 (the module's docstring)."""
    ddx, ddy = _gap(xa, xb, params[PARAM_GX]), _gap(ya, yb, params[PARAM_GY])
    zeta = params[PARAM_K_DIRECT] * (ddx * ddx + ddy * ddy + params[PARAM_Z_U2]) ** params[PARAM_D_EXP]
    if params[PARAM_HAS_SURFACE] != 0.0:
        t_factor, g_side = params[PARAM_T_FACTOR], params[PARAM_G_SIDE]
        if t_factor < 0.0:
            return math.inf
        da, db = xa - params[PARAM_X_C], xb - params[PARAM_X_C]
        if da > 0.0:  # the whole box on the side x > x_c
            side = 1.0 if g_side > 0.0 else t_factor
        elif db < 0.0:
            side = 1.0 if g_side < 0.0 else t_factor
        else:
            side = max(1.0, t_factor)
        u_hi = max(abs(da), abs(db))
        u_lo = 0.0 if da <= 0.0 <= db else min(abs(da), abs(db))
        for k in range(nodes.shape[1]):
            if nodes[2, k] < 0.0:
                return math.inf
        total = 0.0
        for k in range(nodes.shape[1]):
            w = nodes[2, k]
            gy = _gap(ya, yb, nodes[0, k])
            m = gy * gy + nodes[1, k]
            u = min(max(math.sqrt(3.0 * m), u_lo), u_hi)
            d2 = u * u + m
            total += w * u * u * u / (d2 * d2)
        zeta += side * total
    # (N_t antennas gain at most N_t zeta^2: channel.aligned_gain's array factor is at most N_t)
    gain = params[PARAM_ETA] * max(1.0, params[PARAM_ANTENNAS]) * zeta * zeta  # (as rate_row: 0 reads 1)
    return math.log2(1.0 + gain) * (1.0 + BOUND_SLACK)


@jit(fastmath=False)
def candidate(
    x: float, y: float, q0: np.ndarray, qf: np.ndarray, d: float, moves: int, x_c: float, g_sign: float,
    side: int,
) -> bool:  # fmt: skip
    """Whether a fly-hover-fly flight can visit (x, y) (``peak.reachable``: ``moves_needed`` there
    and back within ``moves``) on ``side`` (0 anywhere, 1 G's side of the plane x = x_c, -1 the
    other; ``g_sign`` = sign(x_G - x_c)), in the operations of the numpy forms (each norm's two
    squares summed, then the square root) in IEEE arithmetic: the same result bit for bit."""
    ax, ay, bx, by = x - q0[0], y - q0[1], qf[0] - x, qf[1] - y
    there = np.ceil(math.sqrt(ax * ax + ay * ay) / d - 1e-9)
    back = np.ceil(math.sqrt(bx * bx + by * by) / d - 1e-9)
    if there < 0.0:
        there = 0.0
    if back < 0.0:
        back = 0.0
    ok = there + back <= moves
    if side != 0:
        facing = np.sign(x - x_c) * g_sign
        ok = ok and (facing > 0.0 if side > 0 else facing < 0.0)
    return ok


@jit
def _blocks(nx: int, ny: int, nline: int, block: int) -> np.ndarray:
    """The blocks of the search, one row each: (first column or line index, columns, first row,
    rows); a grid block is ``block`` x ``block`` neighbours (fewer at the edges), a line block
    (rows = 0) ``block`` consecutive points of the line."""
    bx, by = (nx + block - 1) // block, (ny + block - 1) // block
    nl = (nline + block - 1) // block
    out = np.empty((bx * by + nl, 4), dtype=np.int64)
    j = 0
    for r in range(by):
        for c in range(bx):
            out[j, 0], out[j, 1] = c * block, min(block, nx - c * block)
            out[j, 2], out[j, 3] = r * block, min(block, ny - r * block)
            j += 1
    for s in range(nl):
        out[j, 0], out[j, 1], out[j, 2], out[j, 3] = s * block, min(block, nline - s * block), 0, 0
        j += 1
    return out


@jit(fastmath=False)
def decreasing_order(values: np.ndarray) -> np.ndarray:
    """The indices of ``values`` by decreasing value, ties by index, NaN last: the order of
    ``np.argsort(-values, kind="stable")``, by the b-bit search's merge sort
    (``rate_rows.merge_order``; numba's ``np.argsort`` costs seconds more to compile, in every
    process that searches a peak)."""
    n = values.shape[0]
    key, numbers, order = np.empty(n), np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64)
    count, last = 0, n
    for j in range(n - 1, -1, -1):  # the NaNs to the end, in index order
        if math.isnan(values[j]):
            last -= 1
            order[last] = j
    for j in range(n):
        key[j] = -values[j]
        if not math.isnan(values[j]):
            numbers[count] = j
            count += 1
    copy_into(order, merge_order(numbers[:count], key))
    return order


@jit
def grid_argmax(
    xs: np.ndarray, ys: np.ndarray, line: np.ndarray, q0: np.ndarray, qf: np.ndarray, d: float, moves: int,
    x_c: float, g_x: float, side: int, nodes: np.ndarray, params: np.ndarray, block: int,
) -> tuple[int, float]:  # fmt: skip
    """(i, r): the first index ``i`` of the highest rate ``r`` (``channel.rates_at``) among the
    reachable points on ``side`` (:func:`candidate`; q0, qF, D = ``d``, N - 1 = ``moves``, the
    plane x = ``x_c``, G's x = ``g_x``) of the grid ``xs`` x ``ys`` in ``np.meshgrid``'s order
    (index iy nx + ix) followed by the (L, 2) ``line`` (index nx ny + l), by branch and bound over
    blocks of ``block`` points a side (the module's docstring); (-1, -inf) if no point qualifies.
    A block's bound is taken over its bounding box, reachable points or not (still a bound of the
    reachable ones); only the points of the blocks visited are checked and evaluated."""
    nx, ny = xs.shape[0], ys.shape[0]
    g_sign = np.sign(g_x - x_c)
    blocks = _blocks(nx, ny, line.shape[0], block)
    bounds = np.empty(blocks.shape[0])
    for j in range(blocks.shape[0]):
        first, count, row, rows = blocks[j, 0], blocks[j, 1], blocks[j, 2], blocks[j, 3]
        if rows > 0:
            x0, x1, y0, y1 = xs[first], xs[first + count - 1], ys[row], ys[row + rows - 1]
            xa, xb, ya, yb = min(x0, x1), max(x0, x1), min(y0, y1), max(y0, y1)  # (ascending axes)
        else:
            xa, xb, ya, yb = math.inf, -math.inf, math.inf, -math.inf
            for p in range(first, first + count):
                xa, xb = min(xa, line[p, 0]), max(xb, line[p, 0])
                ya, yb = min(ya, line[p, 1]), max(yb, line[p, 1])
        bounds[j] = block_bound(xa, xb, ya, yb, nodes, params)
    order = decreasing_order(bounds)
    best, best_i = -math.inf, -1
    points, index = np.empty((block * block, 2)), np.empty(block * block, dtype=np.int64)
    for j in order:
        if bounds[j] < best:
            break
        first, count, row, rows = blocks[j, 0], blocks[j, 1], blocks[j, 2], blocks[j, 3]
        n = 0
        for r in range(max(rows, 1)):
            for c in range(first, first + count):
                if rows > 0:
                    x, y, i = xs[c], ys[row + r], (row + r) * nx + c
                else:
                    x, y, i = line[c, 0], line[c, 1], nx * ny + c
                if candidate(x, y, q0, qf, d, moves, x_c, g_sign, side):
                    points[n, 0], points[n, 1], index[n] = x, y, i
                    n += 1
        rates = rates_at(points[:n], nodes, params)  # (the exhaustive search's kernel)
        for m in range(n):
            if rates[m] > best or (rates[m] == best and index[m] < best_i):
                best, best_i = rates[m], index[m]
    return best_i, best


@jit(fastmath=False)
def straight_line(x0: float, y0: float, xf: float, yf: float, num: int) -> np.ndarray:
    """``np.linspace((x0, y0), (xf, yf), num)`` (num >= 2) in numpy's operations, bit for bit: n
    step + start with step = (stop - start) / (num - 1), or, where a component's step is 0,
    (n / (num - 1)) (stop - start) + start; the last point is the stop itself."""
    div = num - 1
    dx, dy = xf - x0, yf - y0
    sx, sy = dx / div, dy / div
    out = np.empty((num, 2))
    for n in range(num):
        if sx == 0.0 or sy == 0.0:
            t = n / div
            out[n, 0], out[n, 1] = t * dx + x0, t * dy + y0
        else:
            out[n, 0], out[n, 1] = n * sx + x0, n * sy + y0
    out[num - 1, 0], out[num - 1, 1] = xf, yf
    return out


@jit(fastmath=False)
def fine_axis(centre: float, half: int, step: float) -> np.ndarray:
    """``centre + np.arange(-half, half + 1) * step`` in numpy's operations, bit for bit."""
    out = np.empty(2 * half + 1)
    for k in range(-half, half + 1):
        offset = k * step
        out[k + half] = centre + offset
    return out


@jit
def search_grids(
    xs: np.ndarray, ys: np.ndarray, q0: np.ndarray, qf: np.ndarray, d: float, slots: int, x_c: float,
    g_x: float, side: int, nodes: np.ndarray, params: np.ndarray, half: int, refine: float, coarse_block: int,
    fine_block: int,
) -> tuple[float, float, float]:  # fmt: skip
    """``peak.rate_peak``'s two searches in one call, each by :func:`grid_argmax`: the coarse grid
    ``xs`` x ``ys`` and the straight line q0 -> qF of ``slots`` points, then (``half`` > 0) the
    fine grid of (2 ``half`` + 1)^2 points ``refine`` m apart around the coarse best, which
    replaces it only with a strictly higher rate. (x, y, rate) of the best point, (nan, nan,
    -inf) if no point qualifies."""
    line = straight_line(q0[0], q0[1], qf[0], qf[1], slots)
    moves = slots - 1
    i, rate = grid_argmax(xs, ys, line, q0, qf, d, moves, x_c, g_x, side, nodes, params, coarse_block)
    if i < 0:
        return math.nan, math.nan, -math.inf
    grid = xs.shape[0] * ys.shape[0]
    if i < grid:
        x, y = xs[i % xs.shape[0]], ys[i // xs.shape[0]]
    else:
        x, y = line[i - grid, 0], line[i - grid, 1]
    if half > 0:
        fx, fy = fine_axis(x, half, refine), fine_axis(y, half, refine)
        j, fine = grid_argmax(fx, fy, line[:0], q0, qf, d, moves, x_c, g_x, side, nodes, params, fine_block)
        if j >= 0 and fine > rate:
            x, y, rate = fx[j % fx.shape[0]], fy[j // fx.shape[0]], fine
    return x, y, rate
