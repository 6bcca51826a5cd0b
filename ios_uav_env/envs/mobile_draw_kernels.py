"""The compiled kernels of ``mobile_draws.DrawnEpisodes``: the drawn episodes of the batched
moving-node env for all resetting rows at once (:func:`draw_episodes`), each row's first kernel and
slot-weight window (:func:`start_rows`), the slot's kernel at each step (:func:`put_rows`) and the
slot's observation normals (:func:`take_slot_normals`). What they compute, and in which order, is
``mobile_draws``' module docstring; the scalars they read sit at the ``C_*`` indices of
``DrawnEpisodes.constants``.
"""

from __future__ import annotations

import math

import numpy as np

from ios_uav_env.envs.single_kernels import (
    EP_FX_L,
    EP_FY_L,
    EP_GX_L,
    EP_GY_L,
    EP_HORIZON,
    EP_INV_MOVES,
    EP_MOVES,
    EP_QFX,
    EP_QFY,
)
from ios_uav_env.jit import copy_into, jit
from ios_uav_env.model.motion import walk_component
from ios_uav_env.model.rate_kernels import PARAM_G_SIDE, PARAM_GX, PARAM_GY
from ios_uav_env.model.weight_kernels import interpolated_weights_into

#: Where ``draw_episodes`` reads its scalars in ``DrawnEpisodes.constants``: the IOS centre's x and
#: y, the plane margin, whether the motion has a box and the box (x0, x1, y0, y1), the fixed
#: heading, the motion's speed, sigma, memory and slot gain sqrt(1 - a^2) sigma, dt, D, the report
#: clip's margin, 1 / length_scale, ``T_SCALE`` and ``BOX_MARGIN``.
(
    C_CX,
    C_CY,
    C_GAP,
    C_HAS_BOX,
    C_BOX,
    C_HEADING,
    C_SPEED,
    C_SIGMA,
    C_MEMORY,
    C_GAIN,
    C_DT,
    C_D,
    C_MARGIN,
    C_INV_L,
    C_T_SCALE,
    C_BOX_MARGIN,
) = (0, 1, 2, 3, 4, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18)
N_CONSTANTS = 19

#: Slots of weights a row holds at a time (computed WINDOW slots ahead, as the slots come).
WINDOW = 16


@jit(inline=True, fastmath=False)
def horizon_flagged(n: int, dt: float, x0: float, y0: float, xf: float, yf: float, d_max: float) -> bool:
    """Whether the config must check T = ``n`` ``dt`` itself: N = round(T / dt) and the config's
    checks of T (whole slots, N >= 2, qF reached from q0 in N - 1 moves of at most ``d_max``) could
    fail (a slack, not the exact test: the config decides)."""
    t = n * dt
    ratio = t / dt
    if abs(ratio - n) > 1e-12 * max(1.0, ratio) or n < 2:
        return True
    dist = math.sqrt((xf - x0) * (xf - x0) + (yf - y0) * (yf - y0))
    return math.ceil(dist / d_max - 1e-9) + 1 >= n - 1e-6 * n


@jit(inline=True, fastmath=False)
def node_rectangle(
    gx: float, gy: float, cut: bool, cx: float, gap: float, bx0: float, bx1: float, by0: float, by1: float
) -> tuple[float, float, bool]:
    """(low_x, high_x, flagged) of the node at (``gx``, ``gy``) in the box [bx0, bx1] x [by0, by1]
    (``mobility.rectangles``): x cut to its side of the IOS plane x = ``cx``, ``gap`` away from it
    when ``cut`` (a surface); flagged where the config's validation must decide (the node on the
    plane, the rectangle empty, the node outside it)."""
    low_x, high_x = bx0, bx1
    flagged = False
    if cut:
        if gx < cx:
            high_x = min(high_x, cx - gap)
        else:
            low_x = max(low_x, cx + gap)
        if gx == cx:
            flagged = True
    if not (low_x < high_x and by0 < by1) or not (low_x <= gx <= high_x and by0 <= gy <= by1):
        flagged = True
    return low_x, high_x, flagged


@jit(fastmath=False)
def draw_episodes(
    rows: np.ndarray, uniform: np.ndarray, slots: np.ndarray, surface: np.ndarray, normals: np.ndarray,
    headings: np.ndarray, intervals: np.ndarray, cuts: np.ndarray, c: np.ndarray, ground: np.ndarray,
    ends: np.ndarray, paths: np.ndarray, reports: np.ndarray, measured: np.ndarray, lo: np.ndarray,
    hi: np.ndarray, dx2: np.ndarray, bad: np.ndarray, state: np.ndarray, path: np.ndarray,
    episode: np.ndarray,
) -> None:  # fmt: skip
    """Step 2 of the module docstring for ``rows``, in IEEE arithmetic in the order of
    ``scenarios._draw`` / ``_off_plane``, ``mobility.rectangles``, ``motion.node_paths`` /
    ``_walk``, ``knowledge.start_track`` and ``single_kernels.episode_row``. ``c``: the constants
    of :class:`DrawnEpisodes`; ``headings``: (rows, 2) cos and sin of each row's mean heading.
    ``bad[i]`` = 1 where the scenario's validation must decide (the node outside its motion
    rectangle, the rectangle empty, the node on the IOS plane, T too short)."""
    cx, cy, gap, has_box = c[C_CX], c[C_CY], c[C_GAP], c[C_HAS_BOX] != 0.0
    speed, sigma, a, gain = c[C_SPEED], c[C_SIGMA], c[C_MEMORY], c[C_GAIN]
    dt, d_max, margin = c[C_DT], c[C_D], c[C_MARGIN]
    inv_l, t_scale, box_margin = c[C_INV_L], c[C_T_SCALE], c[C_BOX_MARGIN]
    for j in range(rows.size):
        i = rows[j]
        u = uniform[i]
        gx = intervals[0, 0] + (intervals[0, 1] - intervals[0, 0]) * u[0]
        gy = intervals[1, 0] + (intervals[1, 1] - intervals[1, 0]) * u[1]
        x0 = intervals[2, 0] + (intervals[2, 1] - intervals[2, 0]) * u[2]
        y0 = intervals[3, 0] + (intervals[3, 1] - intervals[3, 0]) * u[3]
        xf = intervals[4, 0] + (intervals[4, 1] - intervals[4, 0]) * u[4]
        yf = intervals[5, 0] + (intervals[5, 1] - intervals[5, 0]) * u[5]
        cut = cuts[surface[i]]
        if cut and not abs(gx - cx) >= gap:  # (_off_plane: the margin on its side)
            gx = cx - gap if gx < cx else cx + gap
        ground[i, 0], ground[i, 1] = gx, gy
        ends[i, 0], ends[i, 1], ends[i, 2], ends[i, 3] = x0, y0, xf, yf
        n = slots[i]
        t = n * dt
        flagged = horizon_flagged(n, dt, x0, y0, xf, yf, d_max)
        # the motion rectangle (mobility.rectangles)
        if has_box:
            bx0, bx1, by0, by1 = c[C_BOX], c[C_BOX + 1], c[C_BOX + 2], c[C_BOX + 3]
        else:
            bx0, bx1 = min(gx, cx) - box_margin, max(gx, cx) + box_margin
            by0, by1 = min(gy, cy) - box_margin, max(gy, cy) + box_margin
        low_x, high_x, outside = node_rectangle(gx, gy, cut, cx, gap, bx0, bx1, by0, by1)
        bad[i] = 1 if flagged or outside else 0
        lo[i, 0], lo[i, 1] = low_x - margin, by0 - margin
        hi[i, 0], hi[i, 1] = high_x + margin, by1 + margin
        # the node path (node_paths: the mean velocity, v[0], then _walk)
        mx, my = speed * headings[j, 0], speed * headings[j, 1]
        vx, vy = mx + sigma * normals[i, 0], my + sigma * normals[i, 1]
        p = paths[i]
        p[0, 0, 0], p[0, 0, 1] = gx, gy
        dx = gx - cx
        dx2[i, 0] = dx * dx
        for s in range(n - 1):
            p[s + 1, 0, 0], vx, mx = walk_component(p[s, 0, 0], vx, mx, normals[i, 2 + 2 * s], low_x, high_x,
                                                    a, gain, dt)  # fmt: skip
            p[s + 1, 0, 1], vy, my = walk_component(p[s, 0, 1], vy, my, normals[i, 3 + 2 * s], by0, by1, a,
                                                    gain, dt)  # fmt: skip
            dx = p[s + 1, 0, 0] - cx
            dx2[i, s + 1] = dx * dx
        for s in range(n):  # the records (knowledge.start_track: NaN until observed)
            reports[i, s, 0, 0], reports[i, s, 0, 1] = np.nan, np.nan
            measured[i, s] = np.nan
        # the episode row's drawn columns (single_kernels.episode_row); the UAV at q0
        moves = n - 1
        episode[i, EP_QFX], episode[i, EP_QFY], episode[i, EP_MOVES] = xf, yf, moves
        episode[i, EP_FX_L], episode[i, EP_FY_L] = xf * inv_l, yf * inv_l
        episode[i, EP_GX_L], episode[i, EP_GY_L] = gx * inv_l, gy * inv_l
        episode[i, EP_INV_MOVES] = 1.0 / moves
        episode[i, EP_HORIZON] = t / t_scale
        state[i, 0], state[i, 1] = x0, y0
        path[i, 0, 0], path[i, 0, 1] = x0, y0


#: The episode row's columns ``draw_episodes`` writes (the others are the geometry's).
DRAWN_COLUMNS = np.array(
    sorted({EP_QFX, EP_QFY, EP_MOVES, EP_FX_L, EP_FY_L, EP_GX_L, EP_GY_L, EP_INV_MOVES, EP_HORIZON}),
    dtype=np.int64,
)


@jit(fastmath=False)
def _fill(i: int, g: int, first: int, count: int, factor: np.ndarray, gy: np.ndarray, gz2: np.ndarray,
          ky: np.ndarray, kz: np.ndarray, sizes: np.ndarray, paths: np.ndarray, dx2: np.ndarray,
          scale: np.ndarray, weights: np.ndarray) -> None:  # fmt: skip
    """Row ``i``'s surface weights of slots ``first`` .. ``first + count - 1`` into ``weights[i, :count]``
    (geometry ``g``): ``surface.path_weights_into``'s call (dx2, its power 1.5 ``scale``, dy2 =
    (y - gy)^2; each point's weights are its own arithmetic, whatever points it is computed with)."""
    py, pz, ny, nz = sizes[g, 0], sizes[g, 1], sizes[g, 2], sizes[g, 3]
    dy2 = np.empty((count, py))
    for s in range(count):
        y = paths[i, first + s, 0, 1]
        for m in range(py):
            d = y - gy[g, m]
            dy2[s, m] = d * d
    interpolated_weights_into(weights[i, :count], factor[g], scale[i, first : first + count],
                              dx2[i, first : first + count], dy2, gz2[g, :pz], ky[g, :py, :ny],
                              kz[g, :pz, :nz])  # fmt: skip


@jit(fastmath=False)
def start_rows(
    rows: np.ndarray, geometry: np.ndarray, factor: np.ndarray, cx: np.ndarray, gy: np.ndarray,
    gz2: np.ndarray,
    ky: np.ndarray, kz: np.ndarray, sizes: np.ndarray, kernel_nodes: np.ndarray, kernel_params: np.ndarray,
    episode_rows: np.ndarray, paths: np.ndarray, slots: np.ndarray, dx2: np.ndarray, scale: np.ndarray,
    weights: np.ndarray, first: np.ndarray, base: np.ndarray, nodes: np.ndarray, params: np.ndarray,
    episode: np.ndarray,
) -> None:  # fmt: skip
    """Step 3 of the module docstring for ``rows``: ``SlotWeights.load`` and ``first`` (the first
    ``WINDOW`` slots' weights), with the geometry's kernel (G's scalars replaced, as
    ``rate_kernel`` does) and episode row (its drawn columns kept)."""
    drawn = np.zeros(episode.shape[1], dtype=np.bool_)
    for c in DRAWN_COLUMNS:
        drawn[c] = True
    for j in range(rows.size):
        i, g = rows[j], geometry[j]
        n = slots[i]
        _fill(i, g, 0, min(n, weights.shape[1]), factor, gy, gz2, ky, kz, sizes, paths, dx2, scale, weights)
        first[i] = 0
        x, y, x_c = paths[i, 0, 0, 0], paths[i, 0, 0, 1], cx[g]
        copy_into(base[i], kernel_params[g])
        base[i, PARAM_G_SIDE] = 1.0 if x > x_c else (-1.0 if x < x_c else 0.0)
        base[i, PARAM_GX], base[i, PARAM_GY] = x, y
        copy_into(nodes[i, 0], kernel_nodes[g, 0])  # (the first kernel_nodes.shape[2] entries of each)
        copy_into(nodes[i, 1], kernel_nodes[g, 1])
        copy_into(nodes[i, 2], weights[i, 0])
        copy_into(params[i], base[i])
        for c in range(episode.shape[1]):
            if not drawn[c]:
                episode[i, c] = episode_rows[g, c]


@jit(fastmath=False)
def put_rows(
    rows: np.ndarray, state: np.ndarray, windowed: np.ndarray, factor: np.ndarray, cx: np.ndarray,
    gy: np.ndarray, gz2: np.ndarray, ky: np.ndarray, kz: np.ndarray, sizes: np.ndarray,
    kernel_nodes: np.ndarray,
    kernel_params: np.ndarray, episode_rows: np.ndarray, paths: np.ndarray, slots: np.ndarray,
    dx2: np.ndarray, scale: np.ndarray, weights: np.ndarray, first: np.ndarray, base: np.ndarray,
    nodes: np.ndarray, params: np.ndarray, geometry: np.ndarray,
) -> None:  # fmt: skip
    """``DrawnEpisodes.put``: each windowed row's kernel of slot ``state[i, 2] + 1`` (its window moved
    on to start there when the slot is past it, ``_fill``)."""
    for j in range(rows.size):
        i = rows[j]
        if not windowed[i]:
            continue
        slot = int(state[i, 2]) + 1
        n = slots[i]
        if slot >= n:
            continue
        at = slot - first[i]
        if at < 0 or at >= weights.shape[1]:
            g = geometry[i]
            count = min(n - slot, weights.shape[1])
            _fill(i, g, slot, count, factor, gy, gz2, ky, kz, sizes, paths, dx2, scale,
                  weights)  # fmt: skip
            first[i], at = slot, 0
        copy_into(nodes[i, 2], weights[i, at])
        x, y, x_c = paths[i, slot, 0, 0], paths[i, slot, 0, 1], cx[geometry[i]]
        copy_into(params[i], base[i])
        params[i, PARAM_G_SIDE] = 1.0 if x > x_c else (-1.0 if x < x_c else 0.0)
        params[i, PARAM_GX], params[i, PARAM_GY] = x, y


@jit(fastmath=False)
def take_slot_normals(
    rows: np.ndarray, state: np.ndarray, normals: np.ndarray, taken: np.ndarray, out: np.ndarray
) -> None:
    """``knowledge_kernels.EpisodeDraws.take`` compiled (``normals``, ``taken``: its arrays): each row
    ``i`` of ``rows``' normals of its slot ``state[i, 2]`` into ``out[i]``, one slot more taken."""
    for j in range(rows.size):
        i = rows[j]
        slot = int(state[i, 2])
        for c in range(out.shape[1]):
            out[i, c] = normals[i, slot, c]
        taken[i] += 1
