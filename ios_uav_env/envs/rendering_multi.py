"""Figures for several ground nodes: the best-node rate map, every node, and trajectories
coloured by the node each slot serves (the node with the largest share in that slot).

matplotlib is imported lazily by the caller's ``ax`` (as in :mod:`ios_uav_env.envs.rendering`);
nothing here touches pyplot.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ios_uav_env.envs.rendering import default_extent
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.schedule import best_schedule, node_rates

#: One colour per node (cycled beyond 8 nodes).
NODE_COLORS = ("#ff5a36", "#00e5ff", "#ffd700", "#ff66cc", "#9cff57", "#ffffff", "#b388ff", "#ff9100")


def served_node(
    config: ScenarioConfig, trajectory: np.ndarray, shares: np.ndarray | None = None
) -> np.ndarray:
    """Per slot, the index of the node with the largest share (best schedule by default), (N,)."""
    a = best_schedule(config, trajectory) if shares is None else np.asarray(shares, dtype=float)
    return np.argmax(a, axis=0)


def plot_multinode_map(ax: Any, config: ScenarioConfig, *, resolution: tuple[int, int] = (200, 100)) -> Any:
    """Draw max_k r_k (the best node's rate) as the background, the IOS, q0, qF and every node."""
    box = default_extent(config)
    xs, ys = np.linspace(box[0], box[1], resolution[0]), np.linspace(box[2], box[3], resolution[1])
    xx, yy = np.meshgrid(xs, ys)
    rates = node_rates(config, np.column_stack([xx.ravel(), yy.ravel()])).max(axis=0).reshape(xx.shape)
    image = ax.imshow(rates, origin="lower", extent=box, cmap="viridis", vmin=0.0, aspect="equal",
                      interpolation="bilinear")  # fmt: skip
    ax.set_xlim(box[0], box[1])
    ax.set_ylim(box[2], box[3])
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.figure.colorbar(image, ax=ax, label="best node's rate max_k r_k (bps/Hz)", shrink=0.8, pad=0.02)
    x_c, y_c, _ = config.ios_center
    half = max(0.5 * config.ios_shape[0] * config.element_spacing, 0.03 * (box[3] - box[2]))
    if config.surface != "none":
        ax.plot([x_c, x_c], [y_c - half, y_c + half], color="k", lw=2, zorder=5)
    for (x, y), marker, text in ((config.q0, "o", "$q_0$"), (config.qF, "s", "$q_F$")):
        ax.plot([x], [y], marker=marker, ms=8, mfc="w", mec="k", ls="none", zorder=5)
        ax.annotate(
            text, (x, y), xytext=(0, 7), textcoords="offset points", ha="center", color="w", fontsize=9
        )
    for k, (x, y) in enumerate(config.nodes):
        color = NODE_COLORS[k % len(NODE_COLORS)]
        ax.plot([x], [y], marker="^", ms=10, mfc=color, mec="k", ls="none", zorder=6)
        ax.annotate(f"G{k + 1}", (x, y), xytext=(0, 8), textcoords="offset points", ha="center", color=color,
                    fontsize=9, fontweight="bold", zorder=6)  # fmt: skip
    return image


def plot_served_trajectories(
    ax: Any,
    config: ScenarioConfig,
    trajectories: Mapping[str, np.ndarray],
    shares: Mapping[str, np.ndarray] | None = None,
) -> None:
    """Draw each trajectory with every move coloured by the node served in its first slot
    (``shares[label]`` or the best schedule); plans are told apart by their markers."""
    markers = ("o", "s", "D", "v", "P", "X")
    for i, (label, traj) in enumerate(trajectories.items()):
        q = np.asarray(traj, dtype=float).reshape(-1, 2)
        served = served_node(config, q, None if shares is None else shares.get(label))
        marker = markers[i % len(markers)]
        for n in range(len(q) - 1):
            color = NODE_COLORS[served[n] % len(NODE_COLORS)]
            ax.plot(q[n : n + 2, 0], q[n : n + 2, 1], color=color, lw=1.6, zorder=4)
        for k in range(config.K):
            sel = served == k
            color = NODE_COLORS[k % len(NODE_COLORS)]
            ax.plot(q[sel, 0], q[sel, 1], ls="none", marker=marker, ms=3, color=color, zorder=4)
        ax.plot([], [], ls="-", marker=marker, color="w", label=label)
    for k in range(config.K):
        ax.plot([], [], color=NODE_COLORS[k % len(NODE_COLORS)], lw=3, label=f"serves G{k + 1}")
    ax.legend(loc="lower right", fontsize=8, framealpha=0.7)
