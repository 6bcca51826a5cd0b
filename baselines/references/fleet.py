"""The several-UAV suite's draws, references and content (``multi-uav-v1``).

**Draws** (:func:`fleet_tasks`): ``n`` scenarios drawn in turn from
``default_rng(SeedSequence(entropy=seed, spawn_key=FLEET_SPAWN_KEY))``, a stream that no reset
seed and no other suite's draws reproduce. Each is ``sample_multinode(rng, FLEET_RANGES,
nodes=FLEET_NODES)`` (3 to 6 static nodes; the random id's ranges, IOS and RIS, with horizons of
:data:`FLEET_RANGES`), then U uniform in :data:`FLEET_UAVS`; the access alternates with the index
(even: orthogonal bands, odd: one shared band), so both are equally represented. The UAVs fly the
default lanes (``model.fleet.default_lanes``: the scenario's q0 -> qF moved 80 m in -y per UAV) at
the scenario's v_max, at least ``DEFAULT_SEPARATION`` apart. UAV 0 flies the scenario's T; each
other UAV has a horizon of its own, uniform over the whole slots in [:data:`HORIZON_SHARE` T, T]
(``model.fleet_horizons``: after it the UAV is gone).

**References** (:func:`solve_fleet`; every rate is ``fleet_suite.score_flights``, i.e.
``fleet_maxmin``, the one scorer of a fleet):

- ``planner``: ``baselines.fleet.solve`` (the normaliser; ``seconds`` its wall time, bound
  included; ``source``: the candidate that won);
- ``bound``: its certified upper bound (``fleet_bound``), above every fleet's value;
- ``tour``: the best tour cover before the pattern search polished it;
- ``dual``: the best of the bound's dual DP flights (separated ones, repaired by the guard where
  they met);
- ``straight``: every UAV straight along its lane at constant speed.

A reference that the planner did not produce (no separated dual flights) is recorded as rate 0,
``feasible`` false.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ios_uav_env import ScenarioConfig, ScenarioRanges, sample_multinode
from ios_uav_env.benchmark.fleet_suite import FLEET_FIELDS, fleet_configs, score_flights
from ios_uav_env.benchmark.suite_registry import BOUND_REL, FLEET_ENV_ID, FLEET_REFERENCES, FORMAT, MULTI_UAV
from ios_uav_env.model.fleet import ACCESS, default_lanes
from ios_uav_env.model.fleet_horizons import hold_flights, horizon_slots
from ios_uav_env.model.scenarios import MULTINODE_RANGES
from ios_uav_env.model.separation import DEFAULT_SEPARATION

__all__ = ["FLEET_RANGES", "FLEET_SIZE", "check_fleet_record", "fleet_content", "fleet_tasks", "solve_fleet"]

#: The several-UAV suite's spawn key (its entropy is ``draws.ENTROPY`` unless given) and size.
FLEET_SPAWN_KEY = (31,)
FLEET_SIZE = 40
#: The family: the multi-node family's ranges with horizons of 60 to 100 s.
FLEET_RANGES = dataclasses.replace(MULTINODE_RANGES, T=(60.0, 100.0))
FLEET_NODES = (3, 6)
#: The shortest horizon of a UAV after the first, as a share of the scenario's T (the first flies T).
HORIZON_SHARE = 0.75
FLEET_UAVS = (2, 3)
#: The planner's grids (m): the plain DP's and the relaxed DP's (the bound's) cells.
RESOLUTION = 5.0
BOUND_RESOLUTION = 5.0
#: The most flights the planner's pattern search scores per scenario (it otherwise chases gains of
#: 1e-6 for tens of minutes on a three-UAV shared band).
POLISH_BUDGET = 200
#: The rows that are plans (every reference but the bound).
PLANS = tuple(r for r in FLEET_REFERENCES if r != "bound")


def fleet_tasks(n: int, seed: int, ranges: ScenarioRanges = FLEET_RANGES) -> list[dict[str, Any]]:
    """The first ``n`` several-UAV tasks ``{"index", "config", "fleet"}`` (module docstring, "Draws")."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be an integer >= 1 (scenarios), got {n!r}")
    rng = np.random.default_rng(np.random.SeedSequence(entropy=int(seed), spawn_key=FLEET_SPAWN_KEY))
    tasks = []
    for i in range(int(n)):
        config = sample_multinode(rng, ranges, nodes=FLEET_NODES)
        uavs = int(rng.integers(FLEET_UAVS[0], FLEET_UAVS[1], endpoint=True))
        starts, finals = default_lanes(config, uavs)
        n_slots = round(config.T / config.dt)
        low = math.ceil(HORIZON_SHARE * n_slots)
        horizons = [config.T] + [
            float(rng.integers(low, n_slots, endpoint=True)) * config.dt for _ in range(uavs - 1)
        ]
        fleet = {"uavs": uavs, "starts": starts.tolist(), "finals": finals.tolist(), "speeds": None,
                 "access": ACCESS[i % 2], "min_separation": DEFAULT_SEPARATION,
                 "horizons": horizons}  # fmt: skip
        tasks.append({"index": i, "config": config.to_dict(), "fleet": fleet})
    return tasks


def straight_flights(config: ScenarioConfig, fleet: Mapping[str, Any]) -> np.ndarray:
    """(U, N, 2) m: every UAV from its start to its final point at constant speed over its own
    horizon, held there after it (``model.fleet_horizons.hold_flights``)."""
    s, f = np.asarray(fleet["starts"], dtype=float), np.asarray(fleet["finals"], dtype=float)
    slots = horizon_slots(fleet_configs(config, fleet))
    flights = [a + np.linspace(0.0, 1.0, n)[:, None] * (b - a) for a, b, n in zip(s, f, slots, strict=True)]
    return hold_flights(flights, config.N)


def solve_fleet(
    task: Mapping[str, Any],
    resolution: float = RESOLUTION,
    bound_resolution: float = BOUND_RESOLUTION,
    polish_budget: int = POLISH_BUDGET,
) -> dict[str, Any]:
    """The reference record of a several-UAV task (module docstring, "References");
    ``polish_budget``: the most flights the planner's pattern search scores (0: no search, for
    quick check suites)."""
    from baselines.fleet import solve

    config, fleet = ScenarioConfig(**task["config"]), dict(task["fleet"])
    record: dict[str, Any] = {"index": int(task["index"]), "config": config.to_dict(), "fleet": fleet}
    t0 = time.perf_counter()
    steps = {"polish_budget": polish_budget} if polish_budget else {"polish_steps": ()}
    plan = solve(config, **fleet, resolution=resolution, bound_resolution=bound_resolution, **steps)
    seconds = time.perf_counter() - t0
    rate, feasible, _ = score_flights(config, fleet, plan.trajectories)
    record["planner"] = {
        "rate": rate,
        "feasible": feasible,
        "seconds": seconds,
        "source": plan.info["source"],
    }
    record["bound"] = {"upper_bound": float(plan.upper_bound), "resolution": float(bound_resolution)}
    candidates = plan.info["candidates"]
    duals = [v for s, v in candidates.items() if s.startswith("dual-dp")]
    tour = plan.info["polished_from"]
    if tour is None:  # no polishing: the best tour cover is the best tour candidate
        tour = max((v for s, v in candidates.items() if s.startswith("tour")), default=None)
    for name, value in (("tour", tour), ("dual", max(duals, default=None))):
        record[name] = (
            {"rate": 0.0, "feasible": False} if value is None else {"rate": float(value), "feasible": True}
        )
    rate, feasible, _ = score_flights(config, fleet, straight_flights(config, fleet))
    record["straight"] = {"rate": rate, "feasible": feasible}
    return record


def fleet_key(
    task: Mapping[str, Any],
    resolution: float = RESOLUTION,
    bound_resolution: float = BOUND_RESOLUTION,
    polish_budget: int = POLISH_BUDGET,
) -> str:
    """A task's cache file stem: ``fleet_``, its index and a hash of its config, fleet and the
    planner's settings."""
    settings = [resolution, bound_resolution, int(polish_budget), "fleet:v1"]
    blob = json.dumps([task["config"], task["fleet"], *settings], sort_keys=True)
    return f"fleet_{int(task['index']):03d}_{hashlib.sha1(blob.encode()).hexdigest()[:16]}"


def describe(index: int, record: Mapping[str, Any]) -> str:
    """The progress bar's note on a finished task."""
    p, b = record["planner"], record["bound"]["upper_bound"]
    return f"#{index}: planner {p['rate']:.4f} / bound {b:.4f} bps/Hz in {p['seconds']:.0f} s"


def longest_first(task: Mapping[str, Any]) -> float:
    """The runner's order: the costliest tasks first (shared band, more UAVs, nodes and slots)."""
    f, c = task["fleet"], task["config"]
    return -(c["T"] * len(c["ground_nodes"]) * f["uavs"] * (3 if f["access"] == "shared" else 1))


def check_fleet_record(rec: Mapping[str, Any]) -> list[str]:
    """The sanity notes of one record: the planner infeasible, a plan above the bound, the planner
    below another row."""
    i, ub, notes = rec["index"], float(rec["bound"]["upper_bound"]), []
    if not rec["planner"]["feasible"]:
        notes.append(f"#{i}: the planner's flights are infeasible")
    for name in PLANS:
        if rec[name]["rate"] > ub * (1.0 + BOUND_REL):
            notes.append(f"#{i}: {name} {rec[name]['rate']:.9g} > bound {ub:.9g} bps/Hz")
        if rec[name]["rate"] > rec["planner"]["rate"] * (1.0 + BOUND_REL):
            notes.append(
                f"#{i}: {name} {rec[name]['rate']:.9g} > planner {rec['planner']['rate']:.9g} bps/Hz"
            )
    return notes


def fleet_content(
    records: Sequence[Mapping[str, Any]], name: str, version: int, *, seed: int, ranges: ScenarioRanges,
    settings: Mapping[str, float],
) -> dict[str, Any]:  # fmt: skip
    """The content of a several-UAV suite from the records of :func:`solve_fleet` (``ValueError``
    naming the scenario where :func:`check_fleet_record` has a note: ``load_suite`` would refuse
    a rate above the bound, and a row above the planner would not be a planner's reference)."""
    scenarios = []
    for rec in records:
        notes = check_fleet_record(rec)
        if notes:
            raise ValueError("; ".join(notes))
        config = ScenarioConfig(**rec["config"]).to_dict()
        fleet = {k: rec["fleet"][k] for k in FLEET_FIELDS}
        entry: dict[str, Any] = {"index": int(rec["index"]), "config": config, "fleet": fleet}
        p = rec["planner"]
        entry["planner"] = {"rate": float(p["rate"]), "feasible": bool(p["feasible"]),
                            "seconds": round(float(p["seconds"]), 3), "source": str(p["source"])}  # fmt: skip
        entry["bound"] = {k: float(v) for k, v in rec["bound"].items()}
        for r in PLANS[1:]:
            entry[r] = {"rate": float(rec[r]["rate"]), "feasible": bool(rec[r]["feasible"])}
        scenarios.append({k: entry[k] for k in ("index", "config", "fleet", *FLEET_REFERENCES)})
    return {
        "format": FORMAT,
        "name": name,
        "version": int(version),
        "kind": MULTI_UAV,
        "env_id": FLEET_ENV_ID,
        "env_kwargs": {"max_nodes": FLEET_NODES[1]},
        "normalizer": "planner",
        "references": list(FLEET_REFERENCES),
        "description": " ".join(
            (
                f"{len(scenarios)} held-out scenarios of {FLEET_NODES[0]} to {FLEET_NODES[1]} static",
                f"nodes flown by {FLEET_UAVS[0]} to {FLEET_UAVS[1]} UAVs: sample_multinode(rng, ranges,",
                "nodes) (the random id's ranges, IOS and RIS, horizons of 60 to 100 s), then U, drawn in",
                f"turn from default_rng(SeedSequence(entropy={int(seed)}, spawn_key={FLEET_SPAWN_KEY}));",
                "the access alternates (even index: orthogonal bands, odd: one shared band); the UAVs fly",
                f"the default lanes (80 m apart in y) at v_max, at least {DEFAULT_SEPARATION:g} m apart;",
                f"UAV 0 flies T, each other UAV a horizon of whole slots in [{HORIZON_SHARE:g} T, T].",
                "Values are the team's max-min rates (bps/Hz, ios_uav_env.model.fleet.fleet_maxmin of the",
                "U flights, the best time sharing of every slot), with feasibility (every flight eq. (10),",
                f"separated all along). planner: baselines.fleet.solve with {settings['resolution']:g} m",
                f"grids and a pattern search of at most {settings['polish_budget']} flights (the",
                "normaliser; seconds: its wall time, bound included, one process on a busy 2-core",
                "machine); bound: its certified upper bound (the relaxed DP's cells of",
                f"{settings['bound_resolution']:g} m); tour: its best tour cover before the polishing;",
                "dual: its best dual DP flights; straight: every UAV straight along its lane at constant",
                "speed.",
            )
        ),
        "source": {
            "entropy": int(seed),
            "spawn_key": list(FLEET_SPAWN_KEY),
            "sampler": "ios_uav_env.sample_multinode(rng, ranges, nodes=(3, 6)), then rng.integers(2, 3, "
            "endpoint=True) UAVs",
            "ranges": ranges.to_dict(),
        },
        "scenarios": scenarios,
    }
