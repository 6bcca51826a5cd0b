"""The online suites' checks and content (``baselines.references.online``, "Checks"): what refuses
a scenario's record, and the frozen suite file of the records that pass.

:func:`check_online_record` lists a record's failures (a plan failed or infeasible, the bound
below the optimum or a row, the optimum under :data:`ONLINE_SHARE` of an online row);
:func:`online_content` builds ``mobile-v2``'s or ``multi-node-mobile-v1``'s content from the
records and refuses, naming every scenario and row, records that fail. Every name here is
importable from ``baselines.references.online`` too.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from baselines.references.online_draws import MULTI_MOBILE_SPAWN_KEY, online_rows
from ios_uav_env import MOBILE_ID, MULTINODE_MOBILE_ID, ScenarioConfig, ScenarioRanges
from ios_uav_env.benchmark.suite_registry import (
    BOUND_REL,
    FORMAT,
    MOBILE,
    MOBILE_V2_REFERENCES,
    MULTI_MOBILE_REFERENCES,
    MULTI_NODE_MOBILE,
)

#: The optimum must reach this share of every online row (the grid's resolution, nothing else).
ONLINE_SHARE = 0.995


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
