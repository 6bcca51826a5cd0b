"""Score a policy on the held-out suite: % of each scenario's DP optimum, feasibility, plan time.

For every suite scenario (``agents.suite``) the policy is rolled out deterministically and its
trajectory is scored with ``ios_uav_env.average_rate`` and checked with ``check_trajectory``,
like the planners' plans. A policy trained on ``ios_uav_env/IOSUAV-Random-v0`` runs in one
env of that id pinned per scenario with ``reset(options={"config": cfg})``; one trained on a
fixed id runs in that id made on the scenario (``agents.rollout.make_env``), so the shipped
single-scenario agents can be scored too. The plan time is the wall time from the reset to
the last step (policy inference and env steps), against SCA's time in the suite file.
"% of DP" may exceed 100: DP is the optimum over a 2.5 m grid, and an off-grid trajectory can
beat it (SCA does by 0.1-1.6% on the suite, most on short horizons).

    python -m agents.suite report --model runs/<run> [--algo ppo|sac] [--n 60] [--out out/suite]
    python -m agents.suite report --model heuristic      # fly to G, hover, arrive (guard)
    python -m agents.suite report --model peak-heuristic # fly to the reachable rate peak instead

Writes ``suite_report.csv`` (one row per scenario), ``suite_report.md`` (the table and the
summary), ``suite_trajectories.png`` (six scenarios, policy vs DP vs SCA over the rate map,
picked from the worst to the best % of DP) and ``suite_pct_dp.png`` (the histogram).
:func:`suite_score` is the same score as a dict, for a training callback.
"""

from __future__ import annotations

import csv
import io
import math
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Protocol

import gymnasium as gym
import numpy as np

from agents.suite import SUITE_PATH, Suite, SuiteEntry, load_suite
from ios_uav_env import RANDOM_ENV_ID, ScenarioConfig, average_rate, check_trajectory
from ios_uav_env.io import atomic_write_text, save_figure


class Policy(Protocol):
    """What the report needs: ``act`` (an ``agents.rollout.Agent`` has it) and the env it ran in."""

    env_id: str
    env_kwargs: dict[str, Any]

    def act(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray: ...


@dataclass
class GroundSeeker:
    """A heuristic policy on the observation alone: fly towards G at full speed and hover there;
    the arrival guard brings it to qF in time. A baseline (and the tests' policy)."""

    env_id: str = RANDOM_ENV_ID
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    name: str = "fly to G and hover (heuristic)"
    length_scale: float = 400.0  # m, the env's L
    D: float = 25.0  # m, v_max dt of the scenarios
    target: tuple[int, int] = (4, 6)  # the slice of the observation's (target - q) / L: G's

    def act(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
        move = np.asarray(obs[self.target[0] : self.target[1]], dtype=np.float64) * (
            self.length_scale / self.D
        )
        norm = float(np.hypot(*move))
        return (move / norm if norm > 1.0 else move).astype(np.float32)


def peak_seeker() -> GroundSeeker:
    """The same heuristic towards the reachable rate peak (``ios_uav_env.rate_peak``, the env's
    ``peak_hint`` features): fly there, hover, let the guard bring the UAV to qF."""
    return GroundSeeker(
        env_kwargs={"peak_hint": True},
        name="fly to the rate peak and hover (heuristic)",
        target=(-3, -1),
    )


#: The heuristic policies ``load_policy`` knows by name.
HEURISTICS = {"heuristic": GroundSeeker, "peak-heuristic": peak_seeker}


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


def load_policy(path: str | Path, algo: str | None = None) -> Any:
    """The policy at ``path`` (``agents.rollout.load_agent``), or a heuristic by name
    (:data:`HEURISTICS`: ``"heuristic"`` flies to G, ``"peak-heuristic"`` to the rate peak).
    ``algo`` checks the run's algorithm, or names a bare ``.zip``'s."""
    if str(path) in HEURISTICS:
        return HEURISTICS[str(path)]()
    from agents.rollout import Agent, load_agent

    path = Path(path)
    if algo is not None and path.suffix == ".zip" and not (path.parent / "config.json").exists():
        if not path.exists():
            raise FileNotFoundError(f"no model at {path}")
        import torch
        from stable_baselines3 import PPO, SAC

        torch.set_num_threads(1)
        model = {"ppo": PPO, "sac": SAC}[algo].load(path, device="cpu")
        return Agent(model, None, RANDOM_ENV_ID, {}, path.stem)
    agent = load_agent(path)
    found = type(agent.model).__name__.lower()
    if algo is not None and found != algo:
        raise ValueError(f"{path} holds a {found.upper()} model, not {algo.upper()}")
    return agent


def as_policy(model: Any, env_kwargs: dict[str, Any] | None = None) -> Any:
    """A policy from an SB3 model (its VecNormalize statistics if it has them) or a policy."""
    if hasattr(model, "act"):
        return model
    from agents.rollout import Agent

    get_vn = getattr(model, "get_vec_normalize_env", None)
    return Agent(model, get_vn() if get_vn else None, RANDOM_ENV_ID, dict(env_kwargs or {}), "model")


class _Planner:
    """Rolls a policy out on scenarios: one pinned env for the randomised id, else one per scenario."""

    def __init__(self, policy: Any) -> None:
        self.policy = policy
        self.act = policy.act
        if getattr(policy, "model", None) is not None:  # an SB3 agent: plan with its numpy export
            from agents.numpy_policy import NumpyPolicy

            self.act = NumpyPolicy.from_sb3(policy.model, getattr(policy, "vecnormalize", None)).act
        self.env_id = getattr(policy, "env_id", RANDOM_ENV_ID)
        self.env_kwargs = dict(getattr(policy, "env_kwargs", {}) or {})
        self.random = gym.spec(self.env_id).entry_point == "ios_uav_env.random_env:RandomIOSUAVEnv"
        self.env = gym.make(self.env_id, **self.env_kwargs) if self.random else None

    def plan(self, config: ScenarioConfig) -> tuple[np.ndarray, float]:
        """(trajectory, seconds from the reset to the last step) of a deterministic episode."""
        start = time.perf_counter()
        if self.random:
            env, options = self.env, {"config": config}
        else:
            from agents.rollout import make_env

            env, options = make_env(self.env_id, self.env_kwargs, config), None
        obs, _ = env.reset(seed=0, options=options)
        done = False
        while not done:
            obs, _, terminated, truncated, _ = env.step(self.act(obs, True))
            done = terminated or truncated
        seconds = time.perf_counter() - start
        trajectory = env.unwrapped.trajectory
        if env is not self.env:
            env.close()
        return trajectory, seconds

    def close(self) -> None:
        if self.env is not None:
            self.env.close()


def evaluate_suite(policy: Any, suite: Suite, n: int | None = None, progress: bool = False) -> list[SuiteRow]:
    """One :class:`SuiteRow` per scenario of ``suite.subset(n)``."""
    planner = _Planner(as_policy(policy))
    entries = suite.subset(n)
    if progress:
        from tqdm.auto import tqdm

        entries = tqdm(entries, desc="suite report", unit="scenario")
    rows = []
    try:
        for e in entries:
            trajectory, seconds = planner.plan(e.config)
            rows.append(_row(e, trajectory, seconds))
    finally:
        planner.close()
    return rows


def _row(e: SuiteEntry, trajectory: np.ndarray, seconds: float) -> SuiteRow:
    c = e.config
    rate = average_rate(c, trajectory)
    report = check_trajectory(c, trajectory)
    return SuiteRow(
        e.index, c.surface, c.T, c.M, e.dp_rate, rate, 100.0 * rate / e.dp_rate, report.feasible,
        report.end_error, seconds, e.sca["rate"], e.sca_pct_dp, bool(e.sca["feasible"]), e.sca["seconds"],
        trajectory,
    )  # fmt: skip


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
    scenarios (all for None). ``env_kwargs``: the training env's (e.g. the guard). ~20 ms per
    scenario; for a training callback (log e.g. ``suite/mean_pct_dp``)."""
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
    from ios_uav_env.rendering import plot_rate_map, plot_trajectories

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
    """Evaluate, print the table and the summary, write the CSV, markdown and figures to ``out``."""
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
