"""The tour heuristic's hover points (``baselines.tour``, "Hover points"): each node's reachable
rate peak and the compromise points of its node rate maps.

:func:`hover_candidates` names them: ``peak<k>``, node k's best reachable point
(``ios_uav_env.rate_peak`` of ``config.node_config(k)``), and ``mid<i>-<j>`` (and all nodes when
K > 2), the reachable point of a ``resolution`` grid that maximises min_k r_k(q) / r_k^*;
:func:`node_rate_maps` computes every node's rate on that grid, which
:func:`check_candidate_grid` sizes before anything is allocated.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

import ios_uav_env as ie
from ios_uav_env import ScenarioConfig
from ios_uav_env.model.peak import reachable

#: Grid (m) of the node rate maps that give the compromise points.
CANDIDATE_RESOLUTION = 5.0


def check_candidate_grid(
    config: ScenarioConfig, resolution: float = CANDIDATE_RESOLUTION, margin: float | None = None
) -> None:
    """``ValueError`` (naming ``resolution`` and ``baselines.grid.MAX_TABLE_BYTES``) when the K
    node rate maps of :func:`node_rate_maps` and their per-cell temporaries would not fit;
    nothing is allocated. The grid is clipped to what the UAV can reach
    (``baselines.grid.grid_box``), so only a very long horizon can trip it."""
    from baselines.grid import DEFAULT_MARGIN, check_grid_bytes

    if not (isinstance(resolution, (int, float)) and math.isfinite(resolution) and resolution > 0):
        raise ValueError(f"resolution must be a finite number > 0 (m), got {resolution!r}")
    margin = DEFAULT_MARGIN if margin is None else margin
    check_grid_bytes(
        config,
        resolution,
        margin,
        8 * (2 * config.K + 8),
        "K node rate maps (which tour.solve skips when given candidates)",
    )


def node_rate_maps(
    config: ScenarioConfig, resolution: float, margin: float | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every node's rate on the DP grid of ``config``: xs (nx,), ys (ny,), rates (K, ny, nx)."""
    from baselines.grid import DEFAULT_MARGIN, grid_axes

    check_candidate_grid(config, resolution, margin)
    xs, ys, _ = grid_axes(config, resolution, DEFAULT_MARGIN if margin is None else margin)
    xx, yy = np.meshgrid(xs, ys)
    rates = ie.node_rates(config, np.column_stack([xx.ravel(), yy.ravel()]))
    return xs, ys, rates.reshape(config.K, len(ys), len(xs))


def hover_candidates(
    config: ScenarioConfig, resolution: float = CANDIDATE_RESOLUTION
) -> list[tuple[str, tuple[float, float]]]:
    """Named hover points: each node's reachable peak and the compromise points (module doc)."""
    if config.K > 1:
        check_candidate_grid(config, resolution)  # before any rate is computed
    out: list[tuple[str, tuple[float, float]]] = []
    for k in range(config.K):
        peak = ie.rate_peak(config.node_config(k))
        out.append((f"peak{k + 1}", (peak.x, peak.y)))
    if config.K > 1:
        xs, ys, rates = node_rate_maps(config, resolution)
        xx, yy = np.meshgrid(xs, ys)
        pts = np.column_stack([xx.ravel(), yy.ravel()])
        ok = reachable(config, pts)
        flat = rates.reshape(config.K, -1)
        best = np.max(np.where(ok, flat, -np.inf), axis=1, keepdims=True)
        # a node no reachable grid point serves (r_k^* = 0) has no preference: 1 everywhere
        norm = np.divide(flat, best, out=np.ones_like(flat), where=best > 0)
        groups = list(itertools.combinations(range(config.K), 2))
        if config.K > 2:
            groups.append(tuple(range(config.K)))
        for group in groups:
            score = np.where(ok, norm[list(group)].min(axis=0), -np.inf)
            i = int(np.argmax(score))
            out.append(("mid" + "-".join(str(k + 1) for k in group), (float(pts[i, 0]), float(pts[i, 1]))))
    unique: list[tuple[str, tuple[float, float]]] = []
    for name, p in out:  # a point within 1 m of an earlier one adds nothing
        if all(math.dist(p, u) > 1.0 for _, u in unique):
            unique.append((name, p))
    return unique
