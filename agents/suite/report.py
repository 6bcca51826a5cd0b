"""Score a policy on a benchmark suite (default ``single-node-v1``, the held-out draw of
``agents/suite/heldout.json``) through ``ios_uav_env.benchmark``: the one scorer and the one
result type, % of each scenario's DP optimum and of SCA, feasibility, plan time.

A policy trained on ``ios_uav_env/IOSUAV-Random-v0`` runs every scenario at once, row i of that
id's batched env pinned to scenario i (``ios_uav_env.benchmark.evaluate_scenarios`` with
``at_once``: the same episodes as one env pinned per scenario); one trained on a fixed id runs in
that id made on each scenario (``ScenarioRunner``), so the single-scenario agents can be scored
too, each plan scored by ``ios_uav_env.score_plan``. An SB3 agent plans with its numpy export
(``agents.numpy_policy``), the same actions without SB3's per-call overhead. The plan time is
the wall time from the reset to the last step (inference and env steps): for the batched
rollout, the batch's divided by the number of scenarios (the time per plan when the suite is
planned at once), compared with SCA's time in the suite file. "% of DP" may exceed 100: DP is
the optimum over a grid, and an off-grid trajectory can beat it.

    python -m agents.suite report --model runs/<run> [--algo ppo|sac] [--n 60] [--out out/suite]
    python -m agents.suite report --model heuristic      # fly to G, hover, arrive (guard)
    python -m agents.suite report --model peak-heuristic # fly to the reachable rate peak instead
    python -m agents.suite report --model runs/<multi-node run>  # on multi-node-v1 (agents.suite.multi)

Writes what ``ios_uav_env.benchmark.Results.save`` writes (``results.csv``, ``results.json``,
``results.md``, ``trajectories.npz``, ``pct_dp.png``) and ``suite_trajectories.png`` (six
scenarios, the policy against DP and SCA over the rate map, from the worst to the best % of DP;
DP's and SCA's plans from the held-out plan file). A folder that already holds a report is
refused before the model loads unless ``--overwrite`` is given (the previous report's files that
this one does not write are then removed). A model whose env arguments change the suite's task
(e.g. ``arrival_guard=False``: ``ios_uav_env.benchmark.overrides``) is refused unless
``--allow-task-change`` is given; its outputs then name the changed task. :func:`suite_score`
is the score as a dict, for a training callback.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from agents.evaluate_multi import fast_act
from agents.rollout import ScenarioRunner
from baselines.references.heldout import SUITE_PATH
from baselines.references.heldout import load_suite as load_plans
from ios_uav_env import ENV_IDS, RANDOM_ENV_ID, score_plan
from ios_uav_env.benchmark import DEFAULT_SUITE, Results, ScenarioResult, Suite, evaluate_scenarios
from ios_uav_env.benchmark import load_suite as load_benchmark
from ios_uav_env.benchmark.metrics import metrics_of
from ios_uav_env.benchmark.outputs import RESULT_FILES, claim, remove_stale
from ios_uav_env.benchmark.overrides import check_overrides, policy_env_kwargs
from ios_uav_env.benchmark.policy_errors import NamedPolicy
from ios_uav_env.envs.policies import HoverAt
from ios_uav_env.io import save_figure

#: The files a report may write to its folder: the benchmark's and the trajectory figure.
REPORT_FILES: tuple[str, ...] = (*RESULT_FILES, "suite_trajectories.png")

#: The heuristic policies :func:`load_policy` knows by name (``ios_uav_env.envs.policies.HoverAt``).
HEURISTICS: dict[str, Callable[[], HoverAt]] = {
    "heuristic": lambda: HoverAt("ground"),
    "peak-heuristic": lambda: HoverAt("peak"),
}


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


def _suite(suite: Suite | str | Path | None) -> Suite:
    return suite if isinstance(suite, Suite) else load_benchmark(DEFAULT_SUITE if suite is None else suite)


def evaluate_suite(
    policy: Any,
    suite: Suite | str | Path | None = None,
    n: int | None = None,
    progress: bool = False,
    *,
    env_id: str | None = None,
    env_kwargs: dict[str, Any] | None = None,
    allow_task_change: bool = False,
) -> Results:
    """``ios_uav_env.benchmark.Results`` of ``policy`` on the first ``n`` scenarios of a
    single-node ``suite`` (a name or a file; default ``single-node-v1``); the policy runs in
    ``env_id`` with ``env_kwargs`` (default: its own ``env_id`` / ``env_kwargs`` attributes
    without its training draw, ``ios_uav_env.benchmark.overrides.policy_env_kwargs``, else the
    randomised id without arguments). Env arguments the suite pins are refused, and so are those
    that change its task unless ``allow_task_change`` (the results then name the changed task).
    A plan's time is its episode's, after an unscored warm-up episode (as the benchmark's)."""
    suite = _suite(suite)
    if suite.multi_node:
        raise ValueError(
            f"{suite.name} is a multi-node suite: score multi-node agents with agents.suite.multi"
        )
    env_id = env_id or getattr(policy, "env_id", RANDOM_ENV_ID)
    env_kwargs = policy_env_kwargs(suite, policy, env_kwargs)
    check_overrides(suite, env_kwargs, allow_task_change=allow_task_change)
    name = getattr(policy, "name", "policy")
    act, scenarios = fast_act(policy), suite.subset(n)
    if env_id not in ENV_IDS:  # the randomised id: every scenario at once, in its batched env
        return evaluate_scenarios(
            act, suite, scenarios, env_kwargs, 0, name, at_once=True, allow_task_change=allow_task_change
        )
    named = NamedPolicy(act, suite.name, name)  # a policy's error names the suite, scenario and policy
    if progress:
        from tqdm.auto import tqdm

        scenarios = tqdm(scenarios, desc="suite report", unit="scenario")
    metrics = metrics_of(suite)
    with ScenarioRunner(env_id, env_kwargs) as runner:
        if len(scenarios):  # warm-up, not scored: compilations and first calls stay out of the times
            runner.run(named.at(suite[0], warm_up=True), suite[0].config, seed=0)
        episodes = [(s, runner.run(named.at(s), s.config, seed=0)) for s in scenarios]
    rows = [ScenarioResult.of(s, metrics, score_plan(s.config, e.trajectory), e.seconds, e.trajectory)
            for s, e in episodes]  # fmt: skip
    return Results.of(suite, name, env_kwargs, rows, [s for s, _ in episodes])


def summarize(results: Results) -> dict[str, Any]:
    """Mean, 10th percentile and minimum % of DP; feasible count; SCA's % of DP on the same
    scenarios; median plan times and the speed-up over SCA."""
    a, by_index = results.aggregate, {s.index: s for s in load_benchmark(results.suite)}
    chosen = [by_index[r.index] for r in results]
    sca = [100.0 * s.sca_rate / s.dp_rate for s in chosen]
    policy_s = a.median_seconds
    return {
        "n": a.n,
        "mean_pct_dp": a.mean_pct_dp,
        "p10_pct_dp": a.p10_pct_dp,
        "min_pct_dp": a.min_pct_dp,
        "feasible": a.feasible,
        "sca_mean_pct_dp": float(np.mean(sca)),
        "sca_feasible": int(sum(bool(s.reference["sca"]["feasible"]) for s in chosen)),
        "median_seconds": policy_s,
        "sca_median_seconds": a.sca_median_seconds,
        "speedup": a.sca_median_seconds / policy_s if policy_s > 0 else math.inf,
        "task": results.task,  # the suite's name, or the changed task's (Results.task)
    }


def suite_score(
    model: Any, suite: Suite | str | Path | None = None, n: int | None = None, env_kwargs: dict | None = None
) -> dict[str, float]:
    """The suite score of ``model`` (an SB3 model, with its VecNormalize if any, or a policy):
    {"mean_pct_dp", "p10_pct_dp", "min_pct_dp", "feasible_frac", "n"} over the first ``n``
    scenarios (all for None). ``env_kwargs``: the training env's (e.g. the guard). For a
    training callback (log e.g. ``suite/mean_pct_dp``)."""
    a = evaluate_suite(as_policy(model, env_kwargs), suite, n).aggregate
    return {"mean_pct_dp": a.mean_pct_dp, "p10_pct_dp": a.p10_pct_dp, "min_pct_dp": a.min_pct_dp,
            "feasible_frac": a.feasible / a.n, "n": a.n}  # fmt: skip


def summary_text(s: dict[str, Any], name: str = "policy") -> str:
    """The summary of :func:`summarize` in a sentence (a changed task named after the count)."""
    task = f" of {s['task']}" if "[not " in str(s.get("task", "")) else ""
    return (
        f"{name} on {s['n']} held-out scenarios{task}: {s['mean_pct_dp']:.2f}% of DP on average, "
        f"10th percentile {s['p10_pct_dp']:.2f}%, minimum {s['min_pct_dp']:.2f}%; feasible "
        f"{s['feasible']}/{s['n']} (SCA: {s['sca_mean_pct_dp']:.2f}% of DP, "
        f"feasible {s['sca_feasible']}/{s['n']}); "
        f"median plan time {1e3 * s['median_seconds']:.1f} ms vs SCA {s['sca_median_seconds']:.2f} s "
        f"({s['speedup']:.0f}x faster)"
    )


def _figure(size: tuple[float, float]) -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, dpi=100)
    FigureCanvasAgg(fig)
    return fig


def save_trajectories_figure(results: Results, path: str | Path, name: str = "policy") -> Path:
    """2 x 3 small multiples: six scenarios from the worst to the best % of DP, the policy's plan
    against DP's and SCA's (from the held-out plan file, where it holds the scenario)."""
    from ios_uav_env.plotting import plot_rate_map, plot_trajectories

    plans = {e.config: e for e in load_plans(SUITE_PATH)} if SUITE_PATH.exists() else {}
    ranked = sorted(results.scenarios, key=lambda r: r.pct_dp)
    picks = sorted({round(q * (len(ranked) - 1)) for q in np.linspace(0, 1, 6)})
    fig = _figure((15, 6.4))
    for k, i in enumerate(picks):
        row = ranked[i]
        config = row.config
        ax = fig.add_subplot(2, 3, k + 1)
        plot_rate_map(ax, config, resolution=(120, 60), colorbar=False)
        lines = {name: row.trajectory}
        if config in plans:
            lines.update(DP=plans[config].dp["trajectory"], SCA=plans[config].sca["trajectory"])
        plot_trajectories(ax, config, lines, legend=k == 0, lw=1.2, ms=2)
        ax.set_title(f"#{row.index} {config.surface.upper()}, T={config.T:g} s, M={config.M}: "
                     f"{row.pct_dp:.1f}% of DP", fontsize=9)  # fmt: skip
    if results.task_changes:
        fig.suptitle(f"{name} on {results.task}", fontsize=10, color="tab:red")
    fig.tight_layout()
    return save_figure(fig, path)


def run_report(
    policy: Any,
    out: str | Path,
    n: int | None = None,
    progress: bool = True,
    suite: Suite | str | None = None,
    node_orders: bool = False,
    *,
    overwrite: bool = False,
    allow_task_change: bool = False,
) -> dict[str, Any]:
    """Evaluate, print the table and the summary, write the benchmark's files and the trajectory
    figure to ``out``. A multi-node agent is scored on the multi-node suite instead
    (:mod:`agents.suite.multi`; ``node_orders``: its action averaged over every order of the
    nodes); ``node_orders`` with a one-node agent is a ``ValueError``. Results already in ``out``
    (:data:`REPORT_FILES`) are refused before anything runs (``FileExistsError``) unless
    ``overwrite``: then the previous report's files this one does not write are removed.
    ``allow_task_change``: run env arguments of the policy that change the suite's task
    (``ios_uav_env.benchmark.overrides``), the outputs naming the changed task."""
    from agents.evaluate_multi import is_multinode

    out = Path(out)
    previous = claim(out, REPORT_FILES, overwrite)
    if is_multinode(policy):
        from agents.suite.multi import multi_report

        report = multi_report(policy, out, n, node_orders=node_orders, overwrite=overwrite,
                              allow_task_change=allow_task_change)  # fmt: skip
        remove_stale(previous, report["paths"].values())
        return report
    if node_orders:
        raise ValueError("node_orders: averaging over the orders of the nodes needs a multi-node agent")
    name = getattr(policy, "name", "policy")
    results = evaluate_suite(policy, suite, n, progress=progress, allow_task_change=allow_task_change)
    s = summarize(results)
    print(results.markdown())
    print(summary_text(s, name))
    paths = results.save(out, overwrite=overwrite)
    paths["trajectories_figure"] = save_trajectories_figure(results, out / "suite_trajectories.png", name)
    remove_stale(previous, paths.values())
    print("wrote " + ", ".join(str(p) for p in paths.values()))
    return {"summary": s, "results": results, "paths": paths}
