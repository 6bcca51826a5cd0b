"""The held-out suite: fixed random scenarios with their planners' results, for scoring generalists.

A generalist policy is trained on ``ios_uav_env/IOSUAV-Random-v0`` (a new scenario from
``ios_uav_env.DEFAULT_RANGES`` at every reset; training seeds are small integers) and scored
on scenarios it has never seen: :data:`HELDOUT_SEED` draws :data:`DEFAULT_SIZE` scenarios
from the same ranges with ``sample_scenario(np.random.default_rng(seed))``, and each one's
DP optimum (``baselines.dp.solve`` at :data:`DP_RESOLUTION` m: rate, trajectory, seconds) and
SCA plan (``baselines.sca.solve``, the paper's algorithm with its default multi-start: rate,
feasibility, seconds, trajectory) are precomputed into ``agents/suite/heldout.json``: the
seed, the ranges, and one line per scenario (its full ``ScenarioConfig``, the plans). Rates
and feasibility are those of the planners' own trajectories; the stored trajectories are
rounded to 10^-:data:`TRAJECTORY_DECIMALS` m (for figures and warm starts).

This module is the reference pipeline's plan file of the single-node suite: the data model
(:class:`Suite`, :class:`SuiteEntry`), its build (the scenarios solved by
:func:`baselines.references.solve_all`) and load. ``python -m baselines.references
single-node`` freezes it into ``single-node-v1``; :mod:`agents.suite.report` draws its DP and
SCA plans beside a policy's; ``python -m agents.suite`` is the command line:

    python -m agents.suite build --overwrite [--jobs 2]   # rebuild the shipped suite (resumable)
    python -m agents.suite build --n 3           # a trial suite: out/suite_n3_seed20261122.json
    python -m agents.suite show [--table]
    python -m agents.suite report --model runs/<run> [--algo ppo|sac] [--out out/suite]
    python -m agents.suite curve --run runs/<run> [--out out/suite_curve]

``build`` solves the scenarios with ``baselines.runner.run_tasks`` (spawned worker processes,
a progress bar) and caches each scenario's result as one JSON file (``--cache``, default
``out/suite-cache``, written atomically as soon as it is solved; the key hashes the config
and the planner settings), so an interrupted build resumes where it stopped (a cached
record that cannot be read or holds a NaN is solved again); the suite file is written
atomically at the end. An existing
suite file (the shipped ``heldout.json`` above all) is replaced only with ``--overwrite``;
a build of another size or seed goes to ``out/`` unless ``--out`` says otherwise.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from baselines.references.draws import DEFAULT_SIZE, HELDOUT_SEED, suite_configs
from baselines.references.solve import DP_RESOLUTION, solve_all, task_key
from ios_uav_env import DEFAULT_RANGES, ScenarioConfig, ScenarioRanges
from ios_uav_env.io import atomic_write_text

#: Decimals (m) of the stored trajectories.
TRAJECTORY_DECIMALS = 3
#: The shipped plan file (the checkout's ``agents/suite/heldout.json``, where the frozen suite names it).
SUITE_PATH = Path(__file__).resolve().parents[2] / "agents" / "suite" / "heldout.json"
CACHE_DIR = Path("out/suite-cache")
FORMAT = "ios_uav_env held-out suite, v1"


@dataclass
class SuiteEntry:
    """One scenario of the suite and its planners' results."""

    index: int
    config: ScenarioConfig
    dp: dict[str, Any]  # rate (bps/Hz), seconds, resolution (m), trajectory ((N, 2) array, m)
    sca: dict[str, Any]  # rate, feasible, worst_violation (m), seconds, status, trajectory

    @property
    def dp_rate(self) -> float:
        return float(self.dp["rate"])

    @property
    def sca_pct_dp(self) -> float:
        return 100.0 * self.sca["rate"] / self.dp["rate"]


@dataclass
class Suite:
    """The held-out suite: its seed, its ranges and its scenarios."""

    seed: int
    ranges: ScenarioRanges
    entries: list[SuiteEntry]
    dp_resolution: float = DP_RESOLUTION
    meta: dict[str, Any] = field(default_factory=dict)  # build information

    def __len__(self) -> int:
        return len(self.entries)

    def __iter__(self) -> Iterator[SuiteEntry]:
        return iter(self.entries)

    def __getitem__(self, i: int) -> SuiteEntry:
        return self.entries[i]

    def configs(self) -> list[ScenarioConfig]:
        return [e.config for e in self.entries]

    def subset(self, n: int | None) -> list[SuiteEntry]:
        """The first ``n`` entries (all for None): a fixed subset, e.g. for a training callback."""
        return list(self.entries if n is None else self.entries[: max(0, int(n))])


def cache_key(config: ScenarioConfig, dp_resolution: float) -> str:
    """The cache file stem of one scenario (``baselines.references.task_key``)."""
    return task_key({"index": 0, "config": config.to_dict()}, dp_resolution=dp_resolution)


def _rounded(trajectory: Any) -> list[list[float]]:
    return np.round(np.asarray(trajectory, dtype=float), TRAJECTORY_DECIMALS).tolist()


def suite_text(suite: Suite) -> str:
    """The suite as JSON: the header indented, then one line per scenario."""
    head = {
        "format": FORMAT,
        "description": (
            "Held-out scenarios of ios_uav_env/IOSUAV-Random-v0: sample_scenario(default_rng(seed), ranges) "
            "drawn n times; per scenario its ScenarioConfig, the DP optimum (baselines.dp.solve at "
            "dp_resolution m) and the SCA plan (baselines.sca.solve, defaults). Rates (eq. (9), bps/Hz) and "
            "feasibility are those of the planners' trajectories; stored trajectories are rounded to 1e-3 m."
        ),
        "seed": suite.seed,
        "n": len(suite),
        "dp_resolution": suite.dp_resolution,
        "trajectory_decimals": TRAJECTORY_DECIMALS,
        "ranges": suite.ranges.to_dict(),
        "build": suite.meta,
    }
    lines = []
    for e in suite.entries:
        record = {
            "index": e.index,
            "config": e.config.to_dict(),
            "dp": {**e.dp, "trajectory": _rounded(e.dp["trajectory"])},
            "sca": {**e.sca, "trajectory": _rounded(e.sca["trajectory"])},
        }
        lines.append("  " + json.dumps(record, separators=(",", ":")))
    text = json.dumps(head, indent=1)
    return text[: text.rindex("}")].rstrip() + ',\n "scenarios": [\n' + ",\n".join(lines) + "\n ]\n}\n"


def build_suite(
    path: str | Path = SUITE_PATH,
    n: int = DEFAULT_SIZE,
    seed: int = HELDOUT_SEED,
    *,
    ranges: ScenarioRanges = DEFAULT_RANGES,
    dp_resolution: float = DP_RESOLUTION,
    jobs: int = 2,
    cache_dir: str | Path = CACHE_DIR,
    progress: bool = True,
    backend: str = "local",
    address: str | None = None,
) -> Suite:
    """Draw the suite, solve (or read from the cache) every scenario, write ``path`` atomically."""
    start = time.perf_counter()
    configs = suite_configs(n, seed, ranges)
    records = solve_all(configs, cache_dir, dp_resolution=dp_resolution, jobs=jobs, progress=progress,
                        backend=backend, address=address, desc="suite")  # fmt: skip
    bad = [f"#{i}: {p}" for i, r in enumerate(records) if (p := _problem({"index": i, "config": {}, **r}))]
    if bad:
        raise ValueError(f"solved scenarios cannot go into a suite: {'; '.join(bad)}")
    entries = [
        SuiteEntry(i, c, r["dp"], r["sca"]) for i, (c, r) in enumerate(zip(configs, records, strict=True))
    ]
    meta = {
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "jobs": int(jobs),
        **({"backend": backend} if backend != "local" else {}),
        "build_seconds": round(time.perf_counter() - start, 1),
        "cpu_count": os.cpu_count(),
        "load_average": [round(v, 2) for v in os.getloadavg()],
        "note": "planner seconds are wall times in worker processes on this machine, with its load",
    }
    suite = Suite(seed, ranges, entries, float(dp_resolution), meta)
    atomic_write_text(path, suite_text(suite))
    return suite


def _problem(rec: Any) -> str | None:
    """What is wrong with one scenario record of a suite file (None if nothing)."""
    if not isinstance(rec, dict):
        return f"not a JSON object but a {type(rec).__name__}"
    for key, fields in (
        ("dp", ("rate", "trajectory")),
        ("sca", ("rate", "feasible", "seconds", "trajectory")),
    ):
        if not isinstance(rec.get(key), dict):
            return f"no {key!r} record"
        missing = [f for f in fields if f not in rec[key]]
        if missing:
            return f"{key} has no {', '.join(map(repr, missing))}"
    if "config" not in rec or "index" not in rec:
        return "no 'config'" if "config" not in rec else "no 'index'"
    for key in ("dp", "sca"):
        rate = rec[key]["rate"]
        if isinstance(rate, bool) or not isinstance(rate, int | float) or not np.isfinite(rate):
            return f"{key} rate {rate!r} is not a finite number"
    if rec["dp"]["rate"] <= 0:
        return f"DP rate {rec['dp']['rate']!r} must be > 0 (the scores are % of it)"
    return None


def load_suite(path: str | Path = SUITE_PATH) -> Suite:
    """Read a suite file (trajectories as (N, 2) arrays); ``ValueError`` naming the file (and the
    scenario) if it is unreadable, has no scenarios, or a scenario lacks a key, has an invalid
    config or a non-finite or zero DP rate."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"no suite at {path}: build it with `python -m agents.suite build`")
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path} cannot be read: {exc}") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        found = data.get("format") if isinstance(data, dict) else None
        raise ValueError(f"{path} is not a suite file ({FORMAT!r}), its format is {found!r}")
    missing = [k for k in ("seed", "dp_resolution", "ranges", "scenarios") if k not in data]
    if missing:
        raise ValueError(f"{path}: no {', '.join(map(repr, missing))} in the suite file")
    if not isinstance(data["scenarios"], list) or not data["scenarios"]:
        raise ValueError(f"{path}: the suite has no scenarios")
    entries = []
    for i, rec in enumerate(data["scenarios"]):
        problem = _problem(rec)
        try:
            if problem is None:
                dp = {**rec["dp"], "trajectory": np.asarray(rec["dp"]["trajectory"], dtype=float)}
                sca = {**rec["sca"], "trajectory": np.asarray(rec["sca"]["trajectory"], dtype=float)}
                entries.append(SuiteEntry(int(rec["index"]), ScenarioConfig(**rec["config"]), dp, sca))
        except (TypeError, ValueError) as exc:
            problem = f"{type(exc).__name__}: {exc}"
        if problem is not None:
            name = rec.get("index", i) if isinstance(rec, dict) else i
            raise ValueError(f"{path}: scenario #{name}: {problem}")
    try:
        ranges = ScenarioRanges.from_dict(data["ranges"])
        return Suite(
            int(data["seed"]), ranges, entries, float(data["dp_resolution"]), dict(data.get("build", {}))
        )
    except (TypeError, ValueError, AttributeError) as exc:
        raise ValueError(f"{path}: bad suite header: {type(exc).__name__}: {exc}") from None


def summary(suite: Suite) -> dict[str, Any]:
    """Headline numbers of the suite: DP rates, SCA's % of DP, feasibility and times."""
    dp = np.array([e.dp_rate for e in suite])
    pct = np.array([e.sca_pct_dp for e in suite])
    surfaces = [e.config.surface for e in suite]
    return {
        "n": len(suite),
        "seed": suite.seed,
        "surfaces": {s: surfaces.count(s) for s in sorted(set(surfaces))},
        "T_range_s": [min(e.config.T for e in suite), max(e.config.T for e in suite)],
        "M_range": [min(e.config.M for e in suite), max(e.config.M for e in suite)],
        "dp_rate_mean": float(dp.mean()),
        "dp_rate_range": [float(dp.min()), float(dp.max())],
        "sca_pct_dp_mean": float(pct.mean()),
        "sca_pct_dp_range": [float(pct.min()), float(pct.max())],
        "sca_feasible": sum(bool(e.sca["feasible"]) for e in suite),
        "sca_seconds_median": float(np.median([e.sca["seconds"] for e in suite])),
        "dp_seconds_median": float(np.median([e.dp["seconds"] for e in suite])),
    }


def show_text(suite: Suite, path: Path | None = None, table: bool = False) -> str:
    """The printed summary of ``show`` (and, with ``table``, one line per scenario)."""
    s = summary(suite)
    size = f", {path.stat().st_size / 1024:.0f} KB" if path is not None and path.exists() else ""
    lines = [
        f"held-out suite{f' {path}' if path else ''}: {s['n']} scenarios, seed {s['seed']}{size}",
        f"  surfaces {s['surfaces']}, T {s['T_range_s'][0]:g}-{s['T_range_s'][1]:g} s, "
        f"M {s['M_range'][0]}-{s['M_range'][1]}",
        f"  DP ({suite.dp_resolution:g} m grid): mean rate {s['dp_rate_mean']:.4f} bps/Hz "
        f"(range {s['dp_rate_range'][0]:.4f}-{s['dp_rate_range'][1]:.4f}), "
        f"median {s['dp_seconds_median']:.2f} s",
        f"  SCA: {s['sca_pct_dp_mean']:.2f}% of DP on average (range {s['sca_pct_dp_range'][0]:.2f}-"
        f"{s['sca_pct_dp_range'][1]:.2f}%), feasible {s['sca_feasible']}/{s['n']}, "
        f"median {s['sca_seconds_median']:.2f} s",
    ]
    if suite.meta:
        lines.append(f"  built {suite.meta.get('created', '?')} in {suite.meta.get('build_seconds', '?')} s "
                     f"with {suite.meta.get('jobs', '?')} jobs")  # fmt: skip
    if table:
        lines.append(
            f"  {'#':>3} {'surf':4} {'T':>4} {'M':>5} {'G (m)':>15} "
            f"{'DP rate':>8} {'SCA %DP':>8} {'SCA s':>6}"
        )
        for e in suite:
            c = e.config
            lines.append(
                f"  {e.index:3d} {c.surface:4} {c.T:4g} {c.M:5d} "
                f"({c.ground_node[0]:6.1f},{c.ground_node[1]:6.1f}) "
                f"{e.dp_rate:8.4f} {e.sca_pct_dp:8.2f} {e.sca['seconds']:6.2f}"
            )
    return "\n".join(lines)
