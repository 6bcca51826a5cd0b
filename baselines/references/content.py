"""What a frozen suite holds, from the pipeline's solved records: the suite content, its checks,
its plans, and the writer that never changes a suite under its name.

- :func:`single_node_content`: a single-node suite from a held-out plan file
  (``agents/suite/heldout.json``: each scenario's config, DP optimum and SCA plan), with the rates
  of ``HoverAt("peak")`` and ``HoverAt("ground")`` rolled out in the suite's env added;
- :func:`multinode_content`: a multi-node suite from the records of
  :func:`~baselines.references.solve.solve_all` (refused, naming the scenario, where one has no
  SCA rate, the normaliser, or no bound); :func:`check_record` lists every sanity note (a planner
  failed or infeasible, SCA below the tour, a value above the bound);
- :func:`energy_content`: an energy suite from the records of an energy draw (refused, naming
  the scenario, where a reference's EE is not > 0 or exceeds the bound); :func:`check_energy_record`
  lists its sanity notes (a plan failed or infeasible, SCA-EE below its DP start, a value above
  the bound);
- :func:`freeze` writes ``<dir>/<name>.json`` (``ios_uav_env.benchmark.suite_registry.suite_text``)
  atomically and refuses other content under an existing file or a registered name;
  :func:`write_plans` writes the planners' plans as trajectory files that the benchmark scores
  like any other.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from baselines.references.draws import ENERGY_RANGES, ENERGY_SPAWN_KEY, ENTROPY, MULTI_ENV_ID, SPAWN_KEY
from ios_uav_env import ENERGY_RANDOM_ID, MULTINODE_RANGES, RANDOM_ENV_ID, ScenarioConfig, ScenarioRanges
from ios_uav_env.benchmark.heuristics import hover_episode
from ios_uav_env.benchmark.suite_registry import (
    BOUND_REL,
    ENERGY,
    ENERGY_REFERENCES,
    FORMAT,
    MULTI_NODE,
    MULTI_REFERENCES,
    REFERENCES,
    SUITE_DIR,
    SUITES,
    content_hash,
    suite_text,
)
from ios_uav_env.io import atomic_write_text

HEURISTICS = {"hover_peak": "peak", "hover_ground": "ground"}


def heuristic_reference(config: ScenarioConfig, target: str, env_id: str = RANDOM_ENV_ID) -> dict[str, Any]:
    """Rate and feasibility of ``HoverAt(target)`` on ``config`` in ``env_id``'s env (with the
    policy's env arguments, reset seed 0: ``ios_uav_env.benchmark.heuristics.hover_episode``)."""
    episode = hover_episode(config, target, env_id=env_id, seed=0)
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

    ``ValueError`` if a file of that name exists with different content, or if the name is a
    registered suite's (``ios_uav_env.benchmark.suite_registry.SUITES``) and the content is not its.
    """
    path = Path(directory) / f"{content['name']}.json"
    digest = content_hash(content)
    registered = SUITES.get(str(content["name"]))
    if registered is not None and registered.sha256 != digest:
        raise ValueError(
            f"{content['name']!r} is a registered suite (sha256 {registered.sha256}): other content "
            "needs a new name"
        )
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
            "sampler": "ios_uav_env.envs.multi.sample_multinode",  # as frozen (ios_uav_env.sample_multinode)
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


#: The plan references of an energy suite, and their stored fields.
ENERGY_PLANS = tuple(r for r in ENERGY_REFERENCES if r != "bound")
_PLAN_FIELDS = ("energy_efficiency", "rate", "energy", "feasible")


def check_energy_record(rec: Mapping[str, Any]) -> list[str]:
    """The sanity notes of one energy record: a plan failed or infeasible, SCA-EE below the DP plan
    it starts from, a plan's EE above the bound."""
    i, notes = rec["index"], []
    ub = float(rec["bound"]["upper_bound"])
    for name in ENERGY_PLANS:
        if "error" in rec[name] or not rec[name]["feasible"]:
            notes.append(f"#{i}: {name} failed or infeasible ({rec[name].get('error', 'infeasible')})")
        elif rec[name]["energy_efficiency"] > ub * (1.0 + BOUND_REL):
            notes.append(f"#{i}: {name} {rec[name]['energy_efficiency']:.9g} > bound {ub:.9g} bits/J")
    if rec["sca"]["energy_efficiency"] < rec["dp"]["energy_efficiency"] * (1.0 - 1e-12):
        notes.append(f"#{i}: SCA-EE {rec['sca']['energy_efficiency']:.6g} < its DP-EE start "
                     f"{rec['dp']['energy_efficiency']:.6g} bits/J")  # fmt: skip
    return notes


def energy_content(
    records: Sequence[Mapping[str, Any]],
    name: str,
    version: int,
    *,
    seed: int = ENTROPY,
    ranges: ScenarioRanges = ENERGY_RANGES,
) -> dict[str, Any]:
    """The content of an energy suite from the records of ``solve_all`` on ``energy_configs(n,
    seed, ranges)`` (``ValueError`` naming the scenario where a reference's EE is not > 0 or a
    plan's exceeds the bound: :func:`~ios_uav_env.benchmark.suite.load_suite` would refuse it)."""
    scenarios = []
    for rec in records:
        i = int(rec["index"])
        ub = rec["bound"].get("upper_bound")
        values = {r: rec[r].get("energy_efficiency") for r in ENERGY_PLANS}
        bad = [f"{r} {v!r}" for r, v in {**values, "bound": ub}.items() if not (v is not None and v > 0)]
        if bad:
            raise ValueError(f"scenario {i}: every reference's EE must be > 0 bits/J, got {', '.join(bad)}")
        above = [f"{r} {v!r}" for r, v in values.items() if v > ub * (1.0 + BOUND_REL)]
        if above:
            raise ValueError(f"scenario {i}: the bound {ub!r} bits/J is below {', '.join(above)}")
        entry: dict[str, Any] = {"index": i, "config": ScenarioConfig(**rec["config"]).to_dict()}
        for r in ENERGY_PLANS:
            entry[r] = {k: (bool(rec[r][k]) if k == "feasible" else float(rec[r][k])) for k in _PLAN_FIELDS}
            entry[r]["seconds"] = round(float(rec[r]["seconds"]), 3)
        entry["dp"]["resolution"] = float(rec["dp"]["resolution"])
        b = rec["bound"]
        entry["bound"] = {"upper_bound": float(ub), "resolution": float(b["resolution"]),
                          "seconds": round(float(b["seconds"]), 3)}  # fmt: skip
        scenarios.append({k: entry[k] for k in ("index", "config", *ENERGY_REFERENCES)})
    return {
        "format": FORMAT,
        "name": name,
        "version": int(version),
        "kind": ENERGY,
        "env_id": ENERGY_RANDOM_ID,
        "env_kwargs": {},
        "normalizer": "dp",
        "references": list(ENERGY_REFERENCES),
        "description": (
            f"{len(scenarios)} held-out scenarios of {ENERGY_RANDOM_ID}: sample_scenario(rng, ranges) (the "
            f"random id's ranges, IOS and RIS, objective energy_efficiency) drawn in turn from default_rng("
            f"SeedSequence(entropy={int(seed)}, spawn_key={ENERGY_SPAWN_KEY})), a stream no reset seed "
            "reproduces. Per scenario: its ScenarioConfig; values are energy efficiencies EE = B T R / E "
            "(bits/J, ios_uav_env.score_plan(...).energy_efficiency of the planner's trajectory), each "
            "with the plan's rate (bps/Hz, eq. (9)), energy (J), feasibility and wall time in seconds (one "
            "process on a busy 2-core machine). dp: baselines.dp_energy.solve_ee on a resolution-m grid, "
            "the normaliser; sca: baselines.sca_energy.solve started from the dp plan; loiter / hover: "
            "baselines.loiter.loiter / hover; bound: baselines.energy_bound.solve at resolution m with "
            "the best of those plans as its reference, the certified upper_bound on the EE of every "
            "feasible plan."
        ),
        "source": {
            "entropy": int(seed),
            "spawn_key": list(ENERGY_SPAWN_KEY),
            "sampler": "ios_uav_env.sample_scenario",
            "ranges": ranges.to_dict(),
        },
        "scenarios": scenarios,
    }
