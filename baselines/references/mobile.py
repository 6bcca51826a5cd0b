"""The mobile suite's draws, references and content: one moving node known through reports.

**Draws** (:func:`mobile_tasks`): ``n`` scenarios of ``ios_uav_env/IOSUAV-Mobile-v0``'s family
(:data:`MOBILE_RANGES`: the random id's ranges, both surfaces, the node walking a pedestrian
Gauss-Markov path), each followed by its episode seed, drawn in turn from
``default_rng(SeedSequence(entropy=seed, spawn_key=MOBILE_SPAWN_KEY))``: a stream that no reset
seed and no other suite's draws reproduce. The episode seed fixes the node's path and the
reports' noise, in the env (``reset(seed=...)`` on the pinned scenario) as in
``baselines.mpc.run_online``.

**References** (:func:`solve_mobile`, on the true path ``node_paths(config, default_rng(seed))``;
every rate is ``ios_uav_env.score_plan(config, q, paths=...)``): the clairvoyant bound
(``dp_bound.clairvoyant_bound``), the clairvoyant tour (``tour.solve(paths=...)``), MPC(k=1),
MPC(k=10) and plan once (``run_online`` with the episode seed), and ``HoverAt("ground")`` in the
env on the true position and on the reports. A planner that raises is recorded (rate 0,
``feasible`` false, the error); the bound is the normaliser, so its failure fails the task.
"""

from __future__ import annotations

import dataclasses
import functools
import time
import traceback
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from ios_uav_env import DEFAULT_RANGES, MOBILE_ID, ScenarioConfig, ScenarioRanges, sample_scenario, score_plan
from ios_uav_env.benchmark.heuristics import hover_episode
from ios_uav_env.benchmark.suite_registry import BOUND_REL, FORMAT, MOBILE, MOBILE_REFERENCES
from ios_uav_env.model.mobility import GaussMarkov
from ios_uav_env.model.motion import node_paths

#: The mobile suite's spawn key (its entropy is ``draws.ENTROPY`` unless given), size and family.
MOBILE_SPAWN_KEY = (9,)
MOBILE_SIZE = 40
MOBILE_RANGES = dataclasses.replace(DEFAULT_RANGES, base=DEFAULT_RANGES.base.replace(motion=GaussMarkov()))
#: The online planners of the suite, by reference name: MPC's k (None: plan once).
ONLINE = {"mpc_k1": 1, "mpc_k10": 10, "plan_once": None}
#: The env rows, by reference name: the ``knowledge`` HoverAt("ground") flies on.
TRACKS = {"track_exact": "exact", "track_reports": "reports"}
PLANS = ("clairvoyant", *ONLINE, *TRACKS)

__all__ = ["MOBILE_RANGES", "MOBILE_SIZE", "MOBILE_SPAWN_KEY", "check_mobile_record", "is_mobile",
           "mobile_content", "mobile_tasks", "solve_mobile", "track"]  # fmt: skip


def is_mobile(config: ScenarioConfig) -> bool:
    """A mobile scenario (one node with a motion model): a mobile suite's."""
    return config.K == 1 and config.motion is not None


def mobile_tasks(n: int, seed: int, ranges: ScenarioRanges = MOBILE_RANGES) -> list[dict[str, Any]]:
    """The first ``n`` mobile tasks ``{"index", "config", "seed"}`` (module docstring, "Draws");
    ``ranges.base`` must have a motion model (``ValueError`` otherwise)."""
    return draw_tasks(n, seed, ranges, MOBILE_SPAWN_KEY, sample_scenario)


def draw_tasks(
    n: int, seed: int, ranges: ScenarioRanges, spawn_key: tuple[int, ...],
    sample: Callable[[np.random.Generator, ScenarioRanges], ScenarioConfig],
) -> list[dict[str, Any]]:  # fmt: skip
    """The first ``n`` tasks ``{"index", "config", "seed"}`` of moving-node scenarios drawn by
    ``sample`` from ``ranges`` (with a motion model: ``ValueError`` otherwise), each config then
    its episode seed from one generator of (``seed``, ``spawn_key``)."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be an integer >= 1 (scenarios), got {n!r}")
    if ranges.base.motion is None:
        raise ValueError("ranges.base.motion must be a motion model for mobile scenarios, got None")
    rng = np.random.default_rng(np.random.SeedSequence(entropy=int(seed), spawn_key=spawn_key))
    tasks = []
    for i in range(int(n)):
        config = sample(rng, ranges)
        tasks.append({"index": i, "config": config.to_dict(), "seed": int(rng.integers(2**31))})
    return tasks


def _failed(err: BaseException, seconds: float) -> dict[str, Any]:
    return {"rate": 0.0, "feasible": False, "seconds": seconds,
            "error": "".join(traceback.format_exception_only(err)).strip()}  # fmt: skip


def track(config: ScenarioConfig, seed: int, knowledge: str) -> tuple[np.ndarray, float]:
    """HoverAt("ground") in the single-node env with ``knowledge``, pinned to ``config`` and reset
    with ``seed`` (``ios_uav_env.benchmark.heuristics.hover_episode``): (the flown trajectory
    (N, 2) m, seconds of the episode)."""
    episode = hover_episode(config, "ground", seed=seed, knowledge=knowledge)
    return episode.trajectory, episode.seconds


def solve_mobile(config: ScenarioConfig, seed: int, bound_resolution: float) -> dict[str, Any]:
    """The reference record of a mobile scenario (module docstring, "References")."""
    from baselines import tour
    from baselines.dp_bound import clairvoyant_bound
    from baselines.mpc import MPC, run_online

    truth = node_paths(config, np.random.default_rng(seed))
    record: dict[str, Any] = {"config": config.to_dict(), "seed": int(seed)}

    def online(k: int | None) -> tuple[np.ndarray, float]:  # its planning time, not its drawing
        run = run_online(config, MPC(k=k), seed)
        return run.trajectory, run.seconds

    solvers = {"clairvoyant": lambda: (tour.solve(config, paths=truth).trajectory, None)}
    for name, k in ONLINE.items():
        solvers[name] = functools.partial(online, k)
    for name, knowledge in TRACKS.items():
        solvers[name] = functools.partial(track, config, seed, knowledge)
    for name, solve in solvers.items():
        t0 = time.perf_counter()
        try:
            q, seconds = solve()
            score = score_plan(config, q, paths=truth)
            seconds = time.perf_counter() - t0 if seconds is None else seconds
            record[name] = {
                "rate": float(score.rate),
                "feasible": bool(score.feasible),
                "seconds": float(seconds),
            }
        except Exception as err:  # recorded, never dropped
            record[name] = _failed(err, time.perf_counter() - t0)
    t0 = time.perf_counter()
    bound = clairvoyant_bound(config, truth, resolution=bound_resolution)
    record["bound"] = {"upper_bound": float(bound), "resolution": float(bound_resolution),
                       "seconds": time.perf_counter() - t0}  # fmt: skip
    return record


def check_mobile_record(rec: Mapping[str, Any]) -> list[str]:
    """The sanity notes of one mobile record: a plan failed or infeasible, a rate above the bound."""
    i, ub, notes = rec["index"], float(rec["bound"]["upper_bound"]), []
    for name in PLANS:
        if "error" in rec[name] or not rec[name]["feasible"]:
            notes.append(f"#{i}: {name} failed or infeasible ({rec[name].get('error', 'infeasible')})")
        elif rec[name]["rate"] > ub * (1.0 + BOUND_REL):
            notes.append(f"#{i}: {name} {rec[name]['rate']:.9g} > bound {ub:.9g} bps/Hz")
    return notes


def mobile_content(
    records: Sequence[Mapping[str, Any]], name: str, version: int, *, seed: int, ranges: ScenarioRanges
) -> dict[str, Any]:
    """The content of a mobile suite from the records of ``solve_all`` on :func:`mobile_tasks`
    (``ValueError`` naming the scenario where the bound or MPC(k=1) is not > 0 or a plan's rate
    exceeds the bound: :func:`~ios_uav_env.benchmark.suite.load_suite` would refuse it)."""
    scenarios = []
    for rec in records:
        i, ub = int(rec["index"]), float(rec["bound"]["upper_bound"])
        if not (ub > 0 and rec["mpc_k1"]["rate"] > 0):
            raise ValueError(f"scenario {i}: the bound and MPC(k=1) must be > 0 bps/Hz")
        above = [f"{r} {rec[r]['rate']!r}" for r in PLANS if rec[r]["rate"] > ub * (1.0 + BOUND_REL)]
        if above:
            raise ValueError(f"scenario {i}: the bound {ub!r} bps/Hz is below {', '.join(above)}")
        entry: dict[str, Any] = {"index": i, "config": ScenarioConfig(**rec["config"]).to_dict(),
                                 "seed": int(rec["seed"])}  # fmt: skip
        for r in PLANS:
            entry[r] = {"rate": float(rec[r]["rate"]), "feasible": bool(rec[r]["feasible"]),
                        "seconds": round(float(rec[r]["seconds"]), 4)}  # fmt: skip
        b = rec["bound"]
        entry["bound"] = {"upper_bound": ub, "resolution": float(b["resolution"]),
                          "seconds": round(float(b["seconds"]), 3)}  # fmt: skip
        scenarios.append({k: entry[k] for k in ("index", "config", "seed", *MOBILE_REFERENCES)})
    return {
        "format": FORMAT,
        "name": name,
        "version": int(version),
        "kind": MOBILE,
        "env_id": MOBILE_ID,
        "env_kwargs": {},
        "normalizer": "bound",
        "references": list(MOBILE_REFERENCES),
        "description": (
            f"{len(scenarios)} held-out scenarios of {MOBILE_ID}: sample_scenario(rng, ranges) (the random "
            "id's ranges, IOS and RIS, the node on a pedestrian Gauss-Markov path) and an episode seed, "
            f"drawn in turn from default_rng(SeedSequence(entropy={int(seed)}, "
            f"spawn_key={MOBILE_SPAWN_KEY})). The episode seed fixes the node's true path and the reports' "
            "noise, in the env reset with it "
            "on the pinned scenario as in baselines.mpc.run_online. Values are average rates on the true "
            "path (bps/Hz, ios_uav_env.score_plan(config, q, paths=...)), with feasibility and planning "
            "seconds per episode (one process on a busy 2-core machine). bound: "
            "baselines.dp_bound.clairvoyant_bound on the true path at resolution m, the normaliser; "
            "clairvoyant: baselines.tour.solve(paths=true path); mpc_k1 / mpc_k10 / plan_once: "
            "baselines.mpc.MPC(k=1) / MPC(k=10) / MPC(k=None) online; track_exact / track_reports: "
            "HoverAt('ground') in the env on the true position / on the reports."
        ),
        "source": {
            "entropy": int(seed),
            "spawn_key": list(MOBILE_SPAWN_KEY),
            "sampler": "ios_uav_env.sample_scenario, then rng.integers(2**31) as the episode seed",
            "ranges": ranges.to_dict(),
        },
        "scenarios": scenarios,
    }
