"""The online task's rows in one picture: % of the clairvoyant optimum against compute per episode.

Run:  python examples/online_task_figure.py --out docs/online_task.png

Two panels, ``mobile-v2`` (one walking node) and ``multi-node-mobile-v1`` (2 to 4), one point per
row of the suite's section of ``docs/leaderboard.md``: a reference row (``show --reference R``)
from the suite's stored values (``reference_results``: mean, 10th percentile and minimum % of the
optimum, and the median of the stored seconds per episode), any other row (a policy rolled out in
the env, a trajectories file) from the numbers of its table row, which
``tests/benchmark/test_mobile_suite_v2.py`` reruns from the row's command. The marker is the mean,
its bar runs down to the 10th percentile, a cross marks the minimum. The optimum (100 %) is the
dashed line; the bound, not a plan, is left out; rows given the truth (the clairvoyant tour, the
tracker of the true position) are hollow. x: the median compute per episode in seconds (log scale):
the planner's own wall time for a reference or a trajectories file, the episode in the env for a
policy, on a busy 2-core machine. Every point is printed. An existing file is never overwritten.

Needs matplotlib.
"""

from __future__ import annotations

import argparse
import math
import re
import shlex
from pathlib import Path
from typing import Any

import numpy as np

from ios_uav_env.benchmark import load_suite, reference_results

ROOT = Path(__file__).resolve().parents[1]
LEADERBOARD = ROOT / "docs" / "leaderboard.md"
#: The online task's suites, one panel each.
SUITES = ("mobile-v2", "multi-node-mobile-v1")
#: Rows left out (not a plan) and rows given the truth (drawn hollow).
NOT_PLANS = ("bound", "optimum")
GIVEN_TRUTH = ("clairvoyant", "track_exact")
#: The references' names in the legend.
NAMES = {
    "mpc_dp_k1": "MPC-DP, k=1 (dp)",
    "mpc_dp_k10": "MPC-DP, k=10 (dp)",
    "mpc_k1": "MPC over the tour, k=1",
    "mpc_k10": "MPC over the tour, k=10",
    "plan_once": "plan once",
    "clairvoyant": "tour given the true paths",
    "track_exact": "track the true position",
    "track_reports": "track the reports",
}
_TIME = re.compile(r"([\d.]+)\s*(ms|s)")


def table_rows(suite: str, page: Path = LEADERBOARD) -> list[dict[str, str]]:
    """The rows of the table in the section ``## <suite>`` of ``page``, by header name."""
    section = page.read_text(encoding="utf-8").split(f"\n## {suite}\n", 1)[1].split("\n## ", 1)[0]
    lines = [line for line in section.splitlines() if line.startswith("|")]
    header = [cell.strip() for cell in lines[0].strip("|").split("|")]
    return [dict(zip(header, [c.strip() for c in line.strip().strip("|").split("|")], strict=True))
            for line in lines[2:]]  # fmt: skip


def seconds_of(text: str) -> float:
    """A plan time of the table (``"14 ms"``, ``"6.67 s"``) in seconds; NaN if it gives none."""
    match = _TIME.fullmatch(text.strip())
    if match is None:
        return math.nan
    return float(match.group(1)) * (1e-3 if match.group(2) == "ms" else 1.0)


def _label(words: list[str]) -> str:
    """A short name of a row's command: the reference, the ``--name``, or the policy."""
    if "--reference" in words:
        reference = words[words.index("--reference") + 1]
        return NAMES.get(reference, reference)
    if "--name" in words:
        return words[words.index("--name") + 1]
    spec = words[words.index("--policy") + 1]
    model = re.search(r"agents/models/([\w.-]+)", spec)
    label = model.group(1) if model else spec.split(":", 1)[1]
    if "--env-kwargs" in words:
        label += " " + " ".join(w.split(":")[0] for w in words[words.index("--env-kwargs") + 1 :])
    return label


def points(suite_name: str, page: Path = LEADERBOARD) -> list[dict[str, Any]]:
    """One point per plan row of the suite's leaderboard section (module docstring): its label,
    mean / p10 / min % of the optimum, median seconds per episode, and whether it is given the truth."""
    suite, out = load_suite(suite_name), []
    for row in table_rows(suite_name, page):
        words = shlex.split(row["command"].strip("`"))
        reference = words[words.index("--reference") + 1] if "--reference" in words else None
        if reference in NOT_PLANS:
            continue
        if reference is not None:
            agg = reference_results(suite, reference).aggregate
            stats = [agg.stats[f"{s}_pct_optimum"] for s in ("mean", "p10", "min")]
            seconds = float(agg.median_seconds)
        else:
            stats = [float(row[c]) for c in ("mean % of optimum", "p10", "min")]
            seconds = seconds_of(row["plan time"])
        out.append({"label": _label(words), "mean": stats[0], "p10": stats[1], "min": stats[2],
                    "seconds": seconds, "truth": reference in GIVEN_TRUTH})  # fmt: skip
    return out


def draw(panels: dict[str, list[dict[str, Any]]], path: Path) -> Path:
    """The two panels (module docstring) as a PNG at ``path``."""
    from matplotlib import colormaps

    from ios_uav_env.plotting import figure_classes, save_png

    tab20 = colormaps["tab20"].colors  # dark and light pairs: the dark ones first
    order = [tab20[i] for i in (*range(0, 20, 2), *range(1, 20, 2))]
    labels = dict.fromkeys(p["label"] for pts in panels.values() for p in pts)  # one colour per row name
    colours = {label: order[j % len(order)] for j, label in enumerate(labels)}
    figure_cls, canvas_cls = figure_classes()
    fig = figure_cls(figsize=(12.0, 6.4), dpi=100)
    canvas = canvas_cls(fig)
    for i, (name, pts) in enumerate(panels.items()):
        ax = fig.add_subplot(1, len(panels), i + 1)
        ax.axhline(100.0, color="k", ls="--", lw=0.8, label="clairvoyant optimum")
        for p in sorted(pts, key=lambda p: -p["mean"]):
            colour = colours[p["label"]]
            face = "none" if p["truth"] else colour
            ax.errorbar([p["seconds"]], [p["mean"]], yerr=[[p["mean"] - p["p10"]], [0.0]], fmt="o",
                        mfc=face, color=colour, capsize=3, label=p["label"])  # fmt: skip
            ax.plot([p["seconds"]], [p["min"]], "x", color=colour)
        ax.set_xscale("log")
        ax.set_ylim(0, 105)
        ax.set_xlabel("median compute per episode (s, log)")
        ax.set_ylabel("% of the clairvoyant optimum (o mean, bar to p10, x min)")
        ax.set_title(f"{name}: {len(load_suite(name))} scenarios", fontsize=10)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, frameon=False)
    fig.tight_layout()
    canvas.draw()
    return save_png(np.array(canvas.buffer_rgba())[:, :, :3], path, colors=256)


def main(argv: list[str] | None = None) -> Path:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="the figure (PNG; never overwritten)")
    args = parser.parse_args(argv)
    if args.out.exists():
        parser.error(f"--out {args.out} exists: give a new path (shipped figures are never overwritten)")
    panels = {name: points(name) for name in SUITES}
    for name, pts in panels.items():
        for p in pts:
            print(f"{name:21s} {p['label']:45s} mean {p['mean']:6.2f} | p10 {p['p10']:6.2f} | "
                  f"min {p['min']:6.2f} % of optimum; {p['seconds']:.3g} s per episode")  # fmt: skip
    path = draw(panels, args.out)
    print(f"figure: {path}")
    return path


if __name__ == "__main__":
    main()
