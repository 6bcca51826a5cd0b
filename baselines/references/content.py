"""What a frozen suite holds, from the pipeline's solved records: the suite content, its checks,
its plans, and the writer that never changes a suite under its name.

- :func:`single_node_content`: a single-node suite from a held-out plan file
  (``agents/suite/heldout.json``: each scenario's config, DP optimum and SCA plan), with the rates
  of ``HoverAt("peak")`` and ``HoverAt("ground")`` rolled out in the suite's env added;
- :func:`multinode_content`: a multi-node suite from the records of
  :func:`~baselines.references.solve.solve_all` (refused, naming the scenario, where one has no
  SCA rate, the normaliser, or no bound); :func:`check_record` lists every sanity note (a planner
  failed or infeasible, SCA below the tour, a value above the bound);
- :func:`freeze` writes ``<dir>/<name>.json`` (``ios_uav_env.benchmark.suite.suite_text``)
  atomically and refuses other content under an existing name; :func:`write_plans` writes the
  planners' plans as trajectory files that the benchmark scores like any other.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from baselines.references.draws import ENTROPY, MULTI_ENV_ID, SPAWN_KEY
from ios_uav_env import ScenarioConfig
from ios_uav_env.benchmark.suite import (
    FORMAT,
    MULTI_NODE,
    MULTI_REFERENCES,
    REFERENCES,
    SUITE_DIR,
    content_hash,
    suite_text,
)
from ios_uav_env.envs.registration import RANDOM_ENV_ID
from ios_uav_env.io import atomic_write_text

HEURISTICS = {"hover_peak": "peak", "hover_ground": "ground"}


def heuristic_reference(config: ScenarioConfig, target: str, env_id: str = RANDOM_ENV_ID) -> dict[str, Any]:
    """Rate and feasibility of ``HoverAt(target)`` on ``config`` (its env arguments, reset seed 0)."""
    import gymnasium as gym

    from ios_uav_env.envs.policies import HoverAt
    from ios_uav_env.envs.rollout import run_episode

    policy = HoverAt(target)
    env = gym.make(env_id, **policy.env_kwargs)
    try:
        episode = run_episode(env, policy, seed=0, options={"config": config})
    finally:
        env.close()
    return {"rate": episode.average_rate, "feasible": bool(episode.feasible)}


def single_node_content(heldout: Mapping[str, Any], name: str, version: int) -> dict[str, Any]:
    """The content of a single-node suite from a held-out suite file's parsed JSON."""
    scenarios = []
    for rec in heldout["scenarios"]:
        config = ScenarioConfig(**rec["config"])
        entry: dict[str, Any] = {
            "index": int(rec["index"]),
            "config": config.to_dict(),
            "dp": {"rate": float(rec["dp"]["rate"]), "resolution": float(rec["dp"]["resolution"])},
            "sca": {
                "rate": float(rec["sca"]["rate"]),
                "feasible": bool(rec["sca"]["feasible"]),
                "seconds": round(float(rec["sca"]["seconds"]), 3),
            },
        }
        for key, target in HEURISTICS.items():
            entry[key] = heuristic_reference(config, target)
        scenarios.append(entry)
    return {
        "format": FORMAT,
        "name": name,
        "version": int(version),
        "env_id": RANDOM_ENV_ID,
        "env_kwargs": {},
        "normalizer": "dp",
        "references": list(REFERENCES),
        "description": (
            f"{len(scenarios)} held-out scenarios of {RANDOM_ENV_ID} (sample_scenario(default_rng("
            f"{heldout['seed']}), ranges) drawn in turn; never a training seed). Per scenario: its "
            "ScenarioConfig; dp: the DP optimum's rate on a resolution-m grid (baselines.dp.solve); sca: "
            "the SCA plan's rate, feasibility and wall time in seconds (baselines.sca.solve, defaults, "
            "one of two worker processes on a 2-core machine); hover_peak / hover_ground: the rate and "
            "feasibility of ios_uav_env.envs.policies.HoverAt('peak') (env with peak_hint=True) / "
            "HoverAt('ground') in the env, reset with seed 0. Rates: eq. (9), bps/Hz."
        ),
        "source": {
            "seed": int(heldout["seed"]),
            "ranges": heldout["ranges"],
            "file": "agents/suite/heldout.json",
            "built": heldout.get("build", {}).get("created"),
        },
        "scenarios": scenarios,
    }


def freeze(content: Mapping[str, Any], directory: str | Path = SUITE_DIR) -> tuple[Path, str]:
    """Write ``content`` to ``<directory>/<name>.json`` (atomically); its path and hash.

    ``ValueError`` if a file of that name exists with different content.
    """
    path = Path(directory) / f"{content['name']}.json"
    digest = content_hash(content)
    if path.exists() and content_hash(json.loads(path.read_text(encoding="utf-8"))) != digest:
        raise ValueError(f"{path} exists with different content: a changed suite needs a new name")
    atomic_write_text(path, suite_text(content))
    return path, digest


def check_record(rec: Mapping[str, Any]) -> list[str]:
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
            "module": "ios_uav_env.benchmark.freeze_multi",  # as frozen: the suite file keeps its bytes
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
