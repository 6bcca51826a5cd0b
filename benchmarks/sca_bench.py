"""Benchmark of the SCA planner (``baselines.sca``) against the DP optimum.

Usage
-----
``python benchmarks/sca_bench.py``                      everything below, default scenario
``python benchmarks/sca_bench.py --quick``              section 1 only
``python benchmarks/sca_bench.py --sweep-T 50 100 150 200 250 300 --surfaces ios ris none``
``python benchmarks/sca_bench.py --json out.json``      also write the numbers as JSON

Sections
1. IA / RA / CUC on the default scenario (T = 150 s, M = 6000): DP at 2.5 m, SCA with its
   default multi-start (cold: the surrogate's compilation is included), share of the DP
   optimum, feasibility, seconds; then SCA started at the DP plan ("DP + SCA polish"): how
   much the off-grid optimum beats the grid.
2. Hovering on the transmissive side: IA from a fly-hover-fly to the best point behind the IOS.
3. Tiles 1..4: tiling error (zeta, rate) on the converged trajectory and on a map, final
   rate, seconds per iteration.
4. Solvers (Clarabel vs SCS) and DPP (compile once) vs rebuilding the problem every iteration.
5. The sweep over T (N = T / dt): DP vs SCA rates and times.
Timings are wall-clock: on a shared machine expect noise of tens of per cent (results/log.md).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

if __package__ in (None, ""):  # run as a script: make the repository importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from baselines import dp, sca  # noqa: E402
from baselines.fixed import fly_hover_fly  # noqa: E402
from baselines.sca_problem import tiled_config  # noqa: E402
from ios_uav_env import ScenarioConfig  # noqa: E402
from ios_uav_env.model import channel as ch

NAMES = {"ios": "IA", "ris": "RA", "none": "CUC"}


def _cold_solve(config: ScenarioConfig, **kwargs: Any):
    sca._CACHE.clear()  # include the surrogate's compilation in the time
    t0 = time.perf_counter()
    plan = sca.solve(config, **kwargs)
    return plan, time.perf_counter() - t0


def _hover_points(q: np.ndarray) -> np.ndarray:
    return q[:-1][np.linalg.norm(np.diff(q, axis=0), axis=1) < 1.0]


def default_scenario(out: dict[str, Any], surfaces: list[str]) -> None:
    print("\n== 1. default scenario (T = 150 s, M = 6000): SCA vs DP at 2.5 m ==")
    print(f"{'scheme':6} {'DP rate':>10} {'DP s':>6} {'SCA rate':>10} {'% of DP':>9} {'SCA s':>6} "
          f"{'compile s':>9} {'iters':>5} {'feasible':>8} {'worst viol m':>12}  winner")  # fmt: skip
    rows = []
    for surface in surfaces:
        config = ScenarioConfig(surface=surface)
        t0 = time.perf_counter()
        ref = dp.solve(config, resolution=2.5)
        t_dp = time.perf_counter() - t0
        plan, t_sca = _cold_solve(config)
        polish = sca.solve(config, init=ref)
        row = {
            "scheme": NAMES[surface], "dp_rate": ref.mean_rate, "dp_seconds": t_dp,
            "sca_rate": plan.mean_rate, "percent_of_dp": 100 * plan.mean_rate / ref.mean_rate,
            "sca_seconds": t_sca, "compile_seconds": plan.info["compile_seconds"],
            "n_iters": plan.info["n_iters"], "feasible": plan.feasible,
            "worst_violation_m": plan.report.worst_violation, "winner": plan.info["start"],
            "starts": plan.info["starts"], "tiling_error": plan.info["tiling_error"],
            "polish_rate": polish.mean_rate, "polish_gain_over_dp": polish.mean_rate - ref.mean_rate,
            "polish_iters": polish.info["n_iters"],
        }  # fmt: skip
        rows.append(row)
        print(f"{row['scheme']:6} {ref.mean_rate:10.6f} {t_dp:6.2f} {plan.mean_rate:10.6f} "
              f"{row['percent_of_dp']:8.3f}% {t_sca:6.2f} {row['compile_seconds']:9.2f} {row['n_iters']:5d} "
              f"{plan.feasible!s:>8} {plan.report.worst_violation:12.2e}  {plan.info['start']}")  # fmt: skip
    for row in rows:
        print(f"  {row['scheme']}: starts " + ", ".join(
            f"{s['start']} {s['init_rate']:.4f}->{s['mean_rate']:.6f} ({s['iters']} it, {s['seconds']:.2f} s)"
            for s in row["starts"]))  # fmt: skip
        gain = row["polish_gain_over_dp"]
        print(f"  {row['scheme']}: DP(2.5 m) + SCA polish {row['polish_rate']:.6f} = DP + "
              f"{gain:.6f} bps/Hz ({100 * gain / row['dp_rate']:.3f}%), "
              f"{row['polish_iters']} iterations")  # fmt: skip
    out["default"] = rows


def transmissive_hover(out: dict[str, Any]) -> None:
    print("\n== 2. IA hovering on the transmissive side (G at x = -100, IOS plane x = 0) ==")
    config = ScenarioConfig()
    point = sca.best_hover_points(config)["behind"]
    init = fly_hover_fly(config, point)
    plan = sca.solve(config, init=init)
    hover = _hover_points(plan.trajectory)
    sides = ch.side_factor(config, hover[:, 0])
    res = {
        "init_hover": list(point), "init_rate": init.mean_rate, "rate": plan.mean_rate,
        "n_hover_slots": len(hover), "hover_mean": hover.mean(axis=0).tolist(),
        "hover_x_range": [float(hover[:, 0].min()), float(hover[:, 0].max())],
        "all_transmissive": bool(np.all(sides == config.epsilon)), "iters": plan.info["n_iters"],
    }  # fmt: skip
    print(f"start: fly-hover-fly to {point} ({init.mean_rate:.6f} bps/Hz) -> SCA {plan.mean_rate:.6f} bps/Hz "
          f"in {res['iters']} iterations; {len(hover)} hover slots at mean "
          f"({res['hover_mean'][0]:.2f}, {res['hover_mean'][1]:.2f}) m, x in "
          f"[{res['hover_x_range'][0]:.2f}, {res['hover_x_range'][1]:.2f}], all with side factor epsilon: "
          f"{res['all_transmissive']}")  # fmt: skip
    out["transmissive_hover"] = res


def tiling(out: dict[str, Any]) -> None:
    print("\n== 3. tiles: error against the exact model and cost (IA, start: fly-hover-fly behind) ==")
    config = ScenarioConfig()
    init = fly_hover_fly(config, sca.best_hover_points(config)["behind"])
    xs, ys = np.meshgrid(np.arange(-400, 401, 5.0), np.arange(-200, 201, 5.0))
    grid = np.column_stack([xs.ravel(), ys.ravel()])
    z_exact = ch.zeta(config, grid)
    z_elements = ch.zeta(config.replace(quadrature_nodes=0), init.trajectory)
    print(f"(the config's own model, 8 x 8 nodes, vs the 6000 elements on the start: "
          f"{np.max(np.abs(ch.zeta(config, init.trajectory) - z_elements) / z_elements):.1e})")  # fmt: skip
    print(f"{'tiles':>5} {'map zeta err':>12} {'traj zeta err':>13} {'traj rate err':>13} {'SCA rate':>10} "
          f"{'iters':>5} {'s/iter':>7} {'compile s':>9}")  # fmt: skip
    rows = []
    for tiles in (1, 2, 3, 4):
        plan, _ = _cold_solve(config, init=init, tiles=tiles)
        map_err = float(np.max(np.abs(ch.zeta(tiled_config(config, tiles), grid) - z_exact) / z_exact))
        err = plan.info["tiling_error"]
        per_iter = float(np.median([h["seconds"] for h in plan.history if h["iteration"] > 1] or [np.nan]))
        row = {"tiles": tiles, "map_zeta_max_rel": map_err, **err, "rate": plan.mean_rate,
               "iters": plan.info["n_iters"], "seconds_per_iter": per_iter,
               "compile_seconds": plan.info["compile_seconds"]}  # fmt: skip
        rows.append(row)
        print(f"{tiles:5d} {map_err:12.2e} {err['zeta_max_rel']:13.2e} {err['rate_rel']:13.2e} "
              f"{plan.mean_rate:10.6f} {row['iters']:5d} {per_iter:7.3f} "
              f"{row['compile_seconds']:9.2f}")  # fmt: skip
    out["tiles"] = rows


def solvers_and_dpp(out: dict[str, Any]) -> None:
    print("\n== 4. solver and DPP (IA, start: fly-hover-fly behind) ==")
    config = ScenarioConfig()
    init = fly_hover_fly(config, sca.best_hover_points(config)["behind"])
    rows = []
    for solver, dpp, max_iters in (("CLARABEL", True, 50), ("CLARABEL", False, 50), ("SCS", True, 3)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            plan, total = _cold_solve(config, init=init, solver=solver, dpp=dpp, max_iters=max_iters)
        solves = [h for h in plan.history if h["iteration"] > 0]
        later = [h["seconds"] for h in solves[1:]]
        row = {
            "solver": solver, "dpp": dpp, "rate": plan.mean_rate, "iters": len(solves),
            "total_seconds": total,
            "first_solve_seconds": solves[0]["seconds"] if solves else None,
            "median_later_solve_seconds": float(np.median(later)) if later else None,
            "median_solver_seconds": float(np.median([h["solver_seconds"] for h in solves])),
            "statuses": sorted({h["status"] for h in solves}), "feasible": plan.feasible,
            "worst_violation_m": plan.report.worst_violation,
        }  # fmt: skip
        rows.append(row)
        later_s = (
            "-" if row["median_later_solve_seconds"] is None else f"{row['median_later_solve_seconds']:.3f}"
        )
        print(f"{solver:8} dpp={dpp!s:5} rate {plan.mean_rate:.6f}  {len(solves):2d} solves  "
              f"total {total:5.2f} s  "
              f"first {row['first_solve_seconds']:.3f} s  later (median) {later_s} s  "
              f"solver (median) {row['median_solver_seconds']:.3f} s  plan feasible {plan.feasible}  "
              f"{row['statuses']}")  # fmt: skip
    out["solvers"] = rows


def sweep(out: dict[str, Any], horizons: list[float], surfaces: list[str]) -> None:
    print("\n== 5. sweep over T (N = T slots): SCA vs DP at 2.5 m ==")
    print(f"{'scheme':6} {'T':>5} {'DP rate':>10} {'DP s':>6} {'SCA rate':>10} {'% of DP':>9} {'SCA s':>6} "
          f"{'iters':>5}  winner")  # fmt: skip
    rows = []
    for surface in surfaces:
        for horizon in horizons:
            config = ScenarioConfig(surface=surface, T=horizon)
            t0 = time.perf_counter()
            ref = dp.solve(config, resolution=2.5)
            t_dp = time.perf_counter() - t0
            plan, t_sca = _cold_solve(config)
            row = {"scheme": NAMES[surface], "T": horizon, "dp_rate": ref.mean_rate, "dp_seconds": t_dp,
                   "sca_rate": plan.mean_rate, "percent_of_dp": 100 * plan.mean_rate / ref.mean_rate,
                   "sca_seconds": t_sca, "n_iters": plan.info["n_iters"], "feasible": plan.feasible,
                   "winner": plan.info["start"]}  # fmt: skip
            rows.append(row)
            print(f"{row['scheme']:6} {horizon:5g} {ref.mean_rate:10.6f} {t_dp:6.2f} {plan.mean_rate:10.6f} "
                  f"{row['percent_of_dp']:8.3f}% {t_sca:6.2f} {row['n_iters']:5d}  {row['winner']}"
                  + ("" if plan.feasible else "  INFEASIBLE"))  # fmt: skip
    out["sweep"] = rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="section 1 only")
    parser.add_argument(
        "--surfaces", nargs="+", default=["ios", "ris", "none"], choices=["ios", "ris", "none"]
    )
    parser.add_argument("--sweep-T", nargs="*", type=float, default=[50, 100, 150, 200, 250, 300])
    parser.add_argument("--json", type=Path, help="write the numbers to this JSON file")
    args = parser.parse_args(argv)
    out: dict[str, Any] = {}
    default_scenario(out, args.surfaces)
    if not args.quick:
        transmissive_hover(out)
        tiling(out)
        solvers_and_dpp(out)
        if args.sweep_T:
            sweep(out, args.sweep_T, args.surfaces)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(out, indent=1, default=float))
        print(f"\nwrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
