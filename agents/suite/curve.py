"""The learning curve of the suite score: every checkpoint of a run, scored on the held-out suite.

    python -m agents.suite curve --run runs/<run> [--n 60] [--out out/suite_curve]

Loads each of the run's checkpoints (``agents.loading.load_agent(run, checkpoint=steps)``:
``checkpoints/rl_model_<steps>_steps.zip`` with the matching VecNormalize statistics, if
any), scores it with :func:`agents.suite.report.evaluate_suite` and writes a CSV (steps,
minutes since the first checkpoint, mean / p10 / min % of DP, feasible) and a PNG.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from agents.loading import checkpoints, load_agent
from agents.suite import Suite
from agents.suite.report import evaluate_suite, summarize
from ios_uav_env import RANDOM_ENV_ID
from ios_uav_env.io import atomic_write_text, save_figure


def learning_curve(run: str | Path, suite: Suite, n: int | None = None) -> list[dict[str, Any]]:
    """One summary row per checkpoint: steps, minutes since the first checkpoint (file times), suite
    score. ``FileNotFoundError`` if the run has no checkpoint."""
    points = checkpoints(run)
    if not points:
        raise FileNotFoundError(f"no checkpoints (rl_model_<steps>_steps.zip) in {Path(run) / 'checkpoints'}")
    t0 = min(p.stat().st_mtime for _, p in points)
    rows = []
    for steps, path in points:
        agent = load_agent(run, checkpoint=steps, env_id=RANDOM_ENV_ID)
        s = summarize(evaluate_suite(agent, suite, n))
        rows.append({"steps": steps, "minutes": (path.stat().st_mtime - t0) / 60.0, **s})
        print(f"{steps:>9d} steps: mean {s['mean_pct_dp']:.2f}%  p10 {s['p10_pct_dp']:.2f}%  "
              f"min {s['min_pct_dp']:.2f}%  feasible {s['feasible']}/{s['n']}", flush=True)  # fmt: skip
    return rows


def write_curve(rows: list[dict[str, Any]], out: str | Path) -> list[Path]:
    """CSV and PNG of the curve under ``out``."""
    from matplotlib.figure import Figure

    out = Path(out)
    keys = ("steps", "minutes", "mean_pct_dp", "p10_pct_dp", "min_pct_dp", "feasible", "n")
    text = ",".join(keys) + "\n" + "".join(",".join(f"{r[k]:.6g}" for k in keys) + "\n" for r in rows)
    csv = atomic_write_text(out / "suite_curve.csv", text)
    fig = Figure(figsize=(6.5, 3.8), layout="constrained")
    ax = fig.add_subplot()
    steps = [r["steps"] / 1e6 for r in rows]
    for key, label in (("mean_pct_dp", "mean"), ("p10_pct_dp", "10th percentile"), ("min_pct_dp", "minimum")):
        ax.plot(steps, [r[key] for r in rows], marker="o", ms=3, label=label)
    ax.axhline(97, color="k", ls=":", lw=1)
    ax.axhline(90, color="k", ls="--", lw=1)
    ax.set_xlabel("training steps (millions)")
    ax.set_ylabel("% of the DP optimum (held-out suite)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return [csv, save_figure(fig, out / "suite_curve.png", dpi=110)]
