"""The env's frames: :class:`FrameRenderer`, one Agg figure per env (``IOSUAVEnv.render``).

The drawing helpers (the rate map, the scene, trajectories, PNGs) are those of
:mod:`ios_uav_env.plotting`, re-exported here where the envs and users' code import them.
matplotlib is imported only when something is drawn.
"""

from __future__ import annotations

import numpy as np

from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.plotting import (
    Extent,
    default_extent,
    figure_classes,
    plot_rate_map,
    plot_scene,
    plot_trajectories,
    rate_grid,
    save_png,
)

__all__ = [
    "Extent", "FrameRenderer", "default_extent", "figure_classes", "plot_rate_map", "plot_scene",
    "plot_trajectories", "rate_grid", "save_png",
]  # fmt: skip

#: (Figure, FigureCanvasAgg) or an ImportError naming the extra: ``plotting.figure_classes``.
_matplotlib = figure_classes


class FrameRenderer:
    """One Agg figure per env: the cached rate map and scene, with the trajectory updated per frame."""

    def __init__(self, config: ScenarioConfig, *, size: tuple[int, int] = (720, 360), dpi: int = 100) -> None:
        figure_cls, canvas_cls = figure_classes()
        self.config = config
        self.figure = figure_cls(figsize=(size[0] / dpi, size[1] / dpi), dpi=dpi)
        self.canvas = canvas_cls(self.figure)
        self.ax = self.figure.add_subplot()
        plot_rate_map(self.ax, config)
        (self._line,) = plot_trajectories(self.ax, config, {"UAV": np.empty((0, 2))}, legend=False)
        (self._head,) = self.ax.plot([], [], "o", ms=7, mfc="#ff5a36", mec="w", zorder=6)
        self.figure.tight_layout()

    def frame(self, trajectory: np.ndarray, title: str | None = None) -> np.ndarray:
        """Draw ``trajectory`` ((K, 2) m) and return the frame as an (H, W, 3) uint8 array."""
        q = np.asarray(trajectory, dtype=float).reshape(-1, 2)
        self._line.set_data(q[:, 0], q[:, 1])
        self._head.set_data(q[-1:, 0], q[-1:, 1])
        if title is not None:
            self.ax.set_title(title, fontsize=10)
        self.canvas.draw()
        return np.array(self.canvas.buffer_rgba())[:, :, :3]

    def close(self) -> None:
        self.figure.clear()
