"""The compiled kernels of ``node_draws.DrawnNodeEpisodes``: the drawn episodes of the batched
moving multi-node env for all resetting rows at once (:func:`draw_node_episodes`) and each row's
kernel geometry put in the rows (:func:`start_node_rows`). What they compute, and in which order,
is ``node_draws``' module docstring; the scalars they read sit at ``mobile_draw_kernels``' ``C_*``
indices (the single-node draw's constants: the same motion and scenario fields).
"""

from __future__ import annotations

import numpy as np

from ios_uav_env.envs.mobile_draw_kernels import (
    C_BOX,
    C_BOX_MARGIN,
    C_CX,
    C_CY,
    C_D,
    C_DT,
    C_GAIN,
    C_GAP,
    C_HAS_BOX,
    C_MARGIN,
    C_MEMORY,
    C_SIGMA,
    C_SPEED,
    C_T_SCALE,
    horizon_flagged,
    node_rectangle,
)
from ios_uav_env.envs.multi_table import (
    MEP_HORIZON,
    MEP_K,
    MEP_MOVES,
    MEP_N,
    MEP_QFX,
    MEP_QFY,
    MST_X,
    MST_Y,
    PT_SIDE,
    PT_X,
    PT_Y,
)
from ios_uav_env.envs.node_weights import PT_GX, PT_GY, PT_SCALE
from ios_uav_env.jit import copy_into, jit
from ios_uav_env.model.motion import walk_component


@jit(fastmath=False)
def draw_node_episodes(
    rows: np.ndarray, uniform: np.ndarray, late: np.ndarray, counts: np.ndarray, slots: np.ndarray,
    surface: np.ndarray, normals: np.ndarray, headings: np.ndarray, intervals: np.ndarray,
    cuts: np.ndarray, c: np.ndarray, ends: np.ndarray, paths: np.ndarray, reports: np.ndarray,
    measured: np.ndarray, tally: np.ndarray, lo: np.ndarray, hi: np.ndarray, bad: np.ndarray,
    terms: np.ndarray, points: np.ndarray, sizes: np.ndarray, state: np.ndarray, path: np.ndarray,
    episode: np.ndarray,
) -> None:  # fmt: skip
    """Step 2 of ``node_draws``' module docstring for ``rows``, in IEEE arithmetic in the order of
    ``scenarios.sample_multinode`` / ``_off_plane``, ``mobility.rectangles``, ``motion.node_paths``
    / ``_walk``, ``knowledge.start_nodes_track``, ``NodeWeights.load`` (its ground points, dx2 in
    the scale's column: its power 1.5 is numpy's) and ``multi_table.node_points`` /
    ``episode_row``. ``headings`` (B, K_max, 2): cos and sin of each node's mean heading;
    ``uniform[i]``: the row's uniform draws of the nodes' x and y (2 k, 2 k + 1), ``late[i]``: those
    of q0 and qF (x, y, x, y); ``terms`` (B, S, K_max, 3): ``NodeWeights.points``. ``bad[i]`` = 1
    where the scenario's validation must decide (a node outside its motion rectangle, a rectangle
    empty, a node on the IOS plane, T too short)."""
    cx, cy, gap, has_box = c[C_CX], c[C_CY], c[C_GAP], c[C_HAS_BOX] != 0.0
    speed, sigma, a, gain = c[C_SPEED], c[C_SIGMA], c[C_MEMORY], c[C_GAIN]
    dt, d_max, margin = c[C_DT], c[C_D], c[C_MARGIN]
    t_scale, box_margin = c[C_T_SCALE], c[C_BOX_MARGIN]
    for j in range(rows.size):
        i = rows[j]
        u = uniform[i]
        k_nodes, n = counts[i], slots[i]
        cut = cuts[surface[i]]
        e = late[i]
        x0 = intervals[2, 0] + (intervals[2, 1] - intervals[2, 0]) * e[0]
        y0 = intervals[3, 0] + (intervals[3, 1] - intervals[3, 0]) * e[1]
        xf = intervals[4, 0] + (intervals[4, 1] - intervals[4, 0]) * e[2]
        yf = intervals[5, 0] + (intervals[5, 1] - intervals[5, 0]) * e[3]
        ends[i, 0], ends[i, 1], ends[i, 2], ends[i, 3] = x0, y0, xf, yf
        t = n * dt
        flagged = horizon_flagged(n, dt, x0, y0, xf, yf, d_max)
        p = paths[i]
        # the nodes (uniform in G's ranges, then off the IOS plane's strip), their box
        bx0, bx1, by0, by1 = cx, cx, cy, cy
        for k in range(k_nodes):
            gx = intervals[0, 0] + (intervals[0, 1] - intervals[0, 0]) * u[2 * k]
            gy = intervals[1, 0] + (intervals[1, 1] - intervals[1, 0]) * u[2 * k + 1]
            if cut and not abs(gx - cx) >= gap:
                gx = cx - gap if gx < cx else cx + gap
            p[0, k, 0], p[0, k, 1] = gx, gy
            bx0, bx1, by0, by1 = min(bx0, gx), max(bx1, gx), min(by0, gy), max(by1, gy)
        if has_box:
            bx0, bx1, by0, by1 = c[C_BOX], c[C_BOX + 1], c[C_BOX + 2], c[C_BOX + 3]
        else:
            bx0, bx1, by0, by1 = bx0 - box_margin, bx1 + box_margin, by0 - box_margin, by1 + box_margin
        for k in range(k_nodes):
            gx, gy = p[0, k, 0], p[0, k, 1]
            low_x, high_x, outside = node_rectangle(gx, gy, cut, cx, gap, bx0, bx1, by0, by1)
            flagged = flagged or outside
            lo[i, k, 0], lo[i, k, 1] = low_x - margin, by0 - margin
            hi[i, k, 0], hi[i, k, 1] = high_x + margin, by1 + margin
            # the node's path (node_paths: the mean velocity, v[0], then _walk)
            mx, my = speed * headings[i, k, 0], speed * headings[i, k, 1]
            vx, vy = mx + sigma * normals[i, 2 * k], my + sigma * normals[i, 2 * k + 1]
            for s in range(n - 1):
                z = 2 * k_nodes * (s + 1) + 2 * k  # (the slot's normals of the node)
                p[s + 1, k, 0], vx, mx = walk_component(p[s, k, 0], vx, mx, normals[i, z], low_x, high_x, a,
                                                        gain, dt)  # fmt: skip
                p[s + 1, k, 1], vy, my = walk_component(p[s, k, 1], vy, my, normals[i, z + 1], by0, by1, a,
                                                        gain, dt)  # fmt: skip
            # the records (NaN until observed), the ground points of every slot, the node's point
            for s in range(n):
                reports[i, s, k, 0], reports[i, s, k, 1] = np.nan, np.nan
                measured[i, k, s] = np.nan
                dx = p[s, k, 0] - cx
                term = terms[i, s, k]
                term[PT_GX], term[PT_GY], term[PT_SCALE] = p[s, k, 0], p[s, k, 1], dx * dx
            tally[i, k] = 0.0
            points[i, k, :] = 0.0
            points[i, k, PT_X], points[i, k, PT_Y] = gx, gy
            points[i, k, PT_SIDE] = 1.0 if gx > cx else -1.0
        bad[i] = 1 if flagged else 0
        sizes[i, 0], sizes[i, 1] = k_nodes, n
        # the episode row's drawn columns (multi_table.episode_row); the UAV at q0
        episode[i, MEP_QFX], episode[i, MEP_QFY], episode[i, MEP_MOVES] = xf, yf, n - 1
        episode[i, MEP_N], episode[i, MEP_K], episode[i, MEP_HORIZON] = n, k_nodes, t / t_scale
        state[i, MST_X], state[i, MST_Y] = x0, y0
        path[i, 0, 0], path[i, 0, 1] = x0, y0


#: The episode row's columns ``draw_node_episodes`` writes (the others are the geometry's).
DRAWN_COLUMNS = np.array(sorted({MEP_QFX, MEP_QFY, MEP_MOVES, MEP_N, MEP_K, MEP_HORIZON}), dtype=np.int64)


@jit(fastmath=False)
def start_node_rows(
    rows: np.ndarray, geometry: np.ndarray, counts: np.ndarray, slots: np.ndarray, which: np.ndarray,
    widths: np.ndarray, factors: np.ndarray, coords: np.ndarray, params: np.ndarray, episodes: np.ndarray,
    w_slots: np.ndarray, w_counts: np.ndarray, w_which: np.ndarray, w_factors: np.ndarray, w_base: np.ndarray,
    nodes: np.ndarray, episode: np.ndarray,
) -> None:  # fmt: skip
    """Each of ``rows``' kernel geometry (``geometry[j]``: its index in the tables ``which`` ..
    ``episodes``) into the rows: ``NodeWeights``' entries (``w_*``: its projection, J, kernel
    scalars, K and N), the kernels' node coordinates and padding (``nodes[i, :K]``, as
    ``node_weights._fill_row``) and the episode row's columns the draw does not write."""
    drawn = np.zeros(episode.shape[1], dtype=np.bool_)
    for col in DRAWN_COLUMNS:
        drawn[col] = True
    for j in range(rows.size):
        i, g = rows[j], geometry[j]
        q = widths[g]
        w_which[i], w_factors[i] = which[g], factors[g]
        w_counts[i], w_slots[i] = counts[i], slots[i]
        copy_into(w_base[i], params[g])
        for k in range(counts[i]):
            kernel = nodes[i, k]
            for x in range(q):
                kernel[0, x], kernel[1, x] = coords[g, 0, x], coords[g, 1, x]
            for x in range(q, kernel.shape[1]):
                kernel[0, x], kernel[1, x], kernel[2, x] = 0.0, 1.0, 0.0
        for col in range(episode.shape[1]):
            if not drawn[col]:
                episode[i, col] = episodes[g, col]
