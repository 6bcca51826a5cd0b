"""Benchmark results for any number of ground nodes: one row per scenario, the aggregate, and
their CSV, JSON, markdown and figures.

Every plan is scored by :func:`ios_uav_env.score_plan` (its own rate, its best schedule's rate,
eq. (10)). What a suite reports is its :class:`Metrics`, named by the suite's kind
(:mod:`ios_uav_env.benchmark.metrics`, re-exported here).

``pct_<reference>`` = 100 x rate / the reference's rate on the scenario (energy: 100 x EE / the
reference's EE). **An infeasible plan
(eq. (10): it misses q0 or qF or moves faster than v_max) scores 0** (its rate is still
reported): the mission was not flown. "% of DP" and "% of SCA" may exceed 100 (DP is the optimum
on a grid, SCA a local optimum); "% of bound" never does for a feasible plan.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ios_uav_env.benchmark.metrics import LABELS, METRICS, Metrics, metrics_of  # noqa: F401 (re-exported)
from ios_uav_env.benchmark.suite import Suite, SuiteScenario
from ios_uav_env.benchmark.suite_registry import TIMED
from ios_uav_env.io import atomic_write_text, save_rows_csv
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.score import PlanScore


@dataclass(frozen=True)
class ScenarioResult:
    """A plan on one scenario of a suite (any K)."""

    index: int
    K: int
    rate: float  # bps/Hz, the plan's own score (ios_uav_env.score_plan)
    best_schedule_rate: float  # bps/Hz, with the best shares of its trajectory (= rate for K = 1)
    feasible: bool  # eq. (10) within FEASIBILITY_TOL
    worst_violation: float  # m, worst breach of eq. (10); NaN for a stored reference
    pct: Mapping[str, float]  # by reference: 100 x rate / the reference's rate; 0 if infeasible
    best_pct: float  # 100 x best_schedule_rate / the normaliser's rate; 0 if infeasible
    seconds: float  # wall time to plan; NaN if unknown (a trajectory file)
    own_shares: bool  # rate scored with the plan's own shares (always for K = 1)
    metrics: Metrics = field(repr=False, compare=False)
    trajectory: np.ndarray | None = field(default=None, repr=False, compare=False)  # (N, 2) m
    shares: np.ndarray | None = field(default=None, repr=False, compare=False)  # (K, N), own shares
    config: ScenarioConfig | None = field(default=None, repr=False, compare=False)
    energy: float = math.nan  # J, propulsion energy E of the flight (PlanScore.energy)
    energy_efficiency: float = math.nan  # bits/J, B T rate / E: an energy suite's score
    seed: int | None = field(default=None, compare=False)  # a mobile scenario's episode seed

    @classmethod
    def of(
        cls,
        scenario: SuiteScenario,
        metrics: Metrics,
        score: PlanScore | tuple[float, float, bool, float, bool],
        seconds: float,
        trajectory: np.ndarray | None = None,
        shares: np.ndarray | None = None,
        energy: tuple[float, float] | None = None,
    ) -> ScenarioResult:
        """The result of a plan's ``score`` (a :class:`PlanScore`, or stored values as
        ``(rate, best_schedule_rate, feasible, worst_violation, own_shares)`` and, for an energy
        suite, ``energy`` = (E in J, EE in bits/J)) on ``scenario``. An energy suite's scores
        are of the EE (a :class:`PlanScore`'s ``objective_value`` on its scenarios)."""
        if isinstance(score, PlanScore):
            values = (score.rate, score.best_schedule_rate, score.feasible,
                      score.report.worst_violation, score.own_shares)  # fmt: skip
            energy = (score.energy, score.objective_value if metrics.energy else score.energy_efficiency)
        else:
            values = score
        if metrics.energy and energy is None:
            raise ValueError(
                f"scenario {scenario.index}: an energy suite's result needs the plan's energy and EE"
            )
        rate, best, feasible, worst, own = (
            float(values[0]),
            float(values[1]),
            bool(values[2]),
            values[3],
            values[4],
        )
        e, ee = (math.nan, math.nan) if energy is None else (float(energy[0]), float(energy[1]))
        value, best_value = (ee, ee) if metrics.energy else (rate, best)
        pct = {r: 100.0 * value / scenario.value(r) if feasible else 0.0 for r in metrics.scores}
        best_pct = 100.0 * best_value / scenario.value(metrics.normaliser) if feasible else 0.0
        return cls(scenario.index, scenario.config.K, rate, best, feasible, float(worst), pct, best_pct,
                   float(seconds), bool(own), metrics, trajectory, shares, scenario.config,
                   e, ee, scenario.seed)  # fmt: skip

    def __getattr__(self, name: str) -> float:
        """``pct_<reference>`` and ``best_pct_<normaliser>`` by name (e.g. ``pct_dp``)."""
        if name.startswith("pct_") and name[4:] in self.__dict__.get("pct", {}):
            return float(self.pct[name[4:]])
        if "metrics" in self.__dict__ and name == f"best_pct_{self.metrics.normaliser}":
            return self.best_pct
        raise AttributeError(f"{type(self).__name__} has no attribute {name!r}")

    def to_dict(self) -> dict[str, Any]:
        """The fields of :meth:`Metrics.columns` (not the trajectory, shares or config)."""
        return {k: getattr(self, k) for k in self.metrics.columns()}


@dataclass(frozen=True)
class Aggregate:
    """Mean, 10th percentile and minimum of each score over the scenarios; counts and times."""

    n: int
    feasible: int
    stats: Mapping[str, float]  # mean_pct_<r>, p10_pct_<r>, min_pct_<r>, ..., mean_rate, ...
    median_seconds: float  # the policy's median time to plan (NaN if unknown)
    # the timed reference's (TIMED: SCA's; MPC(k=1)'s on a mobile suite), from the suite file
    sca_median_seconds: float

    @classmethod
    def of(cls, rows: Sequence[ScenarioResult], scenarios: Sequence[SuiteScenario]) -> Aggregate:
        if not rows:
            raise ValueError("no scenario results to aggregate")
        metrics = rows[0].metrics
        stats: dict[str, float] = {}
        for ref in metrics.scores:
            mean, p10, low = spread([r.pct[ref] for r in rows])
            stats.update({f"mean_pct_{ref}": mean, f"p10_pct_{ref}": p10, f"min_pct_{ref}": low})
        if metrics.schedules:
            stats[f"mean_best_pct_{metrics.normaliser}"] = float(np.mean([r.best_pct for r in rows]))
        stats["mean_rate"] = float(np.mean([r.rate for r in rows]))
        if metrics.energy:
            stats["mean_energy_efficiency"] = float(np.mean([r.energy_efficiency for r in rows]))
        if metrics.schedules:
            stats["mean_best_rate"] = float(np.mean([r.best_schedule_rate for r in rows]))
        median, sca_median = plan_seconds(rows, scenarios)
        return cls(len(rows), int(sum(r.feasible for r in rows)), stats, median, sca_median)

    def __getattr__(self, name: str) -> float:
        stats = self.__dict__.get("stats", {})
        if name in stats:
            return float(stats[name])
        raise AttributeError(f"{type(self).__name__} has no attribute {name!r}")

    def to_dict(self) -> dict[str, Any]:
        return {"n": self.n, "feasible": self.feasible, **self.stats, "median_seconds": self.median_seconds,
                "sca_median_seconds": self.sca_median_seconds}  # fmt: skip


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
    metrics: Metrics = field(repr=False)
    # the env arguments that made another task than the suite's (overrides.task_changes): {} on the suite's
    task_changes: Mapping[str, Any] = field(default_factory=dict)

    @classmethod
    def of(cls, suite: Suite, name: str, kwargs: Mapping[str, Any], rows: Sequence[ScenarioResult],
           scenarios: Sequence[SuiteScenario]) -> Results:  # fmt: skip
        """The results of ``rows`` on ``suite``'s ``scenarios``, run with the env arguments
        ``kwargs``; those that change the suite's task are kept as :attr:`task_changes`."""
        from ios_uav_env.benchmark.overrides import task_changes

        return cls(name, suite.name, suite.sha256, suite.env_id, dict(kwargs), tuple(rows),
                   Aggregate.of(rows, scenarios), metrics_of(suite), task_changes(suite, kwargs))  # fmt: skip

    @property
    def task(self) -> str:
        """What was run: the suite's name, or for a changed task ``"<suite> with k=v, ... [not
        <suite>'s task]"`` (``overrides.task_label``), as the summary, the files and the figures
        name it."""
        from ios_uav_env.benchmark.overrides import task_label

        return task_label(self.suite, self.task_changes)

    def __iter__(self) -> Iterator[ScenarioResult]:
        return iter(self.scenarios)

    def __len__(self) -> int:
        return len(self.scenarios)

    def to_dict(self) -> dict[str, Any]:
        """What was run (``task``: :attr:`task`; ``task_changes``: the arguments that changed it),
        the aggregate and the rows."""
        return {
            "name": self.name, "task": self.task, "suite": self.suite, "sha256": self.sha256,
            "env_id": self.env_id, "env_kwargs": dict(self.env_kwargs),
            "task_changes": dict(self.task_changes), "aggregate": self.aggregate.to_dict(),
            "scenarios": [r.to_dict() for r in self.scenarios],
        }  # fmt: skip

    def summary(self) -> str:
        """One line: mean / p10 / min of each score, the best schedule (K > 1), the feasible count
        and the median time to plan."""
        a, m = self.aggregate, self.metrics
        st = a.stats
        parts = [f"% of {LABELS[r]} mean {st[f'mean_pct_{r}']:.2f} | p10 {st[f'p10_pct_{r}']:.2f} | "
                 f"min {st[f'min_pct_{r}']:.2f}" for r in m.scores]  # fmt: skip
        if m.schedules:
            parts.append(f"best schedule % of {LABELS[m.normaliser]} mean "
                         f"{a.stats[f'mean_best_pct_{m.normaliser}']:.2f}")  # fmt: skip
        parts.append(f"feasible {a.feasible}/{a.n}")
        plan = f"median plan {plan_time(a.median_seconds)} ({LABELS[m.timed]} {a.sca_median_seconds:.2f} s)"
        return f"{self.name} on {self.task} ({a.n} scenarios): " + "; ".join([*parts, plan])

    def markdown(self) -> str:
        """The summary and one table row per scenario, as markdown."""
        m = self.metrics
        rates = ["K", "min rate (bps/Hz)", "shares", "best schedule"] if m.schedules else ["rate (bps/Hz)"]
        rates += ["energy (J)", "EE (bits/J)"] if m.energy else []
        head = ["#", *rates,
                "feasible", *(f"% of {LABELS[r]}" for r in m.scores),
                *([f"best % of {LABELS[m.normaliser]}"] if m.schedules else []), "plan (ms)"]  # fmt: skip
        lines = [f"# {self.name} on {self.task}", "", self.summary(), "", "| " + " | ".join(head) + " |",
                 "|" + "---|" * len(head)]  # fmt: skip
        for r in self.scenarios:
            cells = [str(r.index)]
            if m.schedules:
                cells += [
                    str(r.K),
                    f"{r.rate:.4f}",
                    "own" if r.own_shares else "best",
                    f"{r.best_schedule_rate:.4f}",
                ]
            else:
                cells.append(f"{r.rate:.4f}")
            if m.energy:
                cells += [f"{r.energy:.1f}", f"{r.energy_efficiency:.1f}"]
            cells += ["yes" if r.feasible else "NO", *(f"{r.pct[ref]:.2f}" for ref in m.scores)]
            cells += [f"{r.best_pct:.2f}"] if m.schedules else []
            lines.append("| " + " | ".join([*cells, f"{1e3 * r.seconds:.1f}"]) + " |")
        return "\n".join(lines) + "\n"

    def save_csv(self, path: str | Path) -> Path:
        """One row per scenario (full precision), atomically; a changed task's rows start with a
        ``task`` column (:attr:`task`)."""
        if not self.task_changes:
            return save_rows_csv(path, self.metrics.columns(), (r.to_dict() for r in self.scenarios))
        rows = ({"task": self.task, **r.to_dict()} for r in self.scenarios)
        return save_rows_csv(path, ("task", *self.metrics.columns()), rows)

    def save(self, out: str | Path, *, overwrite: bool = False) -> dict[str, Path]:
        """Write ``results.csv``, ``results.json`` (strict: NaN as null), ``results.md``, the plans
        as ``trajectories.npz`` (with their own shares; if every result has its trajectory: a file
        ``score_trajectories`` scores alike) and, with matplotlib, ``pct_<normaliser>.png`` and,
        K > 1, ``shares.png`` to the folder ``out``; the paths written by kind.

        Results already in ``out`` (:data:`~ios_uav_env.benchmark.outputs.RESULT_FILES`) are
        refused (``FileExistsError`` naming them) unless ``overwrite``; then those of the previous
        run that this one does not write again are removed once the new ones are written."""
        import json

        from ios_uav_env.benchmark.outputs import RESULT_FILES, claim, remove_stale
        from ios_uav_env.benchmark.trajectories import write_trajectories

        out = Path(out)
        previous = claim(out, RESULT_FILES, overwrite)
        paths = {
            "csv": self.save_csv(out / "results.csv"),
            "json": atomic_write_text(
                out / "results.json", json.dumps(_finite(self.to_dict()), indent=1) + "\n"
            ),
            "markdown": atomic_write_text(out / "results.md", self.markdown()),
        }
        if all(r.trajectory is not None for r in self.scenarios):
            plans = {r.index: r.trajectory for r in self.scenarios}
            own = {r.index: r.shares for r in self.scenarios if r.own_shares and r.shares is not None}
            times = {r.index: r.seconds for r in self.scenarios if not math.isnan(r.seconds)}
            paths["trajectories"] = write_trajectories(out / "trajectories.npz", plans, times, own or None)
        try:
            from ios_uav_env.benchmark.figures import save_histogram, save_shares_figure

            paths["figure"] = save_histogram(self, out / f"pct_{self.metrics.normaliser}.png")
            if self.metrics.schedules and any(r.trajectory is not None for r in self.scenarios):
                paths["shares"] = save_shares_figure(self, out / "shares.png")
            if any(r.seed is not None and r.trajectory is not None for r in self.scenarios):
                from ios_uav_env.benchmark.figures import save_mobile_figure

                paths["mobile"] = save_mobile_figure(self, out / "mobile.png")
                paths["mobile_scenarios"] = save_mobile_figure(self, out / "mobile_scenarios.png", count=None)
        except ImportError:
            pass
        remove_stale(previous, paths.values())
        return paths


def spread(values: Sequence[float]) -> tuple[float, float, float]:
    """The mean, 10th percentile and minimum of scores."""
    a = np.asarray(values, dtype=np.float64)
    return float(a.mean()), float(np.percentile(a, 10)), float(a.min())


def plan_seconds(rows: Sequence[Any], scenarios: Sequence[SuiteScenario]) -> tuple[float, float]:
    """The rows' median time to plan (NaN if any is unknown) and the timed reference's (SCA's;
    MPC(k=1)'s on a mobile suite: :data:`~ios_uav_env.benchmark.suite_registry.TIMED`), from the
    suite file."""
    seconds = np.array([r.seconds for r in rows])
    median = float(np.median(seconds)) if np.isfinite(seconds).all() else math.nan
    timed = TIMED[scenarios[0].kind]
    return median, float(np.median([s.reference[timed]["seconds"] for s in scenarios]))


def plan_time(median_seconds: float) -> str:
    """A median time to plan for the summary line: ``"12.3 ms"``, or ``"unknown"``."""
    return "unknown" if math.isnan(median_seconds) else f"{1e3 * median_seconds:.1f} ms"


def _finite(value: Any) -> Any:
    """``value`` with every NaN float replaced by None (strict JSON)."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    return None if isinstance(value, float) and math.isnan(value) else value


def reference_results(suite: Suite, reference: str, n: int | None = None) -> Results:
    """A stored reference scored as a policy from its stored rate and feasibility (single-node:
    ``"dp"``, ``"sca"``, ``"hover_peak"``, ``"hover_ground"``; multi-node: ``"sca"``, ``"tour"``,
    ``"bound"``, the upper bound as if it were a plan's rate; DP's plans are feasible by
    construction; energy: its stored EE, energy and rate, the bound's EE as if it were a plan's)."""
    if reference not in suite.references:
        raise KeyError(f"suite {suite.name} has no reference {reference!r}; it has {list(suite.references)}")
    metrics, scenarios = metrics_of(suite), suite.subset(n)
    rows = []
    for s in scenarios:
        ref = s.reference[reference]
        if metrics.energy:
            rate = float(ref.get("rate", math.nan))
            energy = (float(ref.get("energy", math.nan)), s.value(reference))
        else:
            rate, energy = s.rate(reference), None
        values = (rate, rate, bool(ref.get("feasible", True)), math.nan, True)
        rows.append(ScenarioResult.of(s, metrics, values, float(ref.get("seconds", math.nan)), energy=energy))
    return Results.of(suite, reference, suite.env_kwargs, rows, scenarios)
