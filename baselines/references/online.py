"""The online suites normalised by the clairvoyant optimum: ``mobile-v2`` (one walking node) and
``multi-node-mobile-v1`` (2 to 4 walking nodes), their draws, references, checks and content.

**Draws.** ``mobile-v2``: the tasks of ``mobile-v1`` (:func:`~baselines.references.mobile.mobile_tasks`
at the same entropy: the same 40 scenarios and episode seeds, so the rows of both suites compare).
``multi-node-mobile-v1`` (:func:`multi_mobile_tasks`): ``n`` draws in turn of
``sample_multinode(rng, MULTI_MOBILE_RANGES)`` (2 to 4 nodes, the multi-node random id's ranges with
every node on a pedestrian Gauss-Markov path: the family of ``ios_uav_env/IOSUAV-MultiNode-Mobile-v0``),
each followed by its episode seed ``rng.integers(2**31)``, from ``default_rng(SeedSequence(entropy=seed,
spawn_key=MULTI_MOBILE_SPAWN_KEY))``: a spawned key of its own, so neither a reset seed nor another
suite's draws reproduce it. The episode seed fixes the nodes' true paths and the reports' noise, in
the env (``reset(seed=...)`` on the pinned scenario) as in ``baselines.mpc.run_online``.

**References** (:func:`solve_online`; every rate is ``score_plan(config, q, shares, paths=...)`` on the
true paths ``node_paths(config, default_rng(seed))``, with the plan's own shares):

- ``optimum``: the clairvoyant DP, ``baselines.dp_moving.solve`` (planner ``dp-clairvoyant``) at
  ``dp_resolution`` m: one node, the grid optimum refined by ``dp_refine`` corridor levels
  (:data:`DP_REFINE`); K > 1, the best plan
  of ``dp_bound.solve_multinode(paths=...)``;
- ``bound``: the clairvoyant bound, ``dp_bound.clairvoyant_bound`` (one node) or the certified bound
  of the same ``solve_multinode`` (K > 1) at ``bound_resolution`` m: no flight on the paths scores more;
- ``clairvoyant``: the tour given the true paths (``tour.solve(paths=...)``);
- ``mpc_dp_k1`` / ``mpc_dp_k10``: ``MPC(k=1 / 10, planner="dp")`` online (its default grid and
  refinement, ``mpc_resolution`` m); ``mpc_k1`` / ``mpc_k10`` / ``plan_once``: ``MPC(k=1 / 10 / None)``
  over the tour;
- one node: ``track_exact`` / ``track_reports``, ``HoverAt("ground")`` in the env on the true position
  / on the reports (:func:`~baselines.references.mobile.track`); K > 1: ``straight``,
  ``StraightEqualShares`` in the env (the multi-node env has no tracking heuristic: ``HoverAt`` reads
  one node's position).

**Checks** (:func:`check_online_record`, on every scenario before the freeze): every plan solved and
feasible, bound >= optimum, no row above the bound, and the optimum at least :data:`ONLINE_SHARE`
(99.5 %) of every online row (the grid's resolution is its only allowance). :func:`online_content`
refuses (``ValueError`` naming the scenario and the row) records that fail one, so the freeze stops.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import time
import traceback
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ios_uav_env import (
    MOBILE_ID,
    MULTINODE_MOBILE_ID,
    MULTINODE_RANGES,
    ScenarioConfig,
    ScenarioRanges,
    sample_multinode,
    score_plan,
)
from ios_uav_env.benchmark.suite_registry import (
    BOUND_REL,
    FORMAT,
    MOBILE,
    MOBILE_V2_REFERENCES,
    MULTI_MOBILE_REFERENCES,
    MULTI_NODE_MOBILE,
)
from ios_uav_env.model.mobility import GaussMarkov
from ios_uav_env.model.motion import node_paths

#: The multi-node mobile suite's spawn key (its entropy is ``draws.ENTROPY`` unless given) and size.
MULTI_MOBILE_SPAWN_KEY = (23,)
MULTI_MOBILE_SIZE = 24
#: The family of ``ios_uav_env/IOSUAV-MultiNode-Mobile-v0``: the multi-node ranges, nodes walking.
MULTI_MOBILE_RANGES = dataclasses.replace(
    MULTINODE_RANGES, base=MULTINODE_RANGES.base.replace(motion=GaussMarkov())
)
#: The online rows by name: MPC's k (None: plan once) and inner planner.
ONLINE = {"mpc_dp_k1": (1, "dp"), "mpc_dp_k10": (10, "dp"), "mpc_k1": (1, "tour"), "mpc_k10": (10, "tour"),
          "plan_once": (None, "tour")}  # fmt: skip
#: The env rows by name: one node's (the knowledge HoverAt("ground") flies on), K > 1's.
TRACKS = {"track_exact": "exact", "track_reports": "reports"}
MULTI_ENV_ROWS = ("straight",)
#: The optimum must reach this share of every online row (the grid's resolution, nothing else).
ONLINE_SHARE = 0.995
#: The grids (m): the optimum's (dp-clairvoyant), the bound's cells, MPC-DP's (baselines.mpc's default).
DP_RESOLUTION = 2.5
BOUND_RESOLUTION = 2.5
MPC_RESOLUTION = 5.0
#: The optimum's corridor refinement levels (one node). dp_moving's default, 5, left mobile-v2's
#: scenario 25 at 99.446 % of tracking the true node (HoverAt on exact knowledge, which flies full
#: legs in any direction); 8 levels reach 99.51 % there. More levels never lower the score.
DP_REFINE = 8

__all__ = ["MULTI_MOBILE_RANGES", "MULTI_MOBILE_SIZE", "MULTI_MOBILE_SPAWN_KEY", "ONLINE_SHARE",
           "check_online_record", "describe", "longest_first", "multi_mobile_tasks", "online_content",
           "online_key", "online_rows", "solve_online", "straight"]  # fmt: skip


def online_rows(k: int) -> tuple[str, ...]:
    """The online rows of a scenario with ``k`` nodes (the MPC rows, then the env rows)."""
    return (*ONLINE, *(TRACKS if k == 1 else MULTI_ENV_ROWS))


def multi_mobile_tasks(
    n: int, seed: int, ranges: ScenarioRanges = MULTI_MOBILE_RANGES
) -> list[dict[str, Any]]:
    """The first ``n`` multi-node mobile tasks ``{"index", "config", "seed"}`` (module docstring,
    "Draws"); ``ranges.base`` must have a motion model (``ValueError`` otherwise)."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be an integer >= 1 (scenarios), got {n!r}")
    if ranges.base.motion is None:
        raise ValueError("ranges.base.motion must be a motion model for mobile scenarios, got None")
    rng = np.random.default_rng(np.random.SeedSequence(entropy=int(seed), spawn_key=MULTI_MOBILE_SPAWN_KEY))
    tasks = []
    for i in range(int(n)):
        config = sample_multinode(rng, ranges)
        tasks.append({"index": i, "config": config.to_dict(), "seed": int(rng.integers(2**31))})
    return tasks


def straight(config: ScenarioConfig, seed: int) -> tuple[np.ndarray, np.ndarray, float]:
    """``StraightEqualShares`` in the multi-node mobile env pinned to ``config``, reset with
    ``seed``, as ``evaluate`` plays it (``ios_uav_env.benchmark.heuristics.fly``): (trajectory
    (N, 2) m, shares (K, N), seconds)."""
    from ios_uav_env.benchmark.heuristics import fly
    from ios_uav_env.benchmark.multi_policies import StraightEqualShares

    flight = fly(StraightEqualShares(), config, env_id=MULTINODE_MOBILE_ID, seed=seed)
    assert flight.shares is not None
    return flight.trajectory, flight.shares, flight.seconds


def _failed(err: BaseException, seconds: float) -> dict[str, Any]:
    return {"rate": 0.0, "feasible": False, "seconds": seconds,
            "error": "".join(traceback.format_exception_only(err)).strip()}  # fmt: skip


def solve_online(
    config: ScenarioConfig,
    seed: int,
    dp_resolution: float,
    bound_resolution: float,
    mpc_resolution: float,
    dp_refine: int = 8,
) -> dict[str, Any]:
    """The reference record of a moving-node scenario (module docstring, "References"). A row
    that raises is recorded (rate 0, ``feasible`` false, the error); the checks then refuse it."""
    from baselines import dp_moving, tour
    from baselines.dp_bound import clairvoyant_bound
    from baselines.mpc import MPC, run_online
    from baselines.references.mobile import track

    truth = node_paths(config, np.random.default_rng(seed))
    record: dict[str, Any] = {"config": config.to_dict(), "seed": int(seed)}

    def optimum() -> tuple[np.ndarray, np.ndarray | None, float]:
        extra = {} if config.K == 1 else {"bound_resolution": bound_resolution}
        extra = extra if config.K > 1 else {"refine": int(dp_refine)}
        plan = dp_moving.solve(config, truth, resolution=dp_resolution, bound=False, **extra)
        if config.K > 1:  # the same solve certified the bound
            ub, h = float(plan.info["upper_bound"]), float(bound_resolution)
            record["bound"] = {"upper_bound": ub, "resolution": h, "seconds": float(plan.seconds)}
        return plan.trajectory, plan.info.get("shares"), plan.seconds

    def online(k: int | None, planner: str) -> tuple[np.ndarray, np.ndarray | None, float]:
        options = {"planner": "dp", "resolution": mpc_resolution} if planner == "dp" else {}
        run = run_online(config, MPC(k=k, **options), seed)
        if not np.array_equal(run.paths, truth):
            raise RuntimeError(f"run_online drew other paths than the episode seed {seed}'s")
        return run.trajectory, run.shares if config.K > 1 else None, run.seconds

    def clairvoyant() -> tuple[np.ndarray, np.ndarray | None, float]:
        plan = tour.solve(config, paths=truth)
        return plan.trajectory, plan.info.get("shares"), plan.seconds

    solvers: dict[str, Any] = {"optimum": optimum, "clairvoyant": clairvoyant}
    for name, (k, planner) in ONLINE.items():
        solvers[name] = functools.partial(online, k, planner)
    if config.K == 1:
        for name, knowledge in TRACKS.items():
            solvers[name] = lambda knowledge=knowledge: (*_pair(track(config, seed, knowledge)),)
    else:
        solvers["straight"] = functools.partial(straight, config, seed)
    for name, solve in solvers.items():
        t0 = time.perf_counter()
        try:
            q, shares, seconds = solve()
            score = score_plan(config, q, None if shares is None else np.asarray(shares), paths=truth)
            record[name] = {
                "rate": float(score.rate),
                "feasible": bool(score.feasible),
                "seconds": float(seconds),
            }
        except Exception as err:  # recorded, never dropped: the checks refuse it
            record[name] = _failed(err, time.perf_counter() - t0)
    record["optimum"]["resolution"] = float(dp_resolution)
    if config.K == 1:
        record["optimum"]["refine"] = int(dp_refine)
    if config.K == 1:
        t0 = time.perf_counter()
        bound = clairvoyant_bound(config, truth, resolution=bound_resolution)
        record["bound"] = {"upper_bound": float(bound), "resolution": float(bound_resolution),
                           "seconds": time.perf_counter() - t0}  # fmt: skip
    elif "bound" not in record:  # the optimum's solve failed: so did the bound
        record["bound"] = {"upper_bound": None, "resolution": float(bound_resolution), "seconds": 0.0,
                           "error": record["optimum"].get("error")}  # fmt: skip
    return record


def _pair(run: tuple[np.ndarray, float]) -> tuple[np.ndarray, None, float]:
    """A one-node env row (trajectory, seconds) as (trajectory, no shares, seconds)."""
    return run[0], None, run[1]


def solve_task(task: Mapping[str, Any], *, dp_resolution: float, bound_resolution: float, dp_refine: int,
               mpc_resolution: float) -> dict[str, Any]:  # fmt: skip
    """:func:`solve_online` of one task ``{"index", "config", "seed"}``, its index first."""
    config = ScenarioConfig(**task["config"])
    record = solve_online(
        config, int(task["seed"]), dp_resolution, bound_resolution, mpc_resolution, dp_refine
    )
    return {"index": int(task["index"]), **record}


def online_key(task: Mapping[str, Any], *, dp_resolution: float, bound_resolution: float, dp_refine: int,
               mpc_resolution: float) -> str:  # fmt: skip
    """The cache file stem of a task: ``online_`` and a hash of its config, episode seed and grids."""
    refine = [int(dp_refine)] if ScenarioConfig(**task["config"]).K == 1 else []  # (K > 1 has no refinement)
    blob = json.dumps([task["config"], int(task["seed"]), dp_resolution, bound_resolution, mpc_resolution,
                       "online:v1", *refine], sort_keys=True)  # fmt: skip
    return f"online_{hashlib.sha1(blob.encode()).hexdigest()[:16]}"


def longest_first(task: Mapping[str, Any]) -> float:
    """The order of the tasks to solve: the most node-slots (K N) first, so the pool ends evenly."""
    config = ScenarioConfig(**task["config"])
    return -float(config.K * config.N)


def describe(i: int, rec: Mapping[str, Any]) -> str:
    """The progress bar's note on a solved scenario: the optimum's % of the bound, MPC-DP k = 1's
    and the best online row's % of the optimum."""
    ub, opt = rec["bound"].get("upper_bound"), float(rec["optimum"]["rate"])
    rows = online_rows(ScenarioConfig(**rec["config"]).K)
    best = max(rows, key=lambda r: float(rec[r]["rate"]))
    gap = f"{100 * opt / ub:.2f}% of bound" if ub else "bound failed"
    pct = lambda r: f"{100 * float(rec[r]['rate']) / opt:.2f}%" if opt > 0 else "n/a"  # noqa: E731
    return f"#{i}: optimum {gap}; mpc_dp_k1 {pct('mpc_dp_k1')}, best online {best} {pct(best)} of it"


def check_online_record(rec: Mapping[str, Any]) -> list[str]:
    """What refuses a record (module docstring, "Checks"): one line per failure, naming the scenario
    and the row; none for a record fit to freeze."""
    i, config = rec["index"], ScenarioConfig(**rec["config"])
    ub, notes = rec["bound"].get("upper_bound"), []
    rows = ("optimum", "clairvoyant", *online_rows(config.K))
    for name in rows:
        if "error" in rec[name] or not rec[name]["feasible"]:
            notes.append(f"#{i}: {name} failed or infeasible ({rec[name].get('error', 'infeasible')})")
    if ub is None or not ub > 0:
        return [*notes, f"#{i}: the bound failed ({rec['bound'].get('error', ub)})"]
    opt = float(rec["optimum"]["rate"])
    if opt > ub * (1.0 + BOUND_REL):
        notes.append(f"#{i}: bound {ub!r} < optimum {opt!r} bps/Hz")
    for name in rows[1:]:
        rate = float(rec[name]["rate"])
        if rate > ub * (1.0 + BOUND_REL):
            notes.append(f"#{i}: {name} {rate!r} > bound {ub!r} bps/Hz")
        if name in online_rows(config.K) and opt < ONLINE_SHARE * rate:
            notes.append(f"#{i}: optimum {opt!r} < {100 * ONLINE_SHARE:g}% of {name} {rate!r} bps/Hz "
                         f"({100 * opt / rate:.3f}%)")  # fmt: skip
    return notes


def online_content(
    records: Sequence[Mapping[str, Any]], name: str, version: int, *, seed: int, ranges: ScenarioRanges,
    multi: bool, settings: Mapping[str, float],
) -> dict[str, Any]:  # fmt: skip
    """The content of ``mobile-v2`` (``multi`` false) or ``multi-node-mobile-v1`` from the records of
    :func:`solve_task`; ``ValueError`` naming every scenario and row that fails a check
    (:func:`check_online_record`): such records are never frozen."""
    failed = [note for rec in records for note in check_online_record(rec)]
    if failed:
        raise ValueError(f"{name} is not frozen: {len(failed)} check(s) failed: " + "; ".join(failed))
    references = MULTI_MOBILE_REFERENCES if multi else MOBILE_V2_REFERENCES
    scenarios = []
    for rec in records:
        config = ScenarioConfig(**rec["config"]).to_dict()
        entry: dict[str, Any] = {"index": int(rec["index"]), "config": config, "seed": int(rec["seed"])}
        for r in references:
            if r == "bound":
                b = rec["bound"]
                entry[r] = {"upper_bound": float(b["upper_bound"]), "resolution": float(b["resolution"]),
                            "seconds": round(float(b["seconds"]), 3)}  # fmt: skip
                continue
            entry[r] = {"rate": float(rec[r]["rate"]), "feasible": bool(rec[r]["feasible"]),
                        "seconds": round(float(rec[r]["seconds"]), 4)}  # fmt: skip
            if r == "optimum":
                entry[r]["resolution"] = float(rec[r]["resolution"])
        scenarios.append(entry)
    if multi:
        env_id, kind, key = MULTINODE_MOBILE_ID, MULTI_NODE_MOBILE, MULTI_MOBILE_SPAWN_KEY
        sampler = "ios_uav_env.sample_multinode (2 to 4 nodes), then rng.integers(2**31) as the episode seed"
        family = "2 to 4 nodes, each"
        env_rows = "straight: StraightEqualShares in the env (the multi-node env has no tracking heuristic)"
    else:
        from baselines.references.mobile import MOBILE_SPAWN_KEY as key

        env_id, kind = MOBILE_ID, MOBILE
        sampler = "ios_uav_env.sample_scenario, then rng.integers(2**31) as the episode seed"
        family = "the node"
        env_rows = (
            "track_exact / track_reports: HoverAt('ground') in the env on the true position / on the reports"
        )
    return {
        "format": FORMAT,
        "name": name,
        "version": int(version),
        "kind": kind,
        "env_id": env_id,
        "env_kwargs": {},
        "normalizer": "optimum",
        "references": list(references),
        "description": (
            f"{len(scenarios)} held-out scenarios of {env_id} ({family} on a pedestrian Gauss-Markov path, "
            f"known through reports), each with an episode seed, drawn in turn from default_rng(SeedSequence("
            f"entropy={int(seed)}, spawn_key={tuple(key)})) by {sampler}. The episode seed fixes the true "
            "paths and the reports' noise, in the env reset with it on the pinned scenario as in "
            "baselines.mpc.run_online. Values are rates on the true paths with each row's own shares "
            "(bps/Hz, ios_uav_env.score_plan(config, q, shares, paths=...); max-min for K > 1), with "
            "feasibility and seconds per episode (a busy 2-core machine). optimum: the clairvoyant DP "
            f"baselines.dp_moving.solve (dp-clairvoyant) at {settings['dp_resolution']:g} m (one node: "
            f"refine={settings['dp_refine']:g} corridor levels), the normaliser; "
            "bound: the clairvoyant bound (dp_bound.clairvoyant_bound, K > 1 solve_multinode's certified "
            f"bound) at {settings['bound_resolution']:g} m cells; mpc_dp_k1 / mpc_dp_k10: "
            f"baselines.mpc.MPC(k=1 / 10, planner='dp', resolution={settings['mpc_resolution']:g}) online; "
            "mpc_k1 / mpc_k10 / plan_once: MPC(k=1 / 10 / None) over the tour; clairvoyant: "
            f"baselines.tour.solve(paths=true paths); {env_rows}. Checked before freezing: bound >= "
            f"optimum >= {100 * ONLINE_SHARE:g}% of every online row on every scenario."
        ),
        "source": {
            "entropy": int(seed),
            "spawn_key": list(key),
            "sampler": sampler,
            "ranges": ranges.to_dict(),
            **{k: int(v) if k == "dp_refine" else float(v) for k, v in settings.items()},
        },
        "scenarios": scenarios,
    }
