"""The sweep behind the paper's figures: points, parallel solves, a resumable cache.

A point is one (scheme, T, M) solve on the default scenario with T and M replaced
(M = 100 x M_z, as in the paper's sweeps). Every point is solved by the planners of
``baselines`` (SCA for ia / ra / cuc, fly-hover-fly for ia-ft, DP for dp-*), scored by
``ios_uav_env.average_rate`` and cached as one JSON file per point by
``baselines.runner.run_tasks`` (parallel, written atomically as soon as it finishes): an
interrupted run resumes where it stopped. The cache key includes the base scenario and the
planner settings, so changing them re-solves; a cached record that is unreadable, lacks a key
of :data:`RECORD_KEYS` or holds a non-finite number is solved again (with a warning naming
its file).
"""

from __future__ import annotations

import functools
import hashlib
import json
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from baselines.runner import run_tasks
from ios_uav_env import ScenarioConfig
from ios_uav_env.io import atomic_write_text

#: The DP scheme that gives the optimum of each scheme's surface (for "% of DP").
DP_OF = {
    "ia": "dp-ia",
    "ia-ft": "dp-ia",
    "ra": "dp-ra",
    "cuc": "dp-cuc",
    "dp-ia": "dp-ia",
    "dp-ra": "dp-ra",
    "dp-cuc": "dp-cuc",
}
PAPER_SCHEMES = ("ia", "ra", "ia-ft", "cuc")
CSV_COLUMNS = ("scheme", "T", "M", "average_rate", "pct_of_dp", "feasible", "seconds")
#: The keys of a point's record (a cached record without one of them is solved again).
RECORD_KEYS = ("scheme", "T", "M", "average_rate", "feasible", "worst_violation", "seconds", "trajectory")


@dataclass(frozen=True)
class Point:
    """One solve of the sweep."""

    scheme: str  # a name of baselines.schemes.SCHEMES
    T: float  # s
    M: int  # elements, M = 100 x M_z

    def config(self, base: ScenarioConfig) -> ScenarioConfig:
        if self.M % base.ios_shape[0]:
            raise ValueError(f"M must be a multiple of M_y = {base.ios_shape[0]}, got {self.M}")
        return base.replace(T=float(self.T), ios_shape=(base.ios_shape[0], self.M // base.ios_shape[0]))

    @property
    def name(self) -> str:
        return f"{self.scheme}_T{self.T:g}_M{self.M}"


@dataclass(frozen=True)
class SweepSpec:
    """What to solve: the T grid, the M values and the planner settings."""

    # s, the paper's T axis (40 to 200 s), with T = 150 s of the trajectory panels
    Ts: tuple[float, ...] = tuple(sorted({*(float(t) for t in range(40, 201, 20)), 150.0}))
    Ms: tuple[int, ...] = (2000, 4000, 6000)  # the paper's Fig. 2 element counts
    M_schemes: int = 6000  # M of Fig. 1 (all schemes)
    dp_resolution: float = 2.5  # m, DP grid
    base: ScenarioConfig = ScenarioConfig()

    def points(self) -> list[Point]:
        """Fig. 1: every scheme and DP at M_schemes; Fig. 2: IA and DP-IA at every M."""
        pts: list[Point] = []
        for T in self.Ts:
            for scheme in (*PAPER_SCHEMES, "dp-ia", "dp-ra", "dp-cuc"):
                pts.append(Point(scheme, T, self.M_schemes))
            for M in self.Ms:
                if M != self.M_schemes:
                    pts += [Point("ia", T, M), Point("dp-ia", T, M)]
        return pts

    def planner_kwargs(self, scheme: str) -> dict[str, Any]:
        return {"resolution": self.dp_resolution} if scheme.startswith("dp") else {}

    def cache_key(self, point: Point) -> str:
        blob = json.dumps(
            [point.name, self.base.to_dict(), self.planner_kwargs(point.scheme)], sort_keys=True
        )
        return f"{point.name}_{hashlib.sha1(blob.encode()).hexdigest()[:10]}"


def solve_point(point: Point, spec: SweepSpec) -> dict[str, Any]:
    """Solve one point (in a worker process) and return its record."""
    import warnings

    from baselines.schemes import run_scheme

    with warnings.catch_warnings():  # an SCA start that stopped early is recorded in "status" instead
        warnings.simplefilter("ignore", RuntimeWarning)
        plan = run_scheme(point.scheme, point.config(spec.base), **spec.planner_kwargs(point.scheme))
    return {
        "status": plan.info.get("status", "ok"),
        "scheme": point.scheme,
        "T": point.T,
        "M": point.M,
        "average_rate": plan.mean_rate,
        "feasible": plan.feasible,
        "worst_violation": plan.report.worst_violation,
        "seconds": plan.seconds,
        "trajectory": plan.trajectory.tolist(),
    }


def solve_order(point: Point) -> tuple[bool, bool, float, int]:
    """Sort key of the points to solve: the slowest first (SCA on the IOS at large T, then the
    other SCA schemes, DP last), so that the worker pool ends evenly."""
    return (point.scheme != "ia", point.scheme.startswith("dp"), -point.T, -point.M)


def run_sweep(
    spec: SweepSpec,
    cache_dir: str | Path,
    *,
    jobs: int | None = None,
    progress: bool = True,
    points: Iterable[Point] | None = None,
    backend: str = "local",
    address: str | None = None,
) -> list[dict[str, Any]]:
    """Solve every point not yet in ``cache_dir`` (in parallel over ``jobs`` processes, default
    all cores; ``baselines.runner.run_tasks``) and return all records, cached ones included,
    in the order of ``spec.points()`` (or ``points``). ``backend="ray"`` solves them as Ray
    tasks (on the cluster at ``address``, default a local Ray): the same records and cache."""
    todo = list(spec.points() if points is None else points)
    return run_tasks(
        functools.partial(solve_point, spec=spec),
        todo,
        cache_dir,
        key=spec.cache_key,
        jobs=jobs,
        backend=backend,
        address=address,
        order=solve_order,
        progress=progress,
        desc="sweep",
        unit="solve",
        describe=lambda i, record: f"{todo[i].name}: {record['average_rate']:.4f}",
        required=RECORD_KEYS,
    )


def with_pct_of_dp(records: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Add ``pct_of_dp``: each rate as % of the DP optimum of its surface at the same (T, M)."""
    dp = {(r["scheme"], r["T"], r["M"]): r["average_rate"] for r in records if r["scheme"].startswith("dp")}
    out = []
    for r in records:
        ref = dp.get((DP_OF.get(r["scheme"], ""), r["T"], r["M"]))
        out.append({**r, "pct_of_dp": 100.0 * r["average_rate"] / ref if ref else float("nan")})
    return out


def write_csv(records: Sequence[dict[str, Any]], path: str | Path) -> Path:
    """One row per point: scheme, T, M, average rate, % of DP, feasible, seconds."""
    lines = [",".join(CSV_COLUMNS)]
    for r in records:
        lines.append(
            f"{r['scheme']},{r['T']:g},{r['M']},{r['average_rate']:.8f},{r['pct_of_dp']:.4f},"
            f"{int(bool(r['feasible']))},{r['seconds']:.3f}"
        )
    return atomic_write_text(path, "\n".join(lines) + "\n")
