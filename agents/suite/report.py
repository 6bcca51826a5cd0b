"""Score a policy on the held-out suite: % of each scenario's DP optimum, feasibility, plan time.

For every suite scenario (:mod:`agents.suite`) the policy is rolled out deterministically
and its trajectory scored with ``ios_uav_env.average_rate`` and checked with
``check_trajectory``, like the planners' plans. A policy trained on
``ios_uav_env/IOSUAV-Random-v0`` runs every scenario at once, row i of that id's batched env
pinned to scenario i (``agents.rollout.run_scenarios``, ``ios_uav_env.envs.rollout.run_episodes``;
the same episodes as one env pinned per scenario, tested); one trained on a fixed id runs in
that id made on each scenario (``ScenarioRunner``), so the single-scenario agents can be
scored too. An SB3 agent plans with its numpy export (``agents.numpy_policy``), the same
actions without SB3's per-call overhead. The plan time is the wall time from the reset to
the last step (inference and env steps): for the batched rollout, the batch's divided by the
number of scenarios (the time per plan when the suite is planned at once). It is compared
with SCA's time in the suite file. "% of DP" may exceed 100: DP is the optimum over a grid,
and an off-grid trajectory can beat it.

    python -m agents.suite report --model runs/<run> [--algo ppo|sac] [--n 60] [--out out/suite]
    python -m agents.suite report --model heuristic      # fly to G, hover, arrive (guard)
    python -m agents.suite report --model peak-heuristic # fly to the reachable rate peak instead
    python -m agents.suite report --model runs/<multi-node run>  # on multi-node-v1 (agents.suite.multi)

Writes ``suite_report.csv`` (one row per scenario), ``suite_report.md`` (the table and the
summary), ``suite_trajectories.png`` (six scenarios, policy vs DP vs SCA over the rate map,
picked from the worst to the best % of DP) and ``suite_pct_dp.png`` (the histogram).
:func:`suite_score` is the same score as a dict, for a training callback.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from agents.evaluate_multi import fast_act
from agents.rollout import ScenarioRunner, run_scenarios
from agents.suite import SUITE_PATH, Suite, SuiteEntry, load_suite
from ios_uav_env import ENV_IDS, RANDOM_ENV_ID
from ios_uav_env.envs.policies import HoverAt
from ios_uav_env.envs.rollout import Episode
from ios_uav_env.io import atomic_write_text, save_figure

#: The heuristic policies :func:`load_policy` knows by name (``ios_uav_env.envs.policies.HoverAt``).
HEURISTICS: dict[str, Callable[[], HoverAt]] = {
    "heuristic": lambda: HoverAt("ground"),
    "peak-heuristic": lambda: HoverAt("peak"),
}


@dataclass
class SuiteRow:
    """One scenario of the report."""

    index: int
    surface: str
    T: float  # s
    M: int
    dp_rate: float  # bps/Hz
    rate: float  # bps/Hz, the policy's trajectory, eq. (9)
    pct_dp: float  # 100 x rate / dp_rate
    feasible: bool  # eq. (10)
    terminal_miss: float  # m
    seconds: float  # s, wall time of the policy's plan
    sca_rate: float
    sca_pct_dp: float
    sca_feasible: bool
    sca_seconds: float
    trajectory: np.ndarray = field(repr=False)

    @classmethod
    def of(cls, entry: SuiteEntry, episode: Episode) -> SuiteRow:
        """The row of ``episode``, the policy's episode on ``entry``'s scenario."""
        c = entry.config
        return cls(
            entry.index, c.surface, c.T, c.M, entry.dp_rate, episode.average_rate,
            100.0 * episode.average_rate / entry.dp_rate, episode.feasible, episode.terminal_miss,
            episode.seconds, entry.sca["rate"], entry.sca_pct_dp, bool(entry.sca["feasible"]),
            entry.sca["seconds"], episode.trajectory,
        )  # fmt: skip


def load_policy(path: str | Path, algo: str | None = None) -> Any:
    """The agent at ``path`` (``agents.loading.load_agent``; a bare ``.zip`` is taken as a
    policy of ``ios_uav_env/IOSUAV-Random-v0`` and needs ``algo``), or a heuristic by name
    (:data:`HEURISTICS`: ``"heuristic"`` flies to G, ``"peak-heuristic"`` to the rate peak)."""
    if str(path) in HEURISTICS:
        return HEURISTICS[str(path)]()
    from agents.loading import load_agent

    return load_agent(path, algo, env_id=RANDOM_ENV_ID)


def as_policy(model: Any, env_kwargs: dict[str, Any] | None = None) -> Any:
    """A policy from an SB3 model (its VecNormalize statistics if it has them, on the
    randomised id with ``env_kwargs``) or a policy (returned as it is)."""
    if hasattr(model, "act"):
        return model
    from agents.loading import Agent

    get_vn = getattr(model, "get_vec_normalize_env", None)
    return Agent(model, get_vn() if get_vn else None, RANDOM_ENV_ID, dict(env_kwargs or {}), "model")


def evaluate_suite(
    policy: Any,
    suite: Suite,
    n: int | None = None,
    progress: bool = False,
    *,
    env_id: str | None = None,
    env_kwargs: dict[str, Any] | None = None,
) -> list[SuiteRow]:
    """One :class:`SuiteRow` per scenario of ``suite.subset(n)``; the policy runs in ``env_id``
    with ``env_kwargs`` (default: its own ``env_id`` / ``env_kwargs`` attributes, else the
    randomised id without arguments)."""
    env_id = env_id or getattr(policy, "env_id", RANDOM_ENV_ID)
    env_kwargs = dict(getattr(policy, "env_kwargs", {}) if env_kwargs is None else env_kwargs)
    act = fast_act(policy)
    entries = suite.subset(n)
    if env_id not in ENV_IDS:  # the randomised id: every scenario at once, in its batched env
        episodes = run_scenarios(act, [e.config for e in entries], env_id, env_kwargs, seed=0)
        return [SuiteRow.of(e, episode) for e, episode in zip(entries, episodes, strict=True)]
    if progress:
        from tqdm.auto import tqdm

        entries = tqdm(entries, desc="suite report", unit="scenario")
    with ScenarioRunner(env_id, env_kwargs) as runner:
        return [SuiteRow.of(e, runner.run(act, e.config, seed=0)) for e in entries]


def summarize(rows: Sequence[SuiteRow]) -> dict[str, Any]:
    """Mean, 10th percentile and minimum % of DP; feasible count; median plan times and speed-up."""
    pct = np.array([r.pct_dp for r in rows])
    policy_s = float(np.median([r.seconds for r in rows]))
    sca_s = float(np.median([r.sca_seconds for r in rows]))
    return {
        "n": len(rows),
        "mean_pct_dp": float(pct.mean()),
        "p10_pct_dp": float(np.percentile(pct, 10)),
        "min_pct_dp": float(pct.min()),
        "feasible": int(sum(r.feasible for r in rows)),
        "sca_mean_pct_dp": float(np.mean([r.sca_pct_dp for r in rows])),
        "sca_feasible": int(sum(r.sca_feasible for r in rows)),
        "median_seconds": policy_s,
        "sca_median_seconds": sca_s,
        "speedup": sca_s / policy_s if policy_s > 0 else math.inf,
    }


def suite_score(
    model: Any, suite: Suite | str | Path | None = None, n: int | None = None, env_kwargs: dict | None = None
) -> dict[str, float]:
    """The suite score of ``model`` (an SB3 model, with its VecNormalize if any, or a policy):
    {"mean_pct_dp", "p10_pct_dp", "min_pct_dp", "feasible_frac", "n"} over the first ``n``
    scenarios (all for None). ``env_kwargs``: the training env's (e.g. the guard). For a
    training callback (log e.g. ``suite/mean_pct_dp``)."""
    suite = load_suite(SUITE_PATH if suite is None else suite) if not isinstance(suite, Suite) else suite
    rows = evaluate_suite(as_policy(model, env_kwargs), suite, n)
    s = summarize(rows)
    return {
        "mean_pct_dp": s["mean_pct_dp"],
        "p10_pct_dp": s["p10_pct_dp"],
        "min_pct_dp": s["min_pct_dp"],
        "feasible_frac": s["feasible"] / s["n"],
        "n": s["n"],
    }


CSV_COLUMNS = tuple(f for f in SuiteRow.__dataclass_fields__ if f != "trajectory")


def save_csv(rows: Sequence[SuiteRow], path: str | Path) -> Path:
    """One row per scenario (full precision), atomically."""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=CSV_COLUMNS, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        values = {k: v for k, v in asdict(row).items() if k != "trajectory"}
        writer.writerow({k: repr(v) if isinstance(v, float) else v for k, v in values.items()})
    return atomic_write_text(path, buf.getvalue())


def summary_text(s: dict[str, Any], name: str = "policy") -> str:
    return (
        f"{name} on {s['n']} held-out scenarios: {s['mean_pct_dp']:.2f}% of DP on average, "
        f"10th percentile {s['p10_pct_dp']:.2f}%, minimum {s['min_pct_dp']:.2f}%; feasible "
        f"{s['feasible']}/{s['n']} (SCA: {s['sca_mean_pct_dp']:.2f}% of DP, "
        f"feasible {s['sca_feasible']}/{s['n']}); "
        f"median plan time {1e3 * s['median_seconds']:.1f} ms vs SCA {s['sca_median_seconds']:.2f} s "
        f"({s['speedup']:.0f}x faster)"
    )


def markdown(rows: Sequence[SuiteRow], s: dict[str, Any], name: str = "policy") -> str:
    """The suite table and the summary as markdown."""
    lines = [
        f"# {name} on the held-out suite",
        "",
        summary_text(s, name),
        "",
        "| # | surface | T (s) | M | DP rate | rate | % of DP | feasible | plan (ms) | SCA % of DP "
        "| SCA (s) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r.index} | {r.surface} | {r.T:g} | {r.M} | {r.dp_rate:.4f} | {r.rate:.4f} | "
            f"{r.pct_dp:.2f} | {'yes' if r.feasible else 'NO'} | {1e3 * r.seconds:.1f} | "
            f"{r.sca_pct_dp:.2f} | {r.sca_seconds:.2f} |"
        )
    return "\n".join(lines) + "\n"


def _figure(size: tuple[float, float]) -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, dpi=100)
    FigureCanvasAgg(fig)
    return fig


def save_trajectories_figure(
    rows: Sequence[SuiteRow], suite: Suite, path: str | Path, name: str = "policy"
) -> Path:
    """2 x 3 small multiples: six scenarios from the worst to the best % of DP (policy, DP, SCA)."""
    from ios_uav_env.envs.rendering import plot_rate_map, plot_trajectories

    by_index = {e.index: e for e in suite}
    ranked = sorted(rows, key=lambda r: r.pct_dp)
    picks = sorted({round(q * (len(ranked) - 1)) for q in np.linspace(0, 1, 6)})
    fig = _figure((15, 6.4))
    for k, i in enumerate(picks):
        row = ranked[i]
        e = by_index[row.index]
        ax = fig.add_subplot(2, 3, k + 1)
        plot_rate_map(ax, e.config, resolution=(120, 60), colorbar=False)
        lines = {name: row.trajectory, "DP": e.dp["trajectory"], "SCA": e.sca["trajectory"]}
        plot_trajectories(ax, e.config, lines, legend=k == 0, lw=1.2, ms=2)
        ax.set_title(f"#{row.index} {row.surface.upper()}, T={row.T:g} s, M={row.M}: {row.pct_dp:.1f}% of DP",
                     fontsize=9)  # fmt: skip
    fig.tight_layout()
    return save_figure(fig, path)


def save_histogram(rows: Sequence[SuiteRow], path: str | Path, name: str = "policy") -> Path:
    """Histogram of the policy's % of DP (and SCA's) over the suite."""
    fig = _figure((7, 4))
    ax = fig.add_subplot()
    pct = [r.pct_dp for r in rows]
    sca = [r.sca_pct_dp for r in rows]
    bins = np.linspace(min(min(pct), min(sca), 90.0), max(max(pct), max(sca), 100.5), 30)
    ax.hist(pct, bins=bins, alpha=0.75, label=name)
    ax.hist(sca, bins=bins, alpha=0.5, label="SCA")
    ax.axvline(100.0, color="k", lw=0.8, ls="--")
    ax.set_xlabel("% of the DP optimum (2.5 m grid)")
    ax.set_ylabel("scenarios")
    ax.legend()
    fig.tight_layout()
    return save_figure(fig, path)


def run_report(
    policy: Any, suite: Suite, out: str | Path, n: int | None = None, progress: bool = True
) -> dict[str, Any]:
    """Evaluate, print the table and the summary, write the CSV, markdown and figures to ``out``.
    A multi-node agent is scored on the multi-node suite instead (:mod:`agents.suite.multi`)."""
    from agents.evaluate_multi import is_multinode

    if is_multinode(policy):
        from agents.suite.multi import multi_report

        return multi_report(policy, out, n)
    out = Path(out)
    name = getattr(policy, "name", "policy")
    rows = evaluate_suite(policy, suite, n, progress=progress)
    s = summarize(rows)
    table = markdown(rows, s, name)
    print(table)
    paths = {
        "csv": save_csv(rows, out / "suite_report.csv"),
        "markdown": atomic_write_text(out / "suite_report.md", table),
        "trajectories": save_trajectories_figure(rows, suite, out / "suite_trajectories.png", name),
        "histogram": save_histogram(rows, out / "suite_pct_dp.png", name),
    }
    print("wrote " + ", ".join(str(p) for p in paths.values()))
    return {"summary": s, "rows": rows, "paths": paths}
