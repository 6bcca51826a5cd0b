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

**References** (:func:`solve_online`; every rate is :func:`score`, ``score_plan(config, q, shares,
paths=...)`` on the true paths ``node_paths(config, default_rng(seed))``, with the row's own shares):

- ``optimum``, the normaliser. One node: the clairvoyant DP, ``baselines.dp_moving.solve`` (planner
  ``dp-clairvoyant``) at ``dp_resolution`` m, the grid optimum refined by ``dp_refine`` corridor
  levels (:data:`DP_REFINE`). K > 1 (:func:`clairvoyant_multi`): the max-min rate over TDMA shares
  is not a sum over slots, so no DP is exact and no optimum is proven: the optimum is **the best
  clairvoyant plan found**, the better of two planners that know the true paths, each scored by
  :func:`score` with its own (best) shares: ``dp_bound.solve_multinode(paths=...)``'s plan (grid
  DPs at ``dp_resolution`` m at Kelley's dual weights, the clairvoyant tour, tours through the DP
  paths' hovers) and ``baselines.sca_multi.solve(paths=...)`` (BCD with the paper's SCA on the true
  paths, exact scores never decreasing) started from that plan, the clairvoyant tour and its
  fly-hover-fly flights. The record names the winner (``source``) and every candidate's rate.
  SCA was added because ``solve_multinode``'s plan alone was not strong enough to hold the check
  below: on ``multi-node-mobile-v1``'s scenario 1 (2 nodes) MPC over the tour re-planned every slot
  scored 0.3838 bps/Hz against its 0.3694 (96.25 %); SCA from that plan reaches 0.4478 there, and
  SCA won on all 24 scenarios (``solve_multinode``'s plan is 75 to 99 % of the optimum);
- ``bound``: the clairvoyant bound at ``bound_resolution`` m cells, ``dp_bound.clairvoyant_bound``
  (one node) or the certified bound of the same ``solve_multinode`` (K > 1; weak duality on the
  relaxed DP, ``baselines.dp_bound``): no flight on the paths scores more, so it holds whatever
  planner the optimum came from;
- ``clairvoyant``: the tour given the true paths (``tour.solve(paths=...)``); K > 1, solved once
  and handed to ``solve_multinode`` and SCA (their start weights, candidates and starts);
- ``mpc_dp_k1`` / ``mpc_dp_k10``: ``MPC(k=1 / 10, planner="dp")`` online (its default grid and
  refinement, ``mpc_resolution`` m); ``mpc_k10`` / ``plan_once``: ``MPC(k=10 / None)`` over the
  tour, and one node ``mpc_k1`` (``MPC(k=1)``; K > 1 leaves it out, :data:`MULTI_ONLINE`);
- one node: ``track_exact`` / ``track_reports``, ``HoverAt("ground")`` in the env on the true position
  / on the reports (:func:`~baselines.references.mobile.track`); K > 1: ``straight``,
  ``StraightEqualShares`` in the env (the multi-node env has no tracking heuristic: ``HoverAt`` reads
  one node's position).

**Checks** (:func:`check_online_record`, on every scenario before the freeze): every plan solved and
feasible, bound >= optimum, no row above the bound, and the optimum at least :data:`ONLINE_SHARE`
(99.5 %) of every online row (one node: the grid's resolution is its only allowance; K > 1 the same
rule, with no looser allowance: a clairvoyant planner that an online one beats is not strong enough
to normalise by). :func:`online_content` refuses (``ValueError`` naming the scenario and the row)
records that fail one, so the freeze stops.

**Cost** (K > 1): the plans and the bound at 5 m (:data:`MULTI_DP_RESOLUTION`,
:data:`MULTI_BOUND_RESOLUTION`), the tour solved once, ``mpc_k1`` left out. Each record holds its
``cpu_seconds`` (not frozen); the measured freeze is in ``results/log.md``.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import time
import traceback
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

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
from ios_uav_env.model.score import PlanScore

if TYPE_CHECKING:
    from baselines.plan import Plan

#: A row's flight: (trajectory (N, 2) m, its own shares (K, N) or None for one node, seconds).
Flight = tuple[np.ndarray, Any, float]

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
#: Those of K > 1: MPC over the tour re-planned every slot (``mpc_k1``) is left out, the costliest
#: row (a tour on the predicted paths in every one of up to 197 slots: 916 CPU s on the 24
#: scenarios of ``multi-node-mobile-v1``, against 1470 for all the other rows); the tour's MPC keeps
#: ``mpc_k10`` and plan once.
MULTI_ONLINE = tuple(name for name in ONLINE if name != "mpc_k1")
#: The env rows by name: one node's (the knowledge HoverAt("ground") flies on), K > 1's.
TRACKS = {"track_exact": "exact", "track_reports": "reports"}
MULTI_ENV_ROWS = ("straight",)
#: The optimum must reach this share of every online row (the grid's resolution, nothing else).
ONLINE_SHARE = 0.995
#: The grids (m): the optimum's (dp-clairvoyant), the bound's cells, MPC-DP's (baselines.mpc's default).
DP_RESOLUTION = 2.5
BOUND_RESOLUTION = 2.5
MPC_RESOLUTION = 5.0
#: K > 1: the grid of ``solve_multinode``'s DP plans (SCA polishes the best one) and the bound's
#: cells (m). On the largest scenario (#11: 4 nodes, 193 slots) the plans and bound at 2.5 m cost 77
#: CPU s and bound at 0.2875 bps/Hz; these 15 CPU s and 0.2891 (0.6 % looser, still certified);
#: 10 m cells 8 CPU s and 0.2915.
MULTI_DP_RESOLUTION = 5.0
MULTI_BOUND_RESOLUTION = 5.0
#: The optimum's corridor refinement levels (one node). dp_moving's default, 5, left mobile-v2's
#: scenario 25 at 99.446 % of tracking the true node (HoverAt on exact knowledge, which flies full
#: legs in any direction); 8 levels reach 99.51 % there. More levels never lower the score.
DP_REFINE = 8

__all__ = ["MULTI_BOUND_RESOLUTION", "MULTI_DP_RESOLUTION", "MULTI_MOBILE_RANGES", "MULTI_MOBILE_SIZE",
           "MULTI_MOBILE_SPAWN_KEY", "MULTI_ONLINE", "ONLINE_SHARE", "check_online_record",
           "clairvoyant_multi", "describe", "longest_first", "multi_mobile_tasks", "online_content",
           "online_key", "online_rows", "score", "solve_online", "straight"]  # fmt: skip


def online_rows(k: int) -> tuple[str, ...]:
    """The online rows of a scenario with ``k`` nodes (the MPC rows, then the env rows)."""
    return (*ONLINE, *TRACKS) if k == 1 else (*MULTI_ONLINE, *MULTI_ENV_ROWS)


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


def clairvoyant_multi(
    config: ScenarioConfig,
    truth: np.ndarray,
    resolution: float,
    bound_resolution: float,
    tour_plan: Plan | None = None,
) -> tuple[Plan, Plan]:
    """K > 1: the clairvoyant optimum on the true paths ``truth`` (module docstring, "References"):
    (the best candidate, ``solve_multinode``'s plan, whose ``info["upper_bound"]`` is the certified
    bound). Each candidate is scored by :func:`score` on ``truth`` with its own shares; the winner's
    ``info`` names it (``source``: its planner and, for SCA, its start) and holds every candidate's
    rate (``candidates``); its ``seconds`` are the whole computation, the tour's included.
    ``tour_plan``: the clairvoyant tour, ``tour.solve(config, paths=truth)``, when the caller has it."""
    from baselines import sca_multi, tour
    from baselines.dp_bound import solve_multinode

    t0, given = time.perf_counter(), tour_plan is not None
    tour_plan = tour.tour_of(config, truth, tour_plan)
    dp = solve_multinode(config, resolution=resolution, bound_resolution=bound_resolution, paths=truth,
                         tour_plan=tour_plan)  # fmt: skip
    dp_name = f"dp ({dp.info['plan_source']})"
    fresh = not np.array_equal(dp.trajectory, tour_plan.trajectory)  # (else the tour start is the DP's)
    sca = sca_multi.solve(config, paths=truth, init=[dp.trajectory] if fresh else [], tour_plan=tour_plan)
    start = dp_name if sca.info["start"] == "init0" else str(sca.info["start"])
    candidates = {dp_name: dp, f"sca from {start}": sca}
    rates = {name: float(score(config, p.trajectory, p.info["shares"], truth).rate)
             for name, p in candidates.items()}  # fmt: skip
    source = max(rates, key=rates.__getitem__)  # (the first of equal rates)
    seconds = time.perf_counter() - t0 + (float(tour_plan.seconds) if given else 0.0)
    best = dataclasses.replace(candidates[source], seconds=seconds)
    best.info = {**best.info, "source": source, "candidates": rates}
    return best, dp


def score(config: ScenarioConfig, q: np.ndarray, shares: Any, truth: np.ndarray) -> PlanScore:
    """The one scorer of every row: ``score_plan(config, q, shares, paths=truth)``, with the row's
    own ``shares`` (K, N) (one node: None)."""
    return score_plan(config, q, None if shares is None else np.asarray(shares), paths=truth)


def solve_online(
    config: ScenarioConfig,
    seed: int,
    dp_resolution: float,
    bound_resolution: float,
    mpc_resolution: float,
    dp_refine: int = 8,
) -> dict[str, Any]:
    """The reference record of a moving-node scenario (module docstring, "References"). A row
    that raises is recorded (rate 0, ``feasible`` false, the error); the checks then refuse it.
    ``dp_refine`` applies to one node (K > 1: ``dp_resolution`` is the grid of the DP plans)."""
    from baselines import dp_moving, tour
    from baselines.dp_bound import clairvoyant_bound
    from baselines.mpc import MPC, run_online
    from baselines.references.mobile import track

    truth = node_paths(config, np.random.default_rng(seed))
    record: dict[str, Any] = {"config": config.to_dict(), "seed": int(seed)}
    tours: list[Plan] = []  # the clairvoyant tour, solved once (K > 1: the optimum starts from it)
    notes: dict[str, Any] = {}  # K > 1: the optimum's source and candidates

    def clairvoyant() -> Flight:
        tours.append(tour.solve(config, paths=truth))
        return tours[0].trajectory, tours[0].info.get("shares"), tours[0].seconds

    def optimum() -> Flight:
        if config.K == 1:
            plan = dp_moving.solve(
                config, truth, resolution=dp_resolution, bound=False, refine=int(dp_refine)
            )
            return plan.trajectory, None, plan.seconds
        best, dp = clairvoyant_multi(config, truth, dp_resolution, bound_resolution, next(iter(tours), None))
        ub, h = float(dp.info["upper_bound"]), float(bound_resolution)
        record["bound"] = {"upper_bound": ub, "resolution": h, "seconds": float(dp.seconds)}
        notes.update(source=best.info["source"], candidates=best.info["candidates"])
        return best.trajectory, best.info["shares"], best.seconds

    def online(k: int | None, planner: str) -> Flight:
        options = {"planner": "dp", "resolution": mpc_resolution} if planner == "dp" else {}
        run = run_online(config, MPC(k=k, **options), seed)
        if not np.array_equal(run.paths, truth):
            raise RuntimeError(f"run_online drew other paths than the episode seed {seed}'s")
        return run.trajectory, run.shares if config.K > 1 else None, run.seconds

    def tracking(knowledge: str) -> Flight:
        q, seconds = track(config, seed, knowledge)
        return q, None, seconds

    solvers: dict[str, Any] = {"clairvoyant": clairvoyant, "optimum": optimum}
    for name in online_rows(config.K):
        if name in ONLINE:
            solvers[name] = functools.partial(online, *ONLINE[name])
        elif name in TRACKS:
            solvers[name] = functools.partial(tracking, TRACKS[name])
        else:
            solvers[name] = functools.partial(straight, config, seed)
    for name, solve in solvers.items():
        t0 = time.perf_counter()
        try:
            q, shares, seconds = solve()
            scored = score(config, q, shares, truth)
            record[name] = {"rate": float(scored.rate), "feasible": bool(scored.feasible),
                            "seconds": float(seconds)}  # fmt: skip
        except Exception as err:  # recorded, never dropped: the checks refuse it
            record[name] = _failed(err, time.perf_counter() - t0)
    record["optimum"].update(resolution=float(dp_resolution), **notes)
    if config.K == 1:
        record["optimum"]["refine"] = int(dp_refine)
        t0 = time.perf_counter()
        bound = clairvoyant_bound(config, truth, resolution=bound_resolution)
        record["bound"] = {"upper_bound": float(bound), "resolution": float(bound_resolution),
                           "seconds": time.perf_counter() - t0}  # fmt: skip
    elif "bound" not in record:  # the optimum's solve failed: so did the bound
        record["bound"] = {"upper_bound": None, "resolution": float(bound_resolution), "seconds": 0.0,
                           "error": record["optimum"].get("error")}  # fmt: skip
    return record


def solve_task(task: Mapping[str, Any], *, dp_resolution: float, bound_resolution: float, dp_refine: int,
               mpc_resolution: float) -> dict[str, Any]:  # fmt: skip
    """:func:`solve_online` of one task ``{"index", "config", "seed"}``, its index first and its
    ``cpu_seconds`` last (the CPU time of the whole record in this process, every row's included;
    not frozen: the pipeline's cost on a loaded machine, where wall times mislead)."""
    config = ScenarioConfig(**task["config"])
    cpu = time.process_time()
    record = solve_online(
        config, int(task["seed"]), dp_resolution, bound_resolution, mpc_resolution, dp_refine
    )
    return {"index": int(task["index"]), **record, "cpu_seconds": time.process_time() - cpu}


def online_key(task: Mapping[str, Any], *, dp_resolution: float, bound_resolution: float, dp_refine: int,
               mpc_resolution: float) -> str:  # fmt: skip
    """The cache file stem of a task: ``online_`` and a hash of its config, episode seed and grids
    (one node: and the refinement levels; K > 1: the version of its references, v2 being the best
    clairvoyant plan as the optimum, without ``mpc_k1``)."""
    tail = ["online:v1", int(dp_refine)] if ScenarioConfig(**task["config"]).K == 1 else ["online:v2"]
    blob = json.dumps([task["config"], int(task["seed"]), dp_resolution, bound_resolution, mpc_resolution,
                       *tail], sort_keys=True)  # fmt: skip
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


def check_online_record(rec: Mapping[str, Any], extra: Sequence[str] = ()) -> list[str]:
    """What refuses a record (module docstring, "Checks"): one line per failure, naming the scenario
    and the row; none for a record fit to freeze. ``extra``: more online rows of the record
    (``{"rate", "feasible"}``), checked as the suite's own (rows scored after the freeze)."""
    i, config = rec["index"], ScenarioConfig(**rec["config"])
    ub, notes = rec["bound"].get("upper_bound"), []
    online = (*online_rows(config.K), *extra)
    rows = ("optimum", "clairvoyant", *online)
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
        if name in online and opt < ONLINE_SHARE * rate:
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
                if multi:  # the planner and start of the best clairvoyant plan
                    entry[r]["source"] = str(rec[r]["source"])
        scenarios.append(entry)
    grids = {k: float(v) for k, v in settings.items() if k != "dp_refine"}
    mpc_dp = f"baselines.mpc.MPC(k=1 / 10, planner='dp', resolution={grids['mpc_resolution']:g}) online"
    if multi:
        env_id, kind, key = MULTINODE_MOBILE_ID, MULTI_NODE_MOBILE, MULTI_MOBILE_SPAWN_KEY
        sampler = "ios_uav_env.sample_multinode (2 to 4 nodes), then rng.integers(2**31) as the episode seed"
        family = "2 to 4 nodes, each"
        rows = (
            "optimum: the best clairvoyant plan found on the true paths (not a proven optimum), the "
            "normaliser: the better of baselines.dp_bound.solve_multinode(paths=...)'s plan (grid DPs at "
            f"{grids['dp_resolution']:g} m at Kelley's dual weights, the clairvoyant tour, tours through the "
            "DP paths' hovers) and baselines.sca_multi.solve(paths=...) started from that plan, the "
            "clairvoyant tour and its fly-hover-fly flights, each scored by score_plan with its own shares "
            "(source: the winner); bound: the same solve_multinode's certified bound at "
            f"{grids['bound_resolution']:g} m cells (no flight on the true paths scores more); mpc_dp_k1 / "
            f"mpc_dp_k10: {mpc_dp}; mpc_k10 / plan_once: MPC(k=10 / None) over the tour; clairvoyant: "
            "baselines.tour.solve(paths=true paths); straight: StraightEqualShares in the env (the "
            "multi-node env has no tracking heuristic)"
        )
        source = grids
    else:
        from baselines.references.mobile import MOBILE_SPAWN_KEY as key

        env_id, kind = MOBILE_ID, MOBILE
        sampler = "ios_uav_env.sample_scenario, then rng.integers(2**31) as the episode seed"
        family = "the node"
        rows = (
            "optimum: the clairvoyant DP "
            f"baselines.dp_moving.solve (dp-clairvoyant) at {settings['dp_resolution']:g} m (one node: "
            f"refine={settings['dp_refine']:g} corridor levels), the normaliser; "
            "bound: the clairvoyant bound (dp_bound.clairvoyant_bound, K > 1 solve_multinode's certified "
            f"bound) at {settings['bound_resolution']:g} m cells; mpc_dp_k1 / mpc_dp_k10: {mpc_dp}; "
            "mpc_k1 / mpc_k10 / plan_once: MPC(k=1 / 10 / None) over the tour; clairvoyant: "
            "baselines.tour.solve(paths=true paths); track_exact / track_reports: HoverAt('ground') in the "
            "env on the true position / on the reports"
        )
        source = {k: int(v) if k == "dp_refine" else float(v) for k, v in settings.items()}
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
            f"feasibility and seconds per episode (a busy 2-core machine). {rows}. Checked before freezing: "
            f"bound >= optimum >= {100 * ONLINE_SHARE:g}% of every online row on every scenario."
        ),
        "source": {
            "entropy": int(seed),
            "spawn_key": list(key),
            "sampler": sampler,
            "ranges": ranges.to_dict(),
            **source,
        },
        "scenarios": scenarios,
    }
