"""Benchmark of the planners: DP optimum vs the paper's schemes, and how they scale with N.

Usage
-----
``python benchmarks/planners.py``                       default scenario (T = 150 s, M = 6000)
``python benchmarks/planners.py --no-sca``              DP and the fixed trajectory only
``python benchmarks/planners.py --sweep-T 50 100 150 200 250 300``   gap and times vs N

The first table gives every scheme's average rate, its share of the IOS optimum (DP with
the IOS) and of the DP optimum with the scheme's own surface (its optimality gap), its
feasibility and wall time. SCA rows appear when ``baselines/sca.py`` (and cvxpy) exist.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from baselines.plan import Plan  # noqa: E402
from baselines.schemes import get_scheme, run_scheme, sca_unavailable_reason  # noqa: E402
from ios_uav_env import ScenarioConfig  # noqa: E402

SCHEMES = ("ia", "ra", "ia-ft", "cuc")
DP_OF_SURFACE = {"ios": "dp-ia", "ris": "dp-ra", "none": "dp-cuc"}


def _run(name: str, config: ScenarioConfig, resolution: float) -> Plan | str:
    """The plan of scheme ``name`` or the reason it could not run."""
    scheme = get_scheme(name)
    if scheme.planner == "sca" and (reason := sca_unavailable_reason()) is not None:
        return f"unavailable: {reason}"
    kwargs = {"resolution": resolution} if scheme.planner == "dp" else {}
    try:
        return run_scheme(name, config, **kwargs)
    except Exception as exc:  # a benchmark reports failures instead of stopping
        return f"failed: {type(exc).__name__}: {exc}"


def scheme_table(config: ScenarioConfig, resolution: float, sca: bool = True) -> None:
    """Print DP (each surface) and every scheme: rate, % of DP, feasibility, seconds."""
    print(f"Default scenario: T = {config.T:g} s, N = {config.N}, M = {config.M}, DP at {resolution:g} m")
    dps = {surface: _run(name, config, resolution) for surface, name in DP_OF_SURFACE.items()}
    head = (
        f"{'scheme':>7} {'rate (bps/Hz)':>14} {'% DP-IOS':>9} {'% DP same':>10} {'feasible':>9} "
        f"{'seconds':>8}"
    )
    print(head)
    print("-" * len(head))
    ios_opt = dps["ios"].mean_rate if isinstance(dps["ios"], Plan) else float("nan")
    for name in (*DP_OF_SURFACE.values(), *SCHEMES):
        if name in DP_OF_SURFACE.values():
            plan = dps[get_scheme(name).surface]
        elif get_scheme(name).planner == "sca" and not sca:
            continue
        else:
            plan = _run(name, config, resolution)
        if not isinstance(plan, Plan):
            print(f"{name:>7} {plan}")
            continue
        same = dps[plan.config.surface]
        same_pct = 100 * plan.mean_rate / same.mean_rate if isinstance(same, Plan) else float("nan")
        print(
            f"{name:>7} {plan.mean_rate:14.6f} {100 * plan.mean_rate / ios_opt:8.2f}% {same_pct:9.2f}% "
            f"{'yes' if plan.feasible else 'NO':>9} {plan.seconds:8.2f}",
            flush=True,
        )


def sweep_table(config: ScenarioConfig, horizons: list[float], resolution: float, sca: bool = True) -> None:
    """Print, per horizon T, DP and SCA (IA) rates and times, and the SCA-to-DP gap."""
    print(f"\nSweep over T (IOS, M = {config.M}, DP at {resolution:g} m)")
    head = (
        f"{'T (s)':>6} {'N':>4} {'DP rate':>9} {'DP s':>7} {'IA rate':>9} {'IA s':>7} "
        f"{'gap %':>7} {'IA-FT rate':>11}"
    )
    print(head)
    print("-" * len(head))
    for horizon in horizons:
        try:
            cfg = config.replace(T=horizon, surface="ios")
        except ValueError as exc:
            print(f"{horizon:6g} skipped: {exc}")
            continue
        dp, ft = _run("dp", cfg, resolution), _run("ia-ft", cfg, resolution)
        ia = _run("ia", cfg, resolution) if sca else "skipped (--no-sca)"
        dp_txt = f"{dp.mean_rate:9.4f} {dp.seconds:7.2f}" if isinstance(dp, Plan) else f"{'-':>9} {'-':>7}"
        if isinstance(ia, Plan):
            gap = 100 * (dp.mean_rate - ia.mean_rate) / dp.mean_rate if isinstance(dp, Plan) else float("nan")
            ia_txt = f"{ia.mean_rate:9.4f} {ia.seconds:7.2f} {gap:7.3f}"
        else:
            ia_txt = f"{'-':>9} {'-':>7} {'-':>7}"
        ft_txt = f"{ft.mean_rate:11.4f}" if isinstance(ft, Plan) else f"{'-':>11}"
        print(f"{horizon:6g} {cfg.N:4d} {dp_txt} {ia_txt} {ft_txt}", flush=True)
        for label, res in (("DP", dp), ("IA", ia)):
            if not isinstance(res, Plan) and not res.startswith("skipped"):
                print(f"       {label}: {res}")
    print(
        "gap % = 100 (DP - IA) / DP. DP is the optimum over grid paths (way-points on the grid,\n"
        "moves = grid offsets), a lower bound that rises as the resolution shrinks; SCA moves\n"
        "freely, so a negative gap means SCA beat the grid, not that DP is wrong."
    )


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; return the exit status."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--T", type=float, default=150.0, help="horizon of the scheme table (s)")
    p.add_argument("--M", type=int, default=6000, help="IOS elements, a multiple of 100")
    p.add_argument("--resolution", type=float, default=2.5, help="DP grid spacing (m)")
    p.add_argument("--sweep-T", type=float, nargs="+", metavar="T", help="horizons (s) of the sweep")
    p.add_argument("--no-sca", action="store_true", help="skip the SCA schemes")
    p.add_argument("--no-table", action="store_true", help="only the sweep")
    args = p.parse_args(argv)
    if args.M <= 0 or args.M % 100:
        p.error(f"argument --M: must be a positive multiple of 100, got {args.M}")
    try:
        config = ScenarioConfig(T=args.T, ios_shape=(100, args.M // 100))
    except ValueError as exc:
        p.error(str(exc))
    if not 0 < args.resolution <= config.D:
        p.error(f"argument --resolution: must be in (0, D={config.D:g}] m, got {args.resolution:g}")
    sca = not args.no_sca
    if sca and (reason := sca_unavailable_reason()) is not None:
        print(f"note: SCA schemes skipped: {reason}")
        sca = False
    t0 = time.perf_counter()
    if not args.no_table:
        scheme_table(config, args.resolution, sca)
    if args.sweep_T:
        sweep_table(config, args.sweep_T, args.resolution, sca)
    print(f"\ntotal {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
