"""Figures of a benchmark result (matplotlib, ``ios-uav-env[render]``): the histogram of % of the
normaliser (DP or SCA) and, for K > 1 nodes, for a few scenarios the trajectory coloured by the
node served (over the best-node rate map) above each node's share against the slot (a stacked plot).

:func:`shares_panels` draws one scenario's pair of panels for any plan, so the agents' reports
(``agents.evaluate``, ``agents.suite report``) draw the same figure.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ios_uav_env.io import save_figure
from ios_uav_env.model.config import ScenarioConfig


def _figure(size: tuple[float, float]) -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, dpi=100)
    FigureCanvasAgg(fig)
    return fig


def shares_panels(
    map_ax: Any, share_ax: Any, config: ScenarioConfig, trajectory: np.ndarray, shares: np.ndarray, title: str
) -> None:
    """The trajectory coloured by the served node over the best-node rate map (``map_ax``) and the
    shares (K, N) stacked against the slot (``share_ax``)."""
    from ios_uav_env.plotting import NODE_COLORS, plot_multinode_map, plot_served_trajectories

    a = np.asarray(shares, dtype=float)
    plot_multinode_map(map_ax, config, resolution=(120, 60))
    plot_served_trajectories(map_ax, config, {"plan": trajectory}, {"plan": a})
    map_ax.set_title(title, fontsize=9)
    slots = np.arange(1, a.shape[1] + 1)
    colors = [NODE_COLORS[k % len(NODE_COLORS)] for k in range(a.shape[0])]
    share_ax.stackplot(slots, a, colors=colors, labels=[f"G{k + 1}" for k in range(a.shape[0])],
                       edgecolor="k", linewidth=0.2)  # fmt: skip
    share_ax.set_xlim(1, a.shape[1])
    share_ax.set_ylim(0, 1)
    share_ax.set_xlabel("slot n")
    share_ax.set_ylabel("share alpha_k[n]")
    share_ax.legend(loc="upper right", fontsize=7, ncol=a.shape[0], framealpha=0.7)


def save_histogram(results: Any, path: str | Path) -> Path:
    """Histogram of % of the suite's normaliser over the scenarios; K > 1 nodes: the plan's own
    shares and the best schedule of its trajectory."""
    norm = results.metrics.normaliser
    label = {"dp": "DP", "sca": "SCA"}.get(norm, norm)
    fig = _figure((7, 4))
    ax = fig.add_subplot()
    own = [r.pct[norm] for r in results.scenarios]
    if results.metrics.schedules:
        best = [r.best_pct for r in results.scenarios]
        bins = np.linspace(min(min(own), 90.0), max(max(best), 101.0), 30)
        ax.hist(own, bins=bins, alpha=0.75, label="own shares")
        ax.hist(best, bins=bins, alpha=0.5, label="best schedule of the trajectory")
        ax.set_xlabel(f"% of {label} (max-min rate)")
        ax.legend(fontsize=8)
    else:
        ax.hist(own, bins=np.linspace(min(min(own), 95.0), max(max(own), 101.0), 30), alpha=0.8)
        ax.set_xlabel(f"% of the {label} optimum" if norm == "dp" else f"% of {label}")
    ax.axvline(100.0, color="k", lw=0.8, ls="--")
    ax.set_ylabel("scenarios")
    mean = results.aggregate.stats[f"mean_pct_{norm}"]
    ax.set_title(f"{results.name} on {results.task}: mean {mean:.2f}%", fontsize=9)
    fig.tight_layout()
    return save_figure(fig, path)


def changed_task_title(fig: Any, results: Any) -> None:
    """A figure of a changed task (``results.task_changes``) is titled with it (``results.task``)."""
    if getattr(results, "task_changes", None):
        fig.suptitle(f"{results.name} on {results.task}", fontsize=10, color="tab:red")


def picks(values: Sequence[float], count: int = 3) -> list[int]:
    """Positions of ``count`` scenarios from the worst to the best value (worst, middle, best)."""
    order = np.argsort(values, kind="stable")
    return [int(order[round(q * (len(order) - 1))]) for q in np.linspace(0, 1, min(count, len(order)))]


def save_shares_figure(results: Any, path: str | Path, count: int = 3) -> Path:
    """For ``count`` scenarios (worst, middle, best % of SCA): the served-node trajectory over the
    rate map above each node's share against the slot (the plan's own shares, else its best schedule)."""
    from ios_uav_env.model.schedule import best_schedule

    rows = [r for r in results.scenarios if r.trajectory is not None and r.config is not None]
    if not rows:
        raise ValueError("no result holds a trajectory")
    chosen = [rows[i] for i in dict.fromkeys(picks([r.pct["sca"] for r in rows], count))]
    fig = _figure((5.2 * len(chosen), 6.2))
    for col, r in enumerate(chosen):
        config = r.config
        map_ax = fig.add_subplot(2, len(chosen), col + 1)
        share_ax = fig.add_subplot(2, len(chosen), len(chosen) + col + 1)
        title = (f"#{r.index}, K={r.K}, {config.surface.upper()}, T={config.T:g} s: min rate {r.rate:.3f} "
                 f"({r.pct_sca:.1f}% of SCA)")  # fmt: skip
        shares = best_schedule(config, r.trajectory) if r.shares is None else r.shares  # best: no own shares
        shares_panels(map_ax, share_ax, config, r.trajectory, shares, title)
    changed_task_title(fig, results)
    fig.tight_layout()
    return save_figure(fig, path)


def save_mobile_figure(results: Any, path: str | Path, count: int | None = 3) -> Path:
    """For ``count`` mobile scenarios (worst, middle, best % of the bound; None: every scenario,
    one small panel each in a grid): the node's true path, the position reports the UAV received
    (``knowledge.episode_reports``: the episode's draws replayed from its seed, with the
    ``knowledge`` and ``report_sigma`` the results were run with, the mobile ids' "reports" and
    10 m by default) and the flown trajectory."""
    from ios_uav_env.model.reports import REPORT_SIGMA

    rows = [r for r in results.scenarios if r.seed is not None and r.trajectory is not None]
    if not rows:
        raise ValueError("no result holds a mobile scenario's seed and trajectory")
    knowledge = results.env_kwargs.get("knowledge", "reports")
    sigma = float(results.env_kwargs.get("report_sigma", REPORT_SIGMA))
    if count is None:
        chosen, cols = rows, min(5, len(rows))
        lines = math.ceil(len(rows) / cols)
        grid, size = (lines, cols), (3.3 * cols, 3.0 * lines)
    else:
        chosen = [rows[i] for i in dict.fromkeys(picks([r.pct["bound"] for r in rows], count))]
        grid, size = (1, len(chosen)), (5.2 * len(chosen), 4.6)
    fig = _figure(size)
    for k, r in enumerate(chosen):
        _mobile_panel(fig.add_subplot(*grid, k + 1), r, knowledge, sigma, small=count is None)
    changed_task_title(fig, results)
    fig.tight_layout()
    return save_figure(fig, path)


def _mobile_panel(ax: Any, r: Any, knowledge: str, sigma: float, small: bool) -> None:
    """One scenario's true node path, reports and flight on ``ax`` (``save_mobile_figure``)."""
    from ios_uav_env.envs.knowledge import episode_reports

    config = r.config
    truth, reports = episode_reports(config, r.seed, sigma, knowledge)
    q = np.asarray(r.trajectory)
    if knowledge == "reports":
        ax.scatter(reports[:, 0, 0], reports[:, 0, 1], s=2 if small else 4, c="tab:orange", alpha=0.5,
                   label="reports")  # fmt: skip
    ax.plot(q[:, 0], q[:, 1], c="tab:blue", lw=0.8 if small else 1.0, label="UAV")
    ax.plot(truth[:, 0, 0], truth[:, 0, 1], c="tab:red", lw=1.4 if small else 1.8, zorder=3,
            label="node (true path)")  # fmt: skip
    ax.plot(*q[0], "o", c="tab:blue", ms=3 if small else 4)
    ax.plot(*q[-1], "s", c="tab:blue", ms=3 if small else 4)
    if config.surface != "none":
        ax.plot(*config.ios_center[:2], "^", c="k", ms=4 if small else 6, label=config.surface.upper())
    ax.set_aspect("equal", adjustable="datalim")
    if small:
        ax.tick_params(labelsize=6)
        ax.set_title(f"#{r.index}, T={config.T:g} s: {r.pct['bound']:.1f}% of bound", fontsize=7)
        return
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"#{r.index}, T={config.T:g} s: {r.rate:.3f} bps/Hz ({r.pct['bound']:.1f}% of bound)",
                 fontsize=9)  # fmt: skip
    ax.legend(fontsize=7, loc="best")
