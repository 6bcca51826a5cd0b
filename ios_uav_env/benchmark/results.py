"""Benchmark results: one row per scenario, the aggregate, and their CSV, JSON, markdown and figure.

The score of a scenario is the policy's rate as a percentage of the suite's reference values:
``pct_dp`` = 100 x rate / DP rate and ``pct_sca`` = 100 x rate / SCA rate. An infeasible plan
(eq. (10): it misses q0 or qF or moves faster than v_max) scores 0 on both (its rate is still
reported): the mission was not flown. "% of DP" may exceed 100: DP is the optimum over a grid.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ios_uav_env.benchmark.suite import Suite, SuiteScenario
from ios_uav_env.io import atomic_write_text, save_figure, save_rows_csv


@dataclass(frozen=True)
class ScenarioResult:
    """A policy's plan on one scenario of a suite."""

    index: int
    rate: float  # bps/Hz, eq. (9) of the plan (ios_uav_env.average_rate)
    feasible: bool  # eq. (10) within FEASIBILITY_TOL (ios_uav_env.check_trajectory)
    worst_violation: float  # m, worst breach of eq. (10)
    pct_dp: float  # 100 x rate / the DP optimum's rate; 0 if infeasible
    pct_sca: float  # 100 x rate / the SCA plan's rate; 0 if infeasible
    seconds: float  # wall time to plan (reset to last step); NaN if unknown (a trajectory file)
    trajectory: np.ndarray | None = field(default=None, repr=False, compare=False)  # (N, 2) m, the plan

    @classmethod
    def of(
        cls,
        scenario: SuiteScenario,
        rate: float,
        feasible: bool,
        worst_violation: float,
        seconds: float,
        trajectory: np.ndarray | None = None,
    ) -> ScenarioResult:
        """The result of a plan of ``rate`` and ``feasible`` on ``scenario``."""
        ok = bool(feasible)
        return cls(
            scenario.index, float(rate), ok, float(worst_violation),
            100.0 * rate / scenario.dp_rate if ok else 0.0,
            100.0 * rate / scenario.sca_rate if ok else 0.0,
            float(seconds), trajectory,
        )  # fmt: skip

    def to_dict(self) -> dict[str, Any]:
        """The fields but the trajectory."""
        return {k: getattr(self, k) for k in COLUMNS}


#: The fields of a :class:`ScenarioResult` in its dict and CSV row.
COLUMNS = ("index", "rate", "feasible", "worst_violation", "pct_dp", "pct_sca", "seconds")


@dataclass(frozen=True)
class Aggregate:
    """Mean, 10th percentile and minimum of the scores over the scenarios; counts and times."""

    n: int
    feasible: int
    mean_pct_dp: float
    p10_pct_dp: float
    min_pct_dp: float
    mean_pct_sca: float
    p10_pct_sca: float
    min_pct_sca: float
    mean_rate: float  # bps/Hz
    median_seconds: float  # the policy's median time to plan (NaN if unknown)
    sca_median_seconds: float  # SCA's, from the suite file, on the same scenarios

    @classmethod
    def of(cls, rows: Sequence[ScenarioResult], scenarios: Sequence[SuiteScenario]) -> Aggregate:
        if not rows:
            raise ValueError("no scenario results to aggregate")
        mean_dp, p10_dp, min_dp = spread([r.pct_dp for r in rows])
        mean_sca, p10_sca, min_sca = spread([r.pct_sca for r in rows])
        median, sca_median = plan_seconds(rows, scenarios)
        return cls(
            n=len(rows),
            feasible=int(sum(r.feasible for r in rows)),
            mean_pct_dp=mean_dp,
            p10_pct_dp=p10_dp,
            min_pct_dp=min_dp,
            mean_pct_sca=mean_sca,
            p10_pct_sca=p10_sca,
            min_pct_sca=min_sca,
            mean_rate=float(np.mean([r.rate for r in rows])),
            median_seconds=median,
            sca_median_seconds=sca_median,
        )

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class Results:
    """A policy's results on a suite: per scenario, aggregate, and what was run."""

    name: str  # the policy's name
    suite: str  # the suite's name
    sha256: str  # the suite's content hash
    env_id: str
    env_kwargs: dict[str, Any]
    scenarios: tuple[ScenarioResult, ...] = field(repr=False)
    aggregate: Aggregate

    def to_dict(self) -> dict[str, Any]:
        return results_dict(self)

    def summary(self) -> str:
        """One line: mean / p10 / min % of DP and of SCA, feasible count, median time to plan."""
        a = self.aggregate
        plan = plan_time(a.median_seconds)
        return (
            f"{self.name} on {self.suite} ({a.n} scenarios): % of DP mean {a.mean_pct_dp:.2f} | "
            f"p10 {a.p10_pct_dp:.2f} | min {a.min_pct_dp:.2f}; % of SCA mean {a.mean_pct_sca:.2f} | "
            f"p10 {a.p10_pct_sca:.2f} | min {a.min_pct_sca:.2f}; feasible {a.feasible}/{a.n}; "
            f"median plan {plan} (SCA {a.sca_median_seconds:.2f} s)"
        )

    def markdown(self) -> str:
        """The summary and one table row per scenario, as markdown."""
        lines = [
            f"# {self.name} on {self.suite}", "", self.summary(), "",
            "| # | rate (bps/Hz) | feasible | % of DP | % of SCA | plan (ms) |",
            "|---|---|---|---|---|---|",
        ]  # fmt: skip
        for r in self.scenarios:
            lines.append(
                f"| {r.index} | {r.rate:.4f} | {'yes' if r.feasible else 'NO'} | {r.pct_dp:.2f} | "
                f"{r.pct_sca:.2f} | {1e3 * r.seconds:.1f} |"
            )
        return "\n".join(lines) + "\n"

    def save_csv(self, path: str | Path) -> Path:
        """One row per scenario (full precision), atomically."""
        return save_rows_csv(path, COLUMNS, (r.to_dict() for r in self.scenarios))

    def save_figure(self, path: str | Path) -> Path:
        """Histogram of % of DP over the scenarios (needs matplotlib: ``ios-uav-env[render]``)."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        fig = Figure(figsize=(7, 4), dpi=100)
        FigureCanvasAgg(fig)
        ax = fig.add_subplot()
        pct = [r.pct_dp for r in self.scenarios]
        ax.hist(pct, bins=np.linspace(min(min(pct), 95.0), max(max(pct), 101.0), 30), alpha=0.8)
        ax.axvline(100.0, color="k", lw=0.8, ls="--")
        ax.set_xlabel("% of the DP optimum")
        ax.set_ylabel("scenarios")
        ax.set_title(f"{self.name} on {self.suite}: mean {self.aggregate.mean_pct_dp:.2f}%", fontsize=9)
        fig.tight_layout()
        return save_figure(fig, path)

    def save(self, out: str | Path) -> dict[str, Path]:
        """Write ``results.csv``, ``results.json``, ``results.md``, the plans as ``trajectories.npz``
        (if every result has its trajectory: a file ``score_trajectories`` scores alike) and, with
        matplotlib, ``pct_dp.png`` to the folder ``out``; the paths written by kind."""
        from ios_uav_env.benchmark.trajectories import write_trajectories

        out = Path(out)
        paths = save_tables(self, out)
        if all(r.trajectory is not None for r in self.scenarios):
            plans = {r.index: r.trajectory for r in self.scenarios}
            times = {r.index: r.seconds for r in self.scenarios if not math.isnan(r.seconds)}
            paths["trajectories"] = write_trajectories(out / "trajectories.npz", plans, times)
        try:
            paths["figure"] = self.save_figure(out / "pct_dp.png")
        except ImportError:
            pass
        return paths


def spread(values: Sequence[float]) -> tuple[float, float, float]:
    """The mean, 10th percentile and minimum of scores."""
    a = np.asarray(values, dtype=np.float64)
    return float(a.mean()), float(np.percentile(a, 10)), float(a.min())


def plan_seconds(rows: Sequence[Any], scenarios: Sequence[SuiteScenario]) -> tuple[float, float]:
    """The rows' median time to plan (NaN if any is unknown) and SCA's, from the suite file."""
    seconds = np.array([r.seconds for r in rows])
    median = float(np.median(seconds)) if np.isfinite(seconds).all() else math.nan
    return median, float(np.median([s.reference["sca"]["seconds"] for s in scenarios]))


def plan_time(median_seconds: float) -> str:
    """A median time to plan for the summary line: ``"12.3 ms"``, or ``"unknown"``."""
    return "unknown" if math.isnan(median_seconds) else f"{1e3 * median_seconds:.1f} ms"


def results_dict(results: Any) -> dict[str, Any]:
    """The dict of a :class:`Results` or a ``MultiResults``: what was run, aggregate, scenarios."""
    return {
        "name": results.name, "suite": results.suite, "sha256": results.sha256, "env_id": results.env_id,
        "env_kwargs": dict(results.env_kwargs), "aggregate": results.aggregate.to_dict(),
        "scenarios": [r.to_dict() for r in results.scenarios],
    }  # fmt: skip


def save_tables(results: Any, out: Path) -> dict[str, Path]:
    """``results.csv``, ``results.json`` (strict: NaN as null) and ``results.md`` of a
    :class:`Results` or a ``MultiResults`` in the folder ``out``, atomically; the paths by kind."""
    return {
        "csv": results.save_csv(out / "results.csv"),
        "json": atomic_write_text(
            out / "results.json", json.dumps(_finite(results.to_dict()), indent=1) + "\n"
        ),
        "markdown": atomic_write_text(out / "results.md", results.markdown()),
    }


def _finite(value: Any) -> Any:
    """``value`` with every NaN float replaced by None (strict JSON)."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    return None if isinstance(value, float) and math.isnan(value) else value


def reference_results(suite: Suite, reference: str, n: int | None = None) -> Results:
    """A stored reference (``"dp"``, ``"sca"``, ``"hover_peak"``, ``"hover_ground"``) scored as a
    policy from its stored rate and feasibility (DP's plans are feasible by construction).
    Multi-node suites: ``"sca"``, ``"tour"``, ``"bound"`` (a ``MultiResults``)."""
    if reference not in suite.references:
        raise KeyError(f"suite {suite.name} has no reference {reference!r}; it has {list(suite.references)}")
    if suite.multi_node:
        from ios_uav_env.benchmark.multi import multi_reference_results

        return multi_reference_results(suite, reference, n)  # type: ignore[return-value]
    scenarios = suite.subset(n)
    rows = []
    for s in scenarios:
        ref = s.reference[reference]
        seconds = float(ref.get("seconds", math.nan))
        feasible = bool(ref.get("feasible", True))
        rows.append(ScenarioResult.of(s, float(ref["rate"]), feasible, math.nan, seconds))
    return Results(reference, suite.name, suite.sha256, suite.env_id, dict(suite.env_kwargs), tuple(rows),
                   Aggregate.of(rows, scenarios))  # fmt: skip
