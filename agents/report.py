"""A comparison of plans on one scenario, for any K: its :class:`Row` (a plan's scores by
``ios_uav_env.score_plan``), the one-node table (markdown and CSV) and figure (all trajectories
over the rate map); ``agents.evaluate_multi`` draws the K > 1 table from the same rows."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ios_uav_env import ScenarioConfig
from ios_uav_env.io import save_figure, save_rows_csv


@dataclass
class Row:
    """One line of a comparison table, for any K: a plan's scores by ``ios_uav_env.score_plan``."""

    scheme: str
    kind: str  # "planner", "bound" (a certified upper bound, not a plan) or "agent"
    rate: float  # bps/Hz, the plan's own score: eq. (9); K > 1: min_k R_k with its own shares
    feasible: bool  # eq. (10)
    wall_time: float  # s: planning time, or the agent's episode from reset to the last step
    trajectory: np.ndarray | None = field(default=None, repr=False)
    config: ScenarioConfig | None = field(default=None, repr=False)  # the scenario scored (CUC: no surface)
    terminal_miss: float = float("nan")  # m
    best_schedule_rate: float = float("nan")  # bps/Hz, K > 1: the best shares of the trajectory
    shares: np.ndarray | None = field(default=None, repr=False)  # (K, N), K > 1: the plan's own
    pct: dict[str, float] = field(default_factory=dict)  # by reference: "dp" (one node); "sca", "bound"
    faded_mean: float = float("nan")  # bps/Hz, over the Rician seeds
    faded_std: float = float("nan")

    @property
    def average_rate(self) -> float:
        """The one-node name of :attr:`rate` (eq. (9))."""
        return self.rate

    @property
    def pct_dp(self) -> float:
        return self.pct.get("dp", float("nan"))

    @property
    def pct_sca(self) -> float:
        return self.pct.get("sca", float("nan"))

    @property
    def pct_bound(self) -> float:
        return self.pct.get("bound", float("nan"))


COLUMNS = (
    "scheme",
    "average_rate",
    "pct_dp",
    "feasible",
    "terminal_miss_m",
    "wall_time_s",
    "rician_mean",
    "rician_std",
)


def _values(row: Any) -> dict[str, Any]:
    return {
        "scheme": row.scheme,
        "average_rate": row.average_rate,
        "pct_dp": row.pct_dp,
        "feasible": row.feasible,
        "terminal_miss_m": row.terminal_miss,
        "wall_time_s": row.wall_time,
        "rician_mean": row.faded_mean,
        "rician_std": row.faded_std,
    }


def _fmt(value: float, spec: str) -> str:
    return "-" if isinstance(value, float) and math.isnan(value) else format(value, spec)


def markdown_table(rows: Sequence[Any]) -> str:
    """The rows as a markdown table (rates in bps/Hz; Rician: mean ± std over the seeds)."""
    lines = [
        "| scheme | average rate | % of DP | feasible | terminal miss (m) | wall time (s) | Rician rate |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        rician = "-" if math.isnan(r.faded_mean) else f"{r.faded_mean:.4f} ± {r.faded_std:.4f}"
        lines.append(
            f"| {r.scheme} | {r.average_rate:.6f} | {_fmt(r.pct_dp, '.2f')} | "
            f"{'yes' if r.feasible else 'NO'} | {r.terminal_miss:.3g} | {r.wall_time:.2f} | {rician} |"
        )
    return "\n".join(lines)


def save_table_csv(rows: Sequence[Any], path: str | Path) -> Path:
    """Write the rows as CSV (full precision) atomically."""
    return save_rows_csv(path, COLUMNS, (_values(row) for row in rows))


def save_comparison_figure(rows: Sequence[Any], config: ScenarioConfig, path: str | Path) -> Path:
    """Every row's trajectory over the IOS rate map of ``config`` (whole scene, and a zoom on
    the best-rate point where the good plans hover), saved as PNG atomically."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from ios_uav_env.model.peak import rate_peak
    from ios_uav_env.plotting import plot_rate_map, plot_trajectories

    fig = Figure(figsize=(10, 8.4), dpi=100)
    FigureCanvasAgg(fig)
    full, zoom = fig.subplots(2, 1, height_ratios=[1.0, 0.9])
    px, py, _ = rate_peak(config)
    plot_rate_map(full, config)
    plot_rate_map(
        zoom, config, extent=(px - 90, px + 90, py - 45, py + 45), resolution=(180, 90), scene=False
    )
    styles = ("-", "--", ":", "-.")
    for ax in (full, zoom):
        for i, r in enumerate(rows):
            label = f"{r.scheme}: {r.average_rate:.4f}" + ("" if r.feasible else " (infeasible)")
            color = _COLORS[i % len(_COLORS)]
            plot_trajectories(ax, config, {label: r.trajectory}, legend=False, alpha=0.9,
                              colors={label: color}, ls=styles[i % len(styles)])  # fmt: skip
    full.legend(
        loc="lower right", fontsize=7, framealpha=0.75, title="average rate (bps/Hz)", title_fontsize=7
    )
    full.set_title(f"Trajectories over the IOS rate map (M = {config.M}, T = {config.T:g} s; "
                   "CUC flies without the surface)", fontsize=10)  # fmt: skip
    zoom.set_title(f"around the best-rate point ({px:.0f}, {py:.0f}) m", fontsize=9)
    fig.tight_layout()
    return save_figure(fig, path)


_COLORS = ("#ffffff", "#ff5a36", "#00e5ff", "#ff66cc", "#9cff57", "#c77dff", "#000000", "#ff9f1c")
