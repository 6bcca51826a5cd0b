"""Solve a scenario's references, for any K, cached and resumable: the one solve of the pipeline.

One ground node (``config.K == 1``, the single-node suites): the DP optimum
(``baselines.dp.solve`` at ``dp_resolution`` m: rate, trajectory, seconds) and the paper's SCA
plan (``baselines.sca.solve``, its default multi-start: rate, feasibility, worst violation,
seconds, status, trajectory).

K > 1 nodes (the multi-node suites): the tour heuristic (``baselines.tour.solve``), SCA inside
BCD (``baselines.sca.solve``, ``baselines.sca_multi``), each with its trajectory and LP shares,
and the certified upper bound (``baselines.dp_bound.solve_multinode`` at ``bound_resolution``
m: ``upper_bound``, and the DP-bound plan's own rate). A planner that raises is recorded
(``feasible`` false, rate 0, the error) rather than dropped.

An energy scenario (one node, ``objective == "energy_efficiency"``, the energy suites): the
energy DP (``baselines.dp_energy.solve_ee`` at ``dp_resolution`` m), SCA-EE started from the DP
plan (``baselines.sca_energy.solve(config, init=dp_plan)``), the loiter and hover heuristics
(``baselines.loiter``) and the certified EE bound (``baselines.energy_bound.solve`` at
``energy_bound_resolution`` m, its reference the most efficient of those plans), each with
``energy_efficiency`` (bits/J), ``rate`` (bps/Hz), ``energy`` (J), ``feasible``, ``seconds``
and its trajectory. A plan that raises is recorded as above (EE 0); the DP and the bound are
the suite's normaliser and ceiling, so their failure fails the task.

Every rate is ``ios_uav_env.score_plan`` of the planner's trajectory (``Plan.mean_rate``).
:func:`solve_all` runs the tasks through ``baselines.runner.run_tasks`` (spawned workers or
Ray, a progress bar, one JSON record per scenario written atomically, resumable); the cache
file of a task is :func:`task_key`, which hashes the config and every planner setting.
"""

from __future__ import annotations

import functools
import hashlib
import json
import time
import traceback
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ios_uav_env import ScenarioConfig

#: Grid (m) of each single-node scenario's DP optimum.
DP_RESOLUTION = 2.5
#: Cell side (m) of the certified bound (the relaxed DP) and of the DP-bound plans' grid.
BOUND_RESOLUTION = 2.5
#: Fine cell side (m) of the certified energy-efficiency bound of an energy scenario.
ENERGY_BOUND_RESOLUTION = 5.0
#: The records' keys, by kind: a cached record without them is solved again.
REQUIRED = {
    "single-node": ("config", "dp", "sca"),
    "multi-node": ("tour", "sca", "bound"),
    "energy": ("config", "dp", "sca", "bound", "loiter", "hover"),
    "mobile": ("config", "seed", "bound", "clairvoyant", "mpc_k1", "mpc_k10", "plan_once", "track_exact",
               "track_reports"),
}  # fmt: skip


def _plan_record(plan: Any) -> dict[str, Any]:
    return {
        "rate": float(plan.mean_rate),
        "feasible": bool(plan.feasible),
        "seconds": float(plan.seconds),
        "trajectory": np.asarray(plan.trajectory, dtype=float).tolist(),
        "shares": plan.info.get("shares"),
    }


def _failed(err: BaseException, seconds: float) -> dict[str, Any]:
    return {"rate": 0.0, "feasible": False, "seconds": seconds, "trajectory": None, "shares": None,
            "error": "".join(traceback.format_exception_only(err)).strip()}  # fmt: skip


def _single(config: ScenarioConfig, dp_resolution: float) -> dict[str, Any]:
    from baselines import dp, sca

    dp_plan = dp.solve(config, resolution=dp_resolution)
    with warnings.catch_warnings():  # an SCA start that stopped early is recorded in "status"
        warnings.simplefilter("ignore", RuntimeWarning)
        sca_plan = sca.solve(config)
    return {
        "config": config.to_dict(),
        "dp": {"rate": dp_plan.mean_rate, "seconds": dp_plan.seconds, "resolution": float(dp_resolution),
               "feasible": dp_plan.feasible, "trajectory": dp_plan.trajectory.tolist()},
        "sca": {"rate": sca_plan.mean_rate, "feasible": sca_plan.feasible,
                "worst_violation": sca_plan.report.worst_violation, "seconds": sca_plan.seconds,
                "status": sca_plan.info.get("status", "ok"), "start": sca_plan.info.get("start"),
                "trajectory": sca_plan.trajectory.tolist()},
    }  # fmt: skip


def _multi(config: ScenarioConfig, bound_resolution: float) -> dict[str, Any]:
    from baselines import sca, tour
    from baselines.dp_bound import solve_multinode

    record: dict[str, Any] = {"config": config.to_dict()}
    for name, solve in (("tour", tour.solve), ("sca", sca.solve)):
        t0 = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", RuntimeWarning)
            try:
                plan = solve(config)
                record[name] = _plan_record(plan)
                if name == "sca":
                    record[name]["status"] = plan.info.get("status")
            except Exception as err:  # recorded, never dropped
                record[name] = _failed(err, time.perf_counter() - t0)
        record[name]["warnings"] = [str(w.message) for w in caught]
    t0 = time.perf_counter()
    try:
        plan = solve_multinode(config, resolution=bound_resolution, bound_resolution=bound_resolution)
        record["bound"] = {
            "upper_bound": float(plan.info["upper_bound"]),
            "resolution": float(plan.info["bound_resolution"]),
            "plan_rate": float(plan.mean_rate),
            "plan_feasible": bool(plan.feasible),
            "plan_source": plan.info.get("plan_source"),
            "seconds": float(plan.seconds),
        }
    except Exception as err:
        record["bound"] = {"upper_bound": None, "resolution": float(bound_resolution),
                           "error": "".join(traceback.format_exception_only(err)).strip(),
                           "seconds": time.perf_counter() - t0}  # fmt: skip
    return record


def _energy_plan(plan: Any) -> dict[str, Any]:
    return {
        "energy_efficiency": float(plan.energy_efficiency),
        "rate": float(plan.mean_rate),
        "energy": float(plan.energy),
        "feasible": bool(plan.feasible),
        "seconds": float(plan.seconds),
        "trajectory": np.asarray(plan.trajectory, dtype=float).tolist(),
    }


def _energy(config: ScenarioConfig, dp_resolution: float, bound_resolution: float) -> dict[str, Any]:
    from baselines import dp_energy, energy_bound, loiter, sca_energy

    dp_plan = dp_energy.solve_ee(config, resolution=dp_resolution)
    record: dict[str, Any] = {"config": config.to_dict(), "dp": _energy_plan(dp_plan)}
    record["dp"].update(resolution=float(dp_resolution), ee_gap=dp_plan.info.get("ee_gap"))
    plans = [dp_plan]
    solvers = (
        ("sca", lambda: sca_energy.solve(config, init=dp_plan)),
        ("loiter", lambda: loiter.loiter(config)),
        ("hover", lambda: loiter.hover(config)),
    )
    for name, solve in solvers:
        t0 = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", RuntimeWarning)
            try:
                plan = solve()
                record[name] = _energy_plan(plan)
                plans.append(plan)
                if name == "sca":
                    record[name]["status"] = plan.info.get("status")
            except Exception as err:  # recorded, never dropped
                record[name] = {**_failed(err, time.perf_counter() - t0), "energy_efficiency": 0.0}
        record[name]["warnings"] = [str(w.message) for w in caught]
    best = max((p for p in plans if p.feasible), key=lambda p: p.energy_efficiency)
    bound = energy_bound.solve(config, resolution=bound_resolution, reference=best)
    record["bound"] = {
        "upper_bound": float(bound.upper_bound),
        "resolution": float(bound.resolution),
        "plain_bound": float(bound.plain_bound),
        "reference": best.scheme,
        "seconds": float(bound.seconds),
    }
    return record


def is_energy(config: ScenarioConfig) -> bool:
    """An energy scenario (one node, the objective ``"energy_efficiency"``): an energy suite's."""
    return config.K == 1 and config.objective == "energy_efficiency"


def solve_scenario(
    task: Mapping[str, Any],
    *,
    dp_resolution: float = DP_RESOLUTION,
    bound_resolution: float = BOUND_RESOLUTION,
    energy_bound_resolution: float = ENERGY_BOUND_RESOLUTION,
) -> dict[str, Any]:
    """The reference record of one task ``{"index", "config"}`` (a config dict; a mobile task
    also its episode ``"seed"``), by its K, objective and motion (module docstring)."""
    from baselines.references.mobile import is_mobile, solve_mobile

    config = ScenarioConfig(**task["config"])
    if is_mobile(config):
        record = solve_mobile(config, int(task["seed"]), bound_resolution)
    elif is_energy(config):
        record = _energy(config, dp_resolution, energy_bound_resolution)
    elif config.K == 1:
        record = _single(config, dp_resolution)
    else:
        record = _multi(config, bound_resolution)
    return {"index": int(task["index"]), **record}


def task_key(
    task: Mapping[str, Any],
    *,
    dp_resolution: float = DP_RESOLUTION,
    bound_resolution: float = BOUND_RESOLUTION,
    energy_bound_resolution: float = ENERGY_BOUND_RESOLUTION,
) -> str:
    """The cache file stem of a task: a hash of its config and its kind's planner settings (one
    node: DP's grid and SCA's defaults; K > 1: the bound's grid, and the scenario's index first;
    an energy scenario: ``energy_`` first, the DP's grid and the EE bound's; a mobile one:
    ``mobile_`` first, its episode seed and the bound's grid)."""
    from baselines.references.mobile import is_mobile

    config = ScenarioConfig(**task["config"])
    if is_mobile(config):
        blob = json.dumps(
            [config.to_dict(), int(task["seed"]), bound_resolution, "mobile:v1"], sort_keys=True
        )
        return f"mobile_{hashlib.sha1(blob.encode()).hexdigest()[:16]}"
    if is_energy(config):
        blob = json.dumps(
            [config.to_dict(), dp_resolution, energy_bound_resolution, "energy:v1"], sort_keys=True
        )
        return f"energy_{hashlib.sha1(blob.encode()).hexdigest()[:16]}"
    if config.K == 1:
        blob = json.dumps([config.to_dict(), dp_resolution, "sca:defaults"], sort_keys=True)
        return hashlib.sha1(blob.encode()).hexdigest()[:16]
    blob = json.dumps([task["config"], bound_resolution, "v1"], sort_keys=True)
    return f"scenario{int(task['index']):02d}_{hashlib.sha1(blob.encode()).hexdigest()[:10]}"


def tasks_of(configs: Sequence[ScenarioConfig], seeds: Sequence[int] | None = None) -> list[dict[str, Any]]:
    """The tasks of ``configs``: ``{"index": i, "config": config.to_dict()}`` (and ``"seed"``: the
    episode seeds of mobile scenarios)."""
    tasks = [{"index": i, "config": c.to_dict()} for i, c in enumerate(configs)]
    for task, seed in zip(tasks, seeds or [], strict=False):
        task["seed"] = int(seed)
    return tasks


def _describe(i: int, rec: dict[str, Any]) -> str:
    if "mpc_k1" in rec:
        ub = rec["bound"]["upper_bound"]
        mpc, track = (100 * rec[r]["rate"] / ub for r in ("mpc_k1", "track_reports"))
        return f"#{i}: MPC(k=1) {mpc:.2f}% of bound, tracking the reports {track:.2f}%"
    if "loiter" in rec:
        dp, ub = rec["dp"]["energy_efficiency"], rec["bound"]["upper_bound"]
        sca = 100 * rec["sca"]["energy_efficiency"] / dp
        return f"#{i}: DP-EE {dp:.1f} bits/J ({100 * dp / ub:.2f}% of bound), SCA-EE {sca:.2f}% of DP"
    if "dp" in rec:
        return f"#{i}: SCA {100 * rec['sca']['rate'] / rec['dp']['rate']:.2f}% of DP"
    ub = rec["bound"].get("upper_bound")
    return f"#{i} K={len(rec['config'].get('ground_nodes') or [0])} tour {rec['tour']['rate']:.4f} " + (
        f"sca {rec['sca']['rate']:.4f} bound {ub:.4f}" if ub is not None else "bound failed"
    )


def solve_all(
    configs: Sequence[ScenarioConfig],
    cache_dir: str | Path,
    *,
    dp_resolution: float = DP_RESOLUTION,
    bound_resolution: float = BOUND_RESOLUTION,
    energy_bound_resolution: float = ENERGY_BOUND_RESOLUTION,
    jobs: int = 2,
    progress: bool = True,
    backend: str = "local",
    address: str | None = None,
    desc: str = "references",
    seeds: Sequence[int] | None = None,
) -> list[dict[str, Any]]:
    """Each scenario's :func:`solve_scenario` record, from the cache or solved (the longest
    horizon first, over ``jobs`` spawned processes, in this one for ``jobs=1``; ``backend="ray"``:
    Ray tasks on the cluster at ``address``), each cached atomically as soon as it is solved.
    ``seeds``: the episode seeds of mobile scenarios, one per config."""
    from baselines.references.mobile import is_mobile
    from baselines.runner import run_tasks

    def kind(c: ScenarioConfig) -> str:
        return (
            "mobile"
            if is_mobile(c)
            else "energy"
            if is_energy(c)
            else "single-node"
            if c.K == 1
            else "multi-node"
        )

    kinds = {kind(c) for c in configs}
    settings = {"dp_resolution": dp_resolution, "bound_resolution": bound_resolution,
                "energy_bound_resolution": energy_bound_resolution}  # fmt: skip
    required = sorted({k for kind in kinds for k in REQUIRED[kind]})
    return run_tasks(
        functools.partial(solve_scenario, **settings), tasks_of(configs, seeds), cache_dir,
        key=functools.partial(task_key, **settings), jobs=jobs, backend=backend, address=address,
        order=lambda task: -ScenarioConfig(**task["config"]).N, progress=progress, desc=desc,
        unit="scenario", describe=_describe, required=required,
    )  # fmt: skip
