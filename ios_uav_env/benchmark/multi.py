"""Multi-node suites: score a plan (trajectory and TDMA shares) against SCA and the certified bound.

A plan on a multi-node scenario is a trajectory (N, 2) and, optionally, its shares alpha (K, N)
(>= 0, column sums <= 1). Its scores, by the one scorer of ``ios_uav_env.model.schedule``:

- ``rate``: the plan's own score min_k R_k = ``scheduled_rates(config, q, shares).min()`` (for a
  policy in ``MultiNodeEnv``: the shares it chose, ``info["min_rate"]`` at the last step). A plan
  given without shares (a trajectory file without ``shares_<index>``) is scored with the best
  schedule of its trajectory: ``rate`` = ``best_schedule_rate``, ``own_shares`` false;
- ``best_schedule_rate``: ``maxmin_rate(config, q)``, the best shares for the same flight;
- ``feasible``: eq. (10) (``check_trajectory``). **An infeasible plan scores 0.**
- ``pct_sca`` = 100 x rate / SCA's rate (the normaliser; may exceed 100), ``pct_bound`` = 100 x
  rate / the certified upper bound (never above 100 for a feasible plan), ``best_pct_sca`` =
  100 x best_schedule_rate / SCA's rate.

Aggregates: mean / 10th percentile / minimum of % of SCA and of % of the bound, the mean % of SCA
of the best schedule, the feasible count and the median plan time. Figures (matplotlib):
``pct_sca.png`` (histogram) and ``shares.png`` (three scenarios: the trajectory coloured by the
node served in each slot over the best-node rate map, and each node's share against the slot).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ios_uav_env.benchmark.results import plan_seconds, plan_time, results_dict, save_tables, spread
from ios_uav_env.benchmark.suite import Suite, SuiteScenario
from ios_uav_env.io import save_rows_csv
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.trajectory import check_trajectory

#: The fields of a :class:`MultiScenarioResult` in its dict and CSV row.
MULTI_COLUMNS = ("index", "K", "rate", "best_schedule_rate", "feasible", "worst_violation", "pct_sca",
                 "pct_bound", "best_pct_sca", "seconds", "own_shares")  # fmt: skip


def score_plan(
    scenario: SuiteScenario, trajectory: np.ndarray, shares: np.ndarray | None
) -> tuple[float, float, bool, float]:
    """(own score, best-schedule score, feasible, worst violation) of a plan on ``scenario``;
    ``ValueError`` naming the scenario for shares of the wrong shape or not a schedule."""
    from ios_uav_env.model.schedule import maxmin_rate, scheduled_rates

    cfg = scenario.config
    q = np.asarray(trajectory, dtype=np.float64)
    report = check_trajectory(cfg, q)
    best = float(maxmin_rate(cfg, q))
    if shares is None:
        return best, best, bool(report.feasible), float(report.worst_violation)
    try:
        own = float(scheduled_rates(cfg, q, np.asarray(shares, dtype=np.float64)).min())
    except ValueError as err:
        raise ValueError(f"scenario {scenario.index}: {err}") from None
    return own, best, bool(report.feasible), float(report.worst_violation)


@dataclass(frozen=True)
class MultiScenarioResult:
    """A plan on one scenario of a multi-node suite."""

    index: int
    K: int
    rate: float  # bps/Hz, min_k R_k with the plan's own shares (else its best schedule)
    best_schedule_rate: float  # bps/Hz, maxmin_rate of the trajectory
    feasible: bool
    worst_violation: float  # m
    pct_sca: float  # 100 x rate / SCA's rate; 0 if infeasible
    pct_bound: float  # 100 x rate / the certified upper bound; 0 if infeasible
    best_pct_sca: float  # 100 x best_schedule_rate / SCA's rate; 0 if infeasible
    seconds: float  # wall time to plan; NaN if unknown
    own_shares: bool  # rate scored with the plan's own shares
    trajectory: np.ndarray | None = field(default=None, repr=False, compare=False)
    shares: np.ndarray | None = field(default=None, repr=False, compare=False)
    config: ScenarioConfig | None = field(default=None, repr=False, compare=False)

    @classmethod
    def of(
        cls,
        scenario: SuiteScenario,
        rate: float,
        best: float,
        feasible: bool,
        worst_violation: float,
        seconds: float,
        *,
        own_shares: bool,
        trajectory: np.ndarray | None = None,
        shares: np.ndarray | None = None,
    ) -> MultiScenarioResult:
        ok = bool(feasible)
        sca, bound = scenario.rate("sca"), scenario.rate("bound")
        return cls(
            scenario.index, scenario.config.K, float(rate), float(best), ok, float(worst_violation),
            100.0 * rate / sca if ok else 0.0, 100.0 * rate / bound if ok else 0.0,
            100.0 * best / sca if ok else 0.0, float(seconds), bool(own_shares), trajectory, shares,
            scenario.config,
        )  # fmt: skip

    def to_dict(self) -> dict[str, Any]:
        return {k: getattr(self, k) for k in MULTI_COLUMNS}


@dataclass(frozen=True)
class MultiAggregate:
    """Mean, 10th percentile and minimum of % of SCA and of % of the bound; counts and times."""

    n: int
    feasible: int
    mean_pct_sca: float
    p10_pct_sca: float
    min_pct_sca: float
    mean_pct_bound: float
    p10_pct_bound: float
    min_pct_bound: float
    mean_best_pct_sca: float  # the best schedule of the same trajectories
    mean_rate: float
    mean_best_rate: float
    median_seconds: float
    sca_median_seconds: float

    @classmethod
    def of(cls, rows: Sequence[MultiScenarioResult], scenarios: Sequence[SuiteScenario]) -> MultiAggregate:
        if not rows:
            raise ValueError("no scenario results to aggregate")
        mean_sca, p10_sca, min_sca = spread([r.pct_sca for r in rows])
        mean_bound, p10_bound, min_bound = spread([r.pct_bound for r in rows])
        median, sca_median = plan_seconds(rows, scenarios)
        return cls(
            n=len(rows), feasible=int(sum(r.feasible for r in rows)),
            mean_pct_sca=mean_sca, p10_pct_sca=p10_sca, min_pct_sca=min_sca,
            mean_pct_bound=mean_bound, p10_pct_bound=p10_bound, min_pct_bound=min_bound,
            mean_best_pct_sca=float(np.mean([r.best_pct_sca for r in rows])),
            mean_rate=float(np.mean([r.rate for r in rows])),
            mean_best_rate=float(np.mean([r.best_schedule_rate for r in rows])),
            median_seconds=median, sca_median_seconds=sca_median,
        )  # fmt: skip

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class MultiResults:
    """A policy's results on a multi-node suite: per scenario, aggregate, and what was run."""

    name: str
    suite: str
    sha256: str
    env_id: str
    env_kwargs: dict[str, Any]
    scenarios: tuple[MultiScenarioResult, ...] = field(repr=False)
    aggregate: MultiAggregate

    def to_dict(self) -> dict[str, Any]:
        return results_dict(self)

    def summary(self) -> str:
        """One line: mean / p10 / min % of SCA and of the bound, best schedule, feasible, plan time."""
        a = self.aggregate
        plan = plan_time(a.median_seconds)
        return (
            f"{self.name} on {self.suite} ({a.n} scenarios): % of SCA mean {a.mean_pct_sca:.2f} | "
            f"p10 {a.p10_pct_sca:.2f} | min {a.min_pct_sca:.2f}; % of bound mean {a.mean_pct_bound:.2f} | "
            f"p10 {a.p10_pct_bound:.2f} | min {a.min_pct_bound:.2f}; best schedule % of SCA mean "
            f"{a.mean_best_pct_sca:.2f}; feasible {a.feasible}/{a.n}; median plan {plan} "
            f"(SCA {a.sca_median_seconds:.2f} s)"
        )

    def markdown(self) -> str:
        lines = [
            f"# {self.name} on {self.suite}", "", self.summary(), "",
            "| # | K | min rate (bps/Hz) | shares | best schedule | feasible | % of SCA | % of bound "
            "| best % of SCA | plan (ms) |",
            "|---|---|---|---|---|---|---|---|---|---|",
        ]  # fmt: skip
        for r in self.scenarios:
            lines.append(
                f"| {r.index} | {r.K} | {r.rate:.4f} | {'own' if r.own_shares else 'best'} | "
                f"{r.best_schedule_rate:.4f} | {'yes' if r.feasible else 'NO'} | {r.pct_sca:.2f} | "
                f"{r.pct_bound:.2f} | {r.best_pct_sca:.2f} | {1e3 * r.seconds:.1f} |"
            )
        return "\n".join(lines) + "\n"

    def save_csv(self, path: str | Path) -> Path:
        """One row per scenario (full precision), atomically."""
        return save_rows_csv(path, MULTI_COLUMNS, (r.to_dict() for r in self.scenarios))

    def save(self, out: str | Path) -> dict[str, Path]:
        """``results.{csv,json,md}``, the plans as ``trajectories.npz`` (with their shares) and, with
        matplotlib, ``pct_sca.png`` and ``shares.png`` in ``out``; the paths by kind."""
        from ios_uav_env.benchmark.trajectories import write_trajectories

        out = Path(out)
        paths = save_tables(self, out)
        if all(r.trajectory is not None for r in self.scenarios):
            plans = {r.index: r.trajectory for r in self.scenarios}
            own = {r.index: r.shares for r in self.scenarios if r.own_shares}
            times = {r.index: r.seconds for r in self.scenarios if not math.isnan(r.seconds)}
            paths["trajectories"] = write_trajectories(out / "trajectories.npz", plans, times, own or None)
        try:
            from ios_uav_env.benchmark.figures_multi import save_histogram, save_shares_figure

            paths["figure"] = save_histogram(self, out / "pct_sca.png")
            if any(r.trajectory is not None for r in self.scenarios):  # (a stored reference has none)
                paths["shares"] = save_shares_figure(self, out / "shares.png")
        except ImportError:
            pass
        return paths


def _results(
    suite: Suite,
    rows: list[MultiScenarioResult],
    name: str,
    kwargs: Mapping[str, Any],
    scenarios: Sequence[SuiteScenario],
) -> MultiResults:
    aggregate = MultiAggregate.of(rows, scenarios)
    return MultiResults(name, suite.name, suite.sha256, suite.env_id, dict(kwargs), tuple(rows), aggregate)


def multi_episode(env: Any, act: Any, scenario: SuiteScenario, seed: int | None) -> MultiScenarioResult:
    """One episode of ``act`` in a ``MultiNodeEnv`` pinned to ``scenario``, scored by :func:`score_plan`.
    Its plan time stops before the scoring, as the planners' (``Plan.seconds``, taken before
    ``Plan.from_trajectory`` scores the plan): the env's own best-schedule LP of the last step
    (``score_seconds``, for ``info["best_schedule_rate"]``) is not counted."""
    from ios_uav_env.benchmark.scoring import play

    base = env.unwrapped
    seconds = play(env, act, scenario, seed) - base.score_seconds
    trajectory, shares = base.trajectory, base.shares
    rate, best, feasible, worst = score_plan(scenario, trajectory, shares)
    return MultiScenarioResult.of(scenario, rate, best, feasible, worst, seconds, own_shares=True,
                                  trajectory=trajectory, shares=shares)  # fmt: skip


def evaluate_multi(
    act: Any,
    suite: Suite,
    scenarios: Sequence[SuiteScenario],
    kwargs: Mapping[str, Any],
    seed: int | None,
    name: str,
) -> MultiResults:
    """Roll ``act`` (obs -> action) out on ``scenarios`` in the suite's env with ``kwargs``."""
    import gymnasium as gym

    import ios_uav_env  # noqa: F401  (registers the ids)

    env = gym.make(suite.env_id, **kwargs)
    try:
        too_many = [s.index for s in scenarios if s.config.K > env.unwrapped.max_nodes]
        if too_many:
            raise ValueError(f"scenarios {too_many} have more nodes than the env's max_nodes = "
                             f"{env.unwrapped.max_nodes} (env_kwargs {dict(kwargs)})")  # fmt: skip
        rows = [multi_episode(env, act, s, seed) for s in scenarios]
    finally:
        env.close()
    return _results(suite, rows, name, kwargs, scenarios)


def score_multi_trajectories(
    trajectories: Mapping[int, Any],
    suite: Suite,
    scenarios: Sequence[SuiteScenario],
    seconds: Mapping[int, float] | None,
    shares: Mapping[int, Any] | None,
    name: str,
) -> MultiResults:
    """Score checked trajectories (and shares, for all scenarios or none) on a multi-node suite."""
    shares = dict(shares or {})
    if shares:
        missing = [s.index for s in scenarios if s.index not in shares]
        if missing:
            raise ValueError(f"shares are given for some scenarios but not for {missing}: give them for all "
                             "or none (without shares a plan is scored with its best schedule)")  # fmt: skip
    rows = []
    for s in scenarios:
        t = math.nan if seconds is None else float(seconds.get(s.index, math.nan))
        a = shares.get(s.index)
        rate, best, feasible, worst = score_plan(s, trajectories[s.index], a)
        q = np.asarray(trajectories[s.index], dtype=np.float64)
        own = None if a is None else np.asarray(a, dtype=np.float64)
        rows.append(MultiScenarioResult.of(s, rate, best, feasible, worst, t, own_shares=own is not None,
                                           trajectory=q, shares=own))  # fmt: skip
    return _results(suite, rows, name, {}, scenarios)


def multi_reference_results(suite: Suite, reference: str, n: int | None = None) -> MultiResults:
    """A stored reference (``"sca"``, ``"tour"``, ``"bound"``: the upper bound as if it were a
    plan's rate) scored from its stored values."""
    scenarios = suite.subset(n)
    rows = []
    for s in scenarios:
        ref = s.reference[reference]
        rate = s.rate(reference)
        rows.append(MultiScenarioResult.of(s, rate, rate, bool(ref.get("feasible", True)), math.nan,
                                           float(ref.get("seconds", math.nan)), own_shares=True))  # fmt: skip
    return _results(suite, rows, reference, dict(suite.env_kwargs), scenarios)
