"""Freeze the multi-node suite: held-out scenarios, the planners' reference values, the suite file.

    python -m ios_uav_env.benchmark.freeze_multi [--name multi-node-v1] [--n 48] [--cache out/multi-node-v1]

The scenarios are :func:`scenarios`: ``n`` draws in turn of
``ios_uav_env.envs.multi.sample_multinode(rng)`` (the distribution of
``ios_uav_env/IOSUAV-MultiNode-Random-v0``: 2 to 4 nodes, ``MULTINODE_RANGES``) from the
held-out generator ``np.random.default_rng(np.random.SeedSequence(entropy=20261130,
spawn_key=(17,)))``. A spawned key gives a stream independent of every
``default_rng(seed)`` / ``env.reset(seed=seed)`` stream (those have an empty spawn key), so no
training seed reproduces these scenarios.

Per scenario (:func:`solve_scenario`, planners imported here only, from a checkout):

- ``tour``: ``baselines.tour.solve``; ``sca``: ``baselines.sca.solve`` (K > 1: BCD,
  ``baselines.sca_multi``, defaults); ``bound``: ``baselines.dp_bound.solve_multinode`` at
  :data:`BOUND_RESOLUTION` (``info["upper_bound"]``, and the DP-bound plan's own rate).

Every rate is ``ios_uav_env.maxmin_rate`` of the plan's trajectory (``Plan.mean_rate``).
A planner that raises is recorded (``feasible`` false, rate 0, the error) rather than
dropped; the freeze prints every sanity note (a planner failed or infeasible, SCA below the
tour, a value above the bound) and refuses to write a suite in which a scenario has no SCA
rate (the normaliser) or no bound, naming it. Each scenario's record (trajectories and shares
included) is cached as one JSON file in ``--cache`` (``baselines.runner.run_tasks`` in this
process: atomic writes, resumable); the suite file keeps the values only, and ``--plans``
writes the tour's and SCA's plans as trajectory files (with their shares) that the benchmark
scores like any other.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import time
import traceback
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ios_uav_env.model.config import ScenarioConfig

#: The held-out generator's seed sequence: entropy and spawn key (documented in the suite).
ENTROPY = 2026_1130
SPAWN_KEY = (17,)
#: Cell side (m) of the certified bound (the relaxed DP) and of the DP-bound plans' grid.
BOUND_RESOLUTION = 2.5
MULTI_ENV_ID = "ios_uav_env/IOSUAV-MultiNode-Random-v0"
MULTI_REFERENCES = ("sca", "tour", "bound")
DEFAULT_CACHE = Path("out/multi-node-v1")


def heldout_rng() -> np.random.Generator:
    """The multi-node suite's held-out generator (a fresh one at every call)."""
    return np.random.default_rng(np.random.SeedSequence(entropy=ENTROPY, spawn_key=SPAWN_KEY))


def scenarios(n: int = 48) -> list[ScenarioConfig]:
    """The first ``n`` held-out scenarios: ``sample_multinode`` drawn in turn from :func:`heldout_rng`."""
    from ios_uav_env.envs.multi import sample_multinode

    rng = heldout_rng()
    return [sample_multinode(rng) for _ in range(int(n))]


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


def solve_scenario(task: Mapping[str, Any], bound_resolution: float = BOUND_RESOLUTION) -> dict[str, Any]:
    """The tour, SCA and bound record of one task ``{"index", "config"}`` (planners imported here)."""
    from baselines import sca, tour
    from baselines.dp_bound import solve_multinode

    config = ScenarioConfig(**task["config"])
    record: dict[str, Any] = {"index": int(task["index"]), "config": dict(task["config"])}
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


def task_key(task: Mapping[str, Any], bound_resolution: float = BOUND_RESOLUTION) -> str:
    """The cache file name of a task: its index and a hash of its config and the settings."""
    blob = json.dumps([task["config"], bound_resolution, "v1"], sort_keys=True)
    return f"scenario{int(task['index']):02d}_{hashlib.sha1(blob.encode()).hexdigest()[:10]}"


def compute(n: int = 48, cache: str | Path = DEFAULT_CACHE, *, progress: bool = True) -> list[dict[str, Any]]:
    """Every scenario's record, from ``cache`` or computed (in this process) and cached."""
    import functools

    from baselines.runner import run_tasks

    tasks = [{"index": i, "config": c.to_dict()} for i, c in enumerate(scenarios(n))]

    def describe(i: int, rec: dict[str, Any]) -> str:
        ub = rec["bound"].get("upper_bound")
        return f"#{i} K={len(rec['config'].get('ground_nodes') or [0])} tour {rec['tour']['rate']:.4f} " + (
            f"sca {rec['sca']['rate']:.4f} bound {ub:.4f}" if ub is not None else "bound failed"
        )

    fn = functools.partial(solve_scenario, bound_resolution=BOUND_RESOLUTION)
    key = functools.partial(task_key, bound_resolution=BOUND_RESOLUTION)
    return run_tasks(fn, tasks, cache, key=key, jobs=1, progress=progress, desc="multi-node-v1",
                     unit="scenario", describe=describe, required=("tour", "sca", "bound"))  # fmt: skip


def _check(rec: Mapping[str, Any]) -> list[str]:
    """The sanity notes of one record: SCA below the tour, a value above the bound, a failure."""
    i, notes = rec["index"], []
    ub = rec["bound"].get("upper_bound")
    for name in ("tour", "sca"):
        if "error" in rec[name] or not rec[name]["feasible"]:
            notes.append(f"#{i}: {name} failed or infeasible ({rec[name].get('error', 'infeasible')})")
    if ub is None:
        notes.append(f"#{i}: the bound failed ({rec['bound'].get('error')})")
    else:
        for name, rate in (("tour", rec["tour"]["rate"]), ("sca", rec["sca"]["rate"]),
                           ("dp-bound plan", rec["bound"]["plan_rate"])):  # fmt: skip
            if rate > ub + 1e-9:
                notes.append(f"#{i}: {name} {rate:.9f} > bound {ub:.9f}")
    if rec["sca"]["rate"] < rec["tour"]["rate"] - 1e-12:
        notes.append(f"#{i}: SCA {rec['sca']['rate']:.6f} < tour {rec['tour']['rate']:.6f}")
    return notes


def multinode_content(records: Sequence[Mapping[str, Any]], name: str, version: int) -> dict[str, Any]:
    """The content of a multi-node suite from the per-scenario records of :func:`compute`."""
    from ios_uav_env.benchmark.suite import FORMAT, MULTI_NODE
    from ios_uav_env.envs.multi import MULTINODE_RANGES

    bad = [f"#{r['index']}: {k}" for r in records for k in ("sca", "bound")
           if (r[k].get("rate") if k == "sca" else r[k].get("upper_bound")) in (None, 0.0)]  # fmt: skip
    if bad:
        raise ValueError(f"no normaliser (SCA rate) or bound for {bad}: such a scenario cannot be scored")
    scenarios = []
    for rec in records:
        entry: dict[str, Any] = {
            "index": int(rec["index"]),
            "config": ScenarioConfig(**rec["config"]).to_dict(),
        }
        for key in ("sca", "tour"):
            entry[key] = {"rate": float(rec[key]["rate"]), "feasible": bool(rec[key]["feasible"]),
                          "seconds": round(float(rec[key]["seconds"]), 3)}  # fmt: skip
            if "error" in rec[key]:
                entry[key]["error"] = rec[key]["error"]
        b = rec["bound"]
        entry["bound"] = {"upper_bound": float(b["upper_bound"]), "resolution": float(b["resolution"]),
                          "plan_rate": float(b["plan_rate"]), "plan_feasible": bool(b["plan_feasible"]),
                          "seconds": round(float(b["seconds"]), 3)}  # fmt: skip
        scenarios.append(entry)
    return {
        "format": FORMAT,
        "name": name,
        "version": int(version),
        "kind": MULTI_NODE,
        "env_id": MULTI_ENV_ID,
        "env_kwargs": {},
        "normalizer": "sca",
        "references": list(MULTI_REFERENCES),
        "description": (
            f"{len(scenarios)} held-out scenarios of {MULTI_ENV_ID}: sample_multinode(rng) (2 to 4 nodes, "
            f"MULTINODE_RANGES) drawn in turn from default_rng(SeedSequence(entropy={ENTROPY}, spawn_key="
            f"{SPAWN_KEY})), a stream no reset seed reproduces. Per scenario: its ScenarioConfig; rates are "
            "max-min rates (ios_uav_env.maxmin_rate, bps/Hz) of the planner's trajectory; sca: "
            "baselines.sca.solve (BCD, baselines.sca_multi, defaults): rate, feasibility, wall time in "
            "seconds (one process on a busy 2-core machine); tour: baselines.tour.solve, the same; bound: "
            "baselines.dp_bound.solve_multinode at resolution m: the certified upper_bound of every feasible "
            "plan, the DP-bound plan's own plan_rate, its seconds."
        ),
        "source": {
            "entropy": ENTROPY,
            "spawn_key": list(SPAWN_KEY),
            "sampler": "ios_uav_env.envs.multi.sample_multinode",
            "nodes": [2, 4],
            "ranges": MULTINODE_RANGES.to_dict(),
            "module": "ios_uav_env.benchmark.freeze_multi",
        },
        "scenarios": scenarios,
    }


def write_plans(records: Sequence[Mapping[str, Any]], directory: str | Path) -> list[Path]:
    """The tour's and SCA's plans (trajectories, shares, seconds) as ``<dir>/{tour,sca}.npz``."""
    from ios_uav_env.benchmark.trajectories import write_trajectories

    paths = []
    for name in ("tour", "sca"):
        done = [r for r in records if r[name].get("trajectory") is not None]
        paths.append(write_trajectories(
            Path(directory) / f"{name}.npz",
            {r["index"]: np.asarray(r[name]["trajectory"]) for r in done},
            {r["index"]: round(float(r[name]["seconds"]), 3) for r in done},
            {r["index"]: np.asarray(r[name]["shares"]) for r in done},
            compressed=True,
        ))  # fmt: skip
    return paths


def main(argv: Sequence[str] | None = None) -> int:
    from ios_uav_env.benchmark.freeze import freeze
    from ios_uav_env.benchmark.suite import SUITE_DIR

    p = argparse.ArgumentParser(
        prog="python -m ios_uav_env.benchmark.freeze_multi", description=__doc__.splitlines()[0]
    )
    p.add_argument("--name", default="multi-node-v1")
    p.add_argument("--version", type=int, default=1)
    p.add_argument("--n", type=int, default=48)
    p.add_argument(
        "--cache", type=Path, default=DEFAULT_CACHE, help=f"per-scenario records (default {DEFAULT_CACHE})"
    )
    p.add_argument("--dir", type=Path, default=SUITE_DIR, help="folder of the suite file")
    p.add_argument("--plans", type=Path, default=None, help="also write the tour's and SCA's plans here")
    p.add_argument("--compute-only", action="store_true", help="fill the cache, write no suite")
    args = p.parse_args(argv)
    records = compute(args.n, args.cache)
    notes = [n for r in records for n in _check(r)]
    print("\n".join(notes) if notes else "checks: SCA >= tour and every value <= bound on every scenario")
    if args.compute_only:
        return 0
    path, digest = freeze(multinode_content(records, args.name, args.version), args.dir)
    print(f"{path} ({path.stat().st_size / 1024:.0f} KB), sha256 {digest}")
    if args.plans is not None:
        print("plans: " + ", ".join(str(p) for p in write_plans(records, args.plans)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
