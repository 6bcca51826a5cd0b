"""The comparison table (markdown and CSV) and figure (all trajectories over the rate map)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ios_uav_env import ScenarioConfig
from ios_uav_env.io import save_figure, save_rows_csv

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

    from ios_uav_env.envs.rendering import plot_rate_map, plot_trajectories
    from ios_uav_env.model.peak import rate_peak

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
