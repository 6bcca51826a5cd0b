"""The multi-node sweep: ``python -m experiments multinode [--quick] [--out DIR] [--jobs N]``.

Two parts, every point solved by the planners of ``baselines`` and scored by
``ios_uav_env.maxmin_rate``:

* **rate vs T** on the default 3-node scenario (model.md) for T = 60..300 s: IA, RA, CUC
  (SCA inside BCD), the tour heuristic (IOS) and DP-IA, whose record carries the certified
  upper bound (``baselines.dp_bound``);
* **rate vs K** at T = 150 s for random node sets (K = 1..4, ``seeds`` sets per K, nodes
  uniform in [-250, 250] x [-150, 150] m, fixed seed): IA, the tour and DP-IA (bound).

Each point is cached as one JSON file (key: the scenario's dict, the scheme and the planner
settings), written atomically when it finishes, so an interrupted run resumes. Outputs in
``OUT``: ``multinode.csv``, ``fig_multinode_rate_vs_T.png``, ``fig_multinode_rate_vs_K.png``,
``fig_multinode_trajectories.png`` and ``claims_multinode.md`` (does IA hover on both sides
of the IOS, SCA >= tour, bound >= every plan). The full run writes to ``results/multinode``;
``--quick`` (M = 60, two T, K <= 3) writes to ``out/multinode-quick`` unless ``--out`` is given.
"""

from __future__ import annotations

import functools
import hashlib
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ios_uav_env import ScenarioConfig
from ios_uav_env.io import atomic_write_text

DEFAULT_NODES = ((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0))
CSV_COLUMNS = ("part", "scheme", "T", "K", "seed", "rate", "upper_bound", "feasible", "seconds")


@dataclass(frozen=True)
class MultiSpec:
    """What the multi-node sweep solves."""

    Ts: tuple[float, ...] = (60.0, 100.0, 150.0, 200.0, 250.0, 300.0)
    T_schemes: tuple[str, ...] = ("ia", "ra", "cuc", "tour", "dp-ia")
    Ks: tuple[int, ...] = (1, 2, 3, 4)
    seeds: int = 3
    K_T: float = 150.0
    K_schemes: tuple[str, ...] = ("ia", "tour", "dp-ia")
    dp_resolution: float = 5.0
    base: ScenarioConfig = ScenarioConfig()

    def points(self) -> list[dict[str, Any]]:
        """Every point: ``{"part", "scheme", "T", "K", "seed", "config"}`` (config as a dict)."""
        pts = []
        three = self.base.replace(ground_nodes=DEFAULT_NODES)
        for t in self.Ts:
            for scheme in self.T_schemes:
                pts.append({"part": "T", "scheme": scheme, "T": t, "K": 3, "seed": -1,
                            "config": three.replace(T=t).to_dict()})  # fmt: skip
        rng = np.random.default_rng(2026)
        for k in self.Ks:
            for seed in range(self.seeds):
                nodes = tuple(map(tuple, np.round(rng.uniform([-250, -150], [250, 150], (k, 2))).tolist()))
                config = self.base.replace(T=self.K_T, ground_nodes=nodes)
                for scheme in self.K_schemes:
                    pts.append({"part": "K", "scheme": scheme, "T": self.K_T, "K": k, "seed": seed,
                                "config": config.to_dict()})  # fmt: skip
        return pts

    def kwargs(self, scheme: str) -> dict[str, Any]:
        return {"resolution": self.dp_resolution} if scheme.startswith("dp") else {}

    def key(self, point: dict[str, Any]) -> str:
        blob = json.dumps([point["scheme"], point["config"], self.kwargs(point["scheme"])], sort_keys=True)
        return (
            f"{point['part']}_{point['scheme']}_T{point['T']:g}_K{point['K']}_s{point['seed']}_"
            + (hashlib.sha1(blob.encode()).hexdigest()[:10])
        )


QUICK = MultiSpec(Ts=(60.0, 100.0), Ks=(1, 2, 3), seeds=1, K_T=80.0, base=ScenarioConfig(ios_shape=(10, 6)))


def solve_point(point: dict[str, Any], spec: MultiSpec) -> dict[str, Any]:
    """Solve one point and return its record (trajectory and shares included)."""
    import warnings

    from baselines.schemes import run_scheme

    config = ScenarioConfig(**point["config"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        plan = run_scheme(point["scheme"], config, **spec.kwargs(point["scheme"]))
    return {**{k: v for k, v in point.items() if k != "config"}, "config": point["config"],
            "rate": plan.mean_rate, "upper_bound": plan.info.get("upper_bound"), "feasible": plan.feasible,
            "seconds": plan.seconds, "trajectory": plan.trajectory.tolist(),
            "shares": plan.info.get("shares")}  # fmt: skip


def run(
    spec: MultiSpec,
    cache_dir: Path,
    jobs: int | None = 1,
    *,
    backend: str = "local",
    address: str | None = None,
    progress: bool = False,
) -> list[dict[str, Any]]:
    """Solve every point missing from ``cache_dir`` and return all records in point order
    (``baselines.runner.run_tasks``: ``jobs`` spawned processes, this one for ``jobs=1``; or Ray
    tasks with ``backend="ray"``, on the cluster at ``address``; the same cache files)."""
    from baselines.runner import run_tasks

    return run_tasks(
        functools.partial(solve_point, spec=spec), spec.points(), cache_dir, key=spec.key, jobs=jobs,
        backend=backend, address=address, progress=progress, desc="multinode", unit="solve",
    )  # fmt: skip


def write_csv(records: Sequence[dict[str, Any]], path: Path) -> Path:
    lines = [",".join(CSV_COLUMNS)]
    for r in records:
        ub = "" if r["upper_bound"] is None else f"{r['upper_bound']:.8f}"
        lines.append(f"{r['part']},{r['scheme']},{r['T']:g},{r['K']},{r['seed']},{r['rate']:.8f},{ub},"
                     f"{int(bool(r['feasible']))},{r['seconds']:.3f}")  # fmt: skip
    return atomic_write_text(path, "\n".join(lines) + "\n")


def hover_sides(config: ScenarioConfig, trajectory: np.ndarray, shares: np.ndarray) -> dict[str, int]:
    """Hover slots (move < 0.2 D) with x < x_c and x > x_c, and those serving (largest share)
    a node on the other side of the plane (by transmission)."""
    q = np.asarray(trajectory, dtype=float)
    slow = np.r_[False, np.linalg.norm(np.diff(q, axis=0), axis=1) < 0.2 * config.D]
    dx = q[:, 0] - config.ios_center[0]
    node_x = (
        np.array([n[0] for n in config.nodes])[np.argmax(np.asarray(shares), axis=0)] - config.ios_center[0]
    )
    return {"x<x_c": int(np.sum(slow & (dx < 0))), "x>x_c": int(np.sum(slow & (dx > 0))),
            "transmitting": int(np.sum(slow & (dx * node_x < 0)))}  # fmt: skip


def claims(records: Sequence[dict[str, Any]]) -> str:
    """Markdown: IA hovering on both sides of the IOS, SCA vs tour, bound vs every plan."""
    lines = ["# Several ground nodes: claims checked", ""]
    by = {(r["part"], r["scheme"], r["T"], r["K"], r["seed"]): r for r in records}
    for r in records:
        if r["part"] == "T" and r["scheme"] == "ia":
            config = ScenarioConfig(**r["config"])
            sides = hover_sides(config, np.array(r["trajectory"]), np.array(r["shares"]))
            both = sides["x<x_c"] > 0 and sides["x>x_c"] > 0
            verdict = "yes" if both else "no"
            lines.append(
                f"- T = {r['T']:g} s: IA hovers on both sides of the IOS: **{verdict}** (hover slots "
                f"x < x_c: {sides['x<x_c']}, x > x_c: {sides['x>x_c']}; serving a node across the plane: "
                f"{sides['transmitting']})"
            )
    for r in records:
        tour = by.get((r["part"], "tour", r["T"], r["K"], r["seed"]))
        if r["scheme"] == "ia" and tour is not None and r["rate"] < tour["rate"] - 1e-12:
            lines.append(f"- SCA below the tour: {r['part']} T={r['T']:g} K={r['K']} seed={r['seed']}")
    bad = []
    for r in records:
        if r["upper_bound"] is None:
            continue
        where = (r["part"], r["T"], r["K"], r["seed"])
        same = [s["rate"] for s in records if (s["part"], s["T"], s["K"], s["seed"]) == where
                and s["scheme"] in ("ia", "tour", "dp-ia")]  # fmt: skip
        best = max(same)
        if best > r["upper_bound"]:
            bad.append(r)
    lines.append(f"- certified bound >= every IOS plan at every point: **{'yes' if not bad else 'NO'}**")
    return "\n".join(lines) + "\n"


def make_figures(records: Sequence[dict[str, Any]], out: Path) -> list[Path]:
    """Rate vs T (schemes and bound), rate vs K (mean over seeds), trajectories at the middle T."""
    from matplotlib.figure import Figure

    from ios_uav_env.io import save_figure
    from ios_uav_env.plotting import plot_multinode_map, plot_served_trajectories

    paths = []
    fig = Figure(figsize=(7, 4.2), layout="constrained")
    ax = fig.add_subplot()
    part = [r for r in records if r["part"] == "T"]
    for scheme in dict.fromkeys(r["scheme"] for r in part):
        rows = sorted((r for r in part if r["scheme"] == scheme), key=lambda r: r["T"])
        ax.plot([r["T"] for r in rows], [r["rate"] for r in rows], marker="o", label=scheme)
        if scheme == "dp-ia":
            ax.plot(
                [r["T"] for r in rows], [r["upper_bound"] for r in rows], "k--", label="upper bound (IOS)"
            )
    ax.set(xlabel="T (s)", ylabel="max-min rate (bps/Hz)", title="default 3-node scenario")
    ax.legend(fontsize=8)
    paths.append(save_figure(fig, out / "fig_multinode_rate_vs_T.png", dpi=120))
    fig = Figure(figsize=(7, 4.2), layout="constrained")
    ax = fig.add_subplot()
    part = [r for r in records if r["part"] == "K"]
    for scheme in dict.fromkeys(r["scheme"] for r in part):
        ks = sorted({r["K"] for r in part})
        mean = [np.mean([r["rate"] for r in part if r["K"] == k and r["scheme"] == scheme]) for k in ks]
        ax.plot(ks, mean, marker="o", label=scheme)
    ks = sorted({r["K"] for r in part})
    bounds = [[r["upper_bound"] for r in part if r["K"] == k and r["upper_bound"] is not None] for k in ks]
    ax.plot(ks, [np.mean(b) if b else np.nan for b in bounds], "k--", label="upper bound (K > 1)")
    ax.set(xlabel="K (nodes)", ylabel="mean max-min rate (bps/Hz)", title="random node sets")
    ax.legend(fontsize=8)
    paths.append(save_figure(fig, out / "fig_multinode_rate_vs_K.png", dpi=120))
    ts = sorted({r["T"] for r in records if r["part"] == "T"})
    t_mid = ts[len(ts) // 2] if ts else None
    rows = [r for r in records if r["part"] == "T" and r["T"] == t_mid and r["scheme"] in ("ia", "tour")]
    if rows:
        config = ScenarioConfig(**rows[0]["config"])
        fig = Figure(figsize=(10, 5.5), layout="constrained")
        ax = fig.add_subplot()
        plot_multinode_map(ax, config)
        labels = {f"{r['scheme']}: {r['rate']:.3f}": np.array(r["trajectory"]) for r in rows}
        shares = {f"{r['scheme']}: {r['rate']:.3f}": np.array(r["shares"]) for r in rows}
        plot_served_trajectories(ax, config, labels, shares)
        paths.append(save_figure(fig, out / "fig_multinode_trajectories.png", dpi=120))
    return paths
