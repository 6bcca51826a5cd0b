"""The learning curve of the suite score: every checkpoint of a run, scored on the held-out suite.

    python -m agents.suite curve --run runs/<run> [--n 60] [--out out/suite_curve]

Loads each of the run's checkpoints (``agents.loading.load_agent(run, checkpoint=steps)``:
``checkpoints/rl_model_<steps>_steps.zip`` with the matching VecNormalize statistics, if
any), scores it with :func:`agents.suite.report.evaluate_suite` and writes a CSV (steps,
minutes since the first checkpoint, mean / p10 / min % of DP, feasible) and a PNG. A
checkpoint that does not load is skipped with a warning naming its file; the CSV is
rewritten after every checkpoint, so an interrupted curve keeps the ones it scored. A folder
that already holds a curve (:data:`CURVE_FILES`) is refused before any checkpoint is scored
unless ``--overwrite`` is given: the previous curve's files are then removed before the first
row is written, so an interrupted curve never sits beside another run's figure. Env arguments
of the run that change the suite's task (``ios_uav_env.benchmark.overrides``) are refused:
score such a run with ``python -m agents.suite report --allow-task-change``.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from agents.loading import checkpoints, load_agent
from agents.suite.report import evaluate_suite, summarize
from ios_uav_env import RANDOM_ENV_ID
from ios_uav_env.benchmark.outputs import remove_stale
from ios_uav_env.io import atomic_write_text, save_figure


def learning_curve(
    run: str | Path,
    suite: Any = None,
    n: int | None = None,
    out: str | Path | None = None,
    *,
    stale: Sequence[Path] = (),
) -> list[dict[str, Any]]:
    """One summary row per checkpoint that loads on ``suite`` (a benchmark suite, its name or
    file; default ``single-node-v1``): steps, minutes since the first checkpoint (file times),
    suite score; with ``out``, the CSV there is rewritten after each one, and the files of a
    previous curve there (``stale``) are removed before the first one is written (not before:
    a curve that fails first keeps them). ``FileNotFoundError`` if the run has no checkpoint."""
    points = checkpoints(run)
    if not points:
        raise FileNotFoundError(f"no checkpoints (rl_model_<steps>_steps.zip) in {Path(run) / 'checkpoints'}")
    t0 = min(p.stat().st_mtime for _, p in points)
    rows = []
    for steps, path in points:
        try:
            agent = load_agent(run, checkpoint=steps, env_id=RANDOM_ENV_ID)
        except (OSError, ValueError) as exc:
            warnings.warn(f"checkpoint {path} skipped: {exc}", RuntimeWarning, stacklevel=2)
            continue
        s = summarize(evaluate_suite(agent, suite, n))
        rows.append({"steps": steps, "minutes": (path.stat().st_mtime - t0) / 60.0, **s})
        print(f"{steps:>9d} steps: mean {s['mean_pct_dp']:.2f}%  p10 {s['p10_pct_dp']:.2f}%  "
              f"min {s['min_pct_dp']:.2f}%  feasible {s['feasible']}/{s['n']}", flush=True)  # fmt: skip
        if out is not None:
            remove_stale(stale, ())
            stale = ()
            write_csv(rows, out)
    return rows


KEYS = ("steps", "minutes", "mean_pct_dp", "p10_pct_dp", "min_pct_dp", "feasible", "n")
#: The files a curve writes to its folder.
CURVE_FILES: tuple[str, ...] = ("suite_curve.csv", "suite_curve.png")


def write_csv(rows: list[dict[str, Any]], out: str | Path) -> Path:
    """``out/suite_curve.csv``, atomically."""
    text = ",".join(KEYS) + "\n" + "".join(",".join(f"{r[k]:.6g}" for k in KEYS) + "\n" for r in rows)
    return atomic_write_text(Path(out) / "suite_curve.csv", text)


def write_curve(rows: list[dict[str, Any]], out: str | Path) -> list[Path]:
    """CSV and PNG of the curve under ``out``."""
    from matplotlib.figure import Figure

    out = Path(out)
    csv = write_csv(rows, out)
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
