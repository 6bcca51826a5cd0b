"""Figures of a scenario: the rate map, the scene, trajectories, one node or several.

The drawing helpers of every figure: the envs' frames (``ios_uav_env.envs.rendering``), the
planners' and the evaluation's figures. matplotlib is optional (``pip install
ios-uav-env[render]``) and imported only when something is drawn, through its object-oriented
API on an Agg canvas (:func:`figure_classes`): importing this module or the env never touches
pyplot or the user's backend. The helpers take an ``ax`` so every figure has the same look:

>>> import matplotlib.pyplot as plt                                    # doctest: +SKIP
>>> fig, ax = plt.subplots()                                           # doctest: +SKIP
>>> plot_rate_map(ax, config)                                          # doctest: +SKIP
>>> plot_trajectories(ax, config, {"IA": plan.trajectory})             # doctest: +SKIP
"""

from __future__ import annotations

import io
from collections.abc import Callable, Mapping, Sequence
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from ios_uav_env.model.channel import slot_rates
from ios_uav_env.model.config import ScenarioConfig, scene_box
from ios_uav_env.model.schedule import best_schedule, node_rates

__all__ = [
    "NODE_COLORS", "Extent", "default_extent", "figure_classes", "figure_image", "plot_fleet",
    "plot_multinode_map", "plot_rate_map", "plot_scene", "plot_served_trajectories", "plot_trajectories",
    "rate_grid", "save_png", "served_node",
]  # fmt: skip

_INSTALL = "pip install ios-uav-env[render]"
Extent = tuple[float, float, float, float]  # (x_min, x_max, y_min, y_max) in m


def figure_classes() -> tuple[Any, Any]:
    """(Figure, FigureCanvasAgg), or an ImportError that says what to install."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as exc:
        raise ImportError(f"rendering needs matplotlib: {_INSTALL}") from exc
    return Figure, FigureCanvasAgg


def figure_image(
    draw: Callable[[Any], None], figsize: tuple[float, float] = (7.2, 3.6), dpi: int = 100
) -> np.ndarray:
    """An (H, W, 3) uint8 image of a one-axes figure that ``draw(ax)`` fills (laid out tightly): the
    envs' ``rgb_array`` frames and the tools' pictures."""
    figure_cls, canvas_cls = figure_classes()
    fig = figure_cls(figsize=figsize, dpi=dpi)
    canvas = canvas_cls(fig)
    draw(fig.add_subplot())
    fig.tight_layout()
    canvas.draw()
    return np.array(canvas.buffer_rgba())[:, :, :3]


def default_extent(config: ScenarioConfig, aspect: float = 0.5) -> Extent:
    """A map around q0, qF, G and the IOS with a margin, at least ``aspect`` times as tall as wide."""
    x0, x1, y0, y1 = scene_box(config)
    lo, hi = np.array([x0, y0]), np.array([x1, y1])
    pad = 0.08 * max(float((hi - lo).max()), 4 * config.D)
    lo, hi = lo - pad, hi + pad
    width, height = hi - lo
    if height < aspect * width:
        mid = 0.5 * (lo[1] + hi[1])
        lo[1], hi[1] = mid - 0.5 * aspect * width, mid + 0.5 * aspect * width
    return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])


@lru_cache(maxsize=16)
def rate_grid(
    config: ScenarioConfig, extent: Extent | None = None, resolution: tuple[int, int] = (200, 100)
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Expected-gain rate (bps/Hz) on a grid: (xs (nx,), ys (ny,), rates (ny, nx)); cached, read-only."""
    x0, x1, y0, y1 = default_extent(config) if extent is None else extent
    xs, ys = np.linspace(x0, x1, resolution[0]), np.linspace(y0, y1, resolution[1])
    xx, yy = np.meshgrid(xs, ys)
    rates = slot_rates(config, np.column_stack([xx.ravel(), yy.ravel()])).reshape(xx.shape)
    for arr in (xs, ys, rates):
        arr.setflags(write=False)
    return xs, ys, rates


def plot_scene(ax: Any, config: ScenarioConfig, *, labels: bool = True) -> None:
    """Mark the IOS (a segment at x = x_c), the ground node G and the end points q0, qF.

    The IOS is M_y lambda/2 wide (2.5 m at the defaults): it is drawn at least 6% of the
    axes' height tall so that it shows.
    """
    x_c, y_c, _ = config.ios_center
    y_lo, y_hi = ax.get_ylim()
    half = max(0.5 * config.ios_shape[0] * config.element_spacing, 0.03 * abs(y_hi - y_lo))
    style = {"zorder": 5, "clip_on": False}
    if config.surface != "none":
        ax.plot([x_c, x_c], [y_c - half, y_c + half], color="w", lw=4, solid_capstyle="butt", **style)
        ax.plot([x_c, x_c], [y_c - half, y_c + half], color="k", lw=1.5, solid_capstyle="butt", **style)
    marks = [(config.ground_node, "^", "G"), (config.q0, "o", "$q_0$"), (config.qF, "s", "$q_F$")]
    for (x, y), marker, _ in marks:
        ax.plot([x], [y], marker=marker, ms=8, mfc="w", mec="k", ls="none", **style)
    if labels:
        name = {"ios": "IOS", "ris": "RIS", "none": "", "star": "STAR"}[config.surface]
        texts = [*(((x, y), text) for (x, y), _, text in marks), ((x_c, y_c + half), name)]
        for (x, y), text in texts:
            ax.annotate(text, (x, y), xytext=(0, 7), textcoords="offset points", ha="center",
                        va="bottom", color="w", fontsize=9, fontweight="bold", zorder=6)  # fmt: skip


def plot_rate_map(
    ax: Any,
    config: ScenarioConfig,
    *,
    extent: Extent | None = None,
    resolution: tuple[int, int] = (200, 100),
    cmap: str = "viridis",
    vmax: float | None = None,
    colorbar: bool = True,
    scene: bool = True,
) -> Any:
    """Draw the expected-gain rate map of ``config`` on ``ax`` (and the scene); return the image."""
    box = default_extent(config) if extent is None else extent
    _, _, rates = rate_grid(config, box, resolution)
    image = ax.imshow(rates, origin="lower", extent=box, cmap=cmap, vmin=0.0, vmax=vmax,
                      aspect="equal", interpolation="bilinear")  # fmt: skip
    ax.set_xlim(box[0], box[1])
    ax.set_ylim(box[2], box[3])
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    if colorbar:
        ax.figure.colorbar(image, ax=ax, label="rate (bps/Hz)", shrink=0.8, pad=0.02)
    if scene:
        plot_scene(ax, config)
    return image


def plot_trajectories(
    ax: Any,
    config: ScenarioConfig,
    trajectories: Mapping[str, np.ndarray],
    *,
    colors: Mapping[str, str] | None = None,
    legend: bool = True,
    **line_kw: Any,
) -> list[Any]:
    """Draw each labelled (K, 2) trajectory as a line with a dot per way-point; return the lines."""
    palette = ["#ff5a36", "#ffffff", "#ffd700", "#00e5ff", "#ff66cc", "#9cff57"]
    lines = []
    for i, (label, traj) in enumerate(trajectories.items()):
        q = np.asarray(traj, dtype=float).reshape(-1, 2)
        color = (colors or {}).get(label, palette[i % len(palette)])
        kw = {"lw": 1.6, "marker": ".", "ms": 3, "zorder": 4, **line_kw}
        (line,) = ax.plot(q[:, 0], q[:, 1], color=color, label=label, **kw)
        lines.append(line)
    if legend and trajectories:
        ax.legend(loc="lower right", fontsize=8, framealpha=0.7)
    return lines


def save_png(image: np.ndarray, path: str | Path, *, colors: int | None = None) -> Path:
    """Write an (H, W, 3) uint8 image as PNG (``colors``: quantise to a palette, for small files),
    atomically (``io.atomic_write_bytes``: an interrupted write leaves the old file or none)."""
    try:
        from PIL import Image
    except ImportError as exc:
        raise ImportError(f"saving PNGs needs Pillow (a matplotlib dependency): {_INSTALL}") from exc
    from ios_uav_env.io import atomic_write_bytes

    img = Image.fromarray(np.ascontiguousarray(image, dtype=np.uint8))
    if colors is not None:
        img = img.quantize(colors=colors, method=Image.Quantize.MEDIANCUT)
    buffer = io.BytesIO()
    img.save(buffer, format="PNG", optimize=True)
    return atomic_write_bytes(Path(path), buffer.getvalue())


# --- several ground nodes: the best-node rate map, trajectories coloured by the node served ---

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


def plot_fleet(
    ax: Any,
    config: ScenarioConfig,
    flights: np.ndarray | Sequence[np.ndarray],
    shares: Sequence[np.ndarray] | None = None,
    *,
    resolution: tuple[int, int] = (120, 60),
) -> None:
    """Several UAVs' ``flights`` (U, n, 2) m, or one (n_u, 2) array each (UAVs of their own
    horizons), over the best node's rate map, each UAV's moves coloured by the node it serves
    (``shares[u]``: (K, n_u) its node shares, or each flight's own best schedule), the view
    widened to every flight."""
    flights = [np.asarray(f, dtype=float).reshape(-1, 2) for f in flights]
    plot_multinode_map(ax, config, resolution=resolution)
    labels = [f"uav_{u}" for u in range(len(flights))]
    plot_served_trajectories(
        ax, config, dict(zip(labels, flights, strict=True)),
        None if shares is None else dict(zip(labels, shares, strict=True)),
    )  # fmt: skip
    x0, x1, y0, y1 = default_extent(config)
    pts = np.concatenate(flights)
    pad = 0.05 * max(x1 - x0, y1 - y0)
    ax.set_xlim(min(x0, pts[:, 0].min() - pad), max(x1, pts[:, 0].max() + pad))
    ax.set_ylim(min(y0, pts[:, 1].min() - pad), max(y1, pts[:, 1].max() + pad))
