"""``python -m experiments figures``: the paper's sweeps and figures under ``results/``.

    python -m experiments figures --overwrite             # regenerate the shipped results/
    python -m experiments figures --quick                 # a tiny sweep into out/figures-quick
    python -m experiments figures [--quick] [--jobs N] [--out DIR] [--no-agents]
    python -m experiments multinode [--quick] [--jobs N] [--out DIR]   (see experiments.multinode)
    python -m experiments energy [--quick] [--jobs N] [--out DIR] [--overwrite]   (experiments.energy)

The shipped ``results/`` is replaced only with ``--overwrite`` (the full sweep's default
``--out`` is ``results``, ``--quick``'s is ``out/figures-quick``). Solves every point of
:class:`experiments.sweep.SweepSpec` in parallel (a progress bar; finished points are
cached under ``OUT/cache`` so an interrupted run resumes), then writes ``OUT/sweep.csv``
(scheme, T, M, average rate, % of DP, feasible, seconds), the PNG panels and
``OUT/claims.md`` (the paper's qualitative claims checked with the numbers). SIGINT or
SIGTERM stops the worker processes and keeps the finished points in the cache (exit status
130 or 143); running the command again resumes. ``--backend ray [--address HOST:PORT]``
solves the points as Ray tasks (a local Ray, or a cluster; the ``ray`` extra), with the same
cache and CSV (docs/scale-out.md).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from baselines.ray_backend import add_backend_arguments, check_backend_arguments
from baselines.runner import check_writable
from experiments.figures import check_claims, make_figures, write_claims
from experiments.sweep import SweepSpec, run_sweep, with_pct_of_dp, write_csv
from ios_uav_env import ScenarioConfig
from ios_uav_env.io import atomic_write_text

QUICK = SweepSpec(Ts=(40.0, 60.0), Ms=(200, 400), M_schemes=400, dp_resolution=5.0)
#: The shipped results (replaced only with --overwrite) and the default folder of --quick.
RESULTS_DIR = Path(__file__).resolve().parents[1] / "results"
QUICK_OUT = Path("out/figures-quick")


def agent_trajectories(spec: SweepSpec) -> dict[str, np.ndarray]:
    """Deterministic trajectories of the shipped RL agents on Fig. 1(a)'s scenario (the one
    they were trained on: T = 150 s, M = 6000); {} if that scenario is not in the sweep or
    the agents (SB3, torch) are not installed."""
    t = 150.0 if 150.0 in spec.Ts else max(spec.Ts)
    config = spec.base.replace(
        T=t, ios_shape=(spec.base.ios_shape[0], spec.M_schemes // spec.base.ios_shape[0])
    )
    if config != ScenarioConfig():
        return {}  # the shipped agents' scenario does not apply
    from agents.evaluate import shipped_agents
    from agents.rollout import rollout

    try:
        agents = shipped_agents()
    except ImportError:  # no stable-baselines3 / torch here
        return {}
    return {f"RL: {agent.name}": rollout(agent, config).trajectory for agent in agents}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m experiments",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="command", required=True)
    fig = sub.add_parser("figures", help="run the sweeps and write the CSV, the figures and claims.md")
    fig.add_argument("--out", type=Path, default=None,
                     help="output folder (default: results, or out/figures-quick with --quick)")  # fmt: skip
    fig.add_argument("--overwrite", action="store_true", help="allow replacing the shipped results/")
    fig.add_argument("--jobs", type=int, default=None, help="worker processes (default: all cores)")
    fig.add_argument("--quick", action="store_true", help="a tiny sweep: T in {40, 60} s, M in {200, 400}")
    fig.add_argument("--no-agents", action="store_true", help="do not draw the shipped RL agents")
    fig.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_backend_arguments(fig)
    multi = sub.add_parser("multinode", help="several ground nodes: rate vs T and vs K, bound, claims")
    multi.add_argument(
        "--out", type=Path, default=None, help="output folder (default: results/multinode; --quick: out/...)"
    )
    multi.add_argument("--overwrite", action="store_true", help="allow replacing results/multinode")
    multi.add_argument("--jobs", type=int, default=None,
                       help="worker processes (default 1; with --backend ray: no cap)")  # fmt: skip
    multi.add_argument("--quick", action="store_true", help="M = 60, T in {60, 100} s, K <= 3, one seed")
    add_backend_arguments(multi)
    en = sub.add_parser("energy", help="energy efficiency: EE vs T, trajectories, rate-energy trade-off")
    en.add_argument(
        "--out",
        type=Path,
        default=None,
        help="output folder (default: results/energy; --quick: out/energy-quick)",
    )
    en.add_argument("--overwrite", action="store_true", help="allow replacing results/energy")
    en.add_argument("--jobs", type=int, default=None, help="worker processes (default 1)")
    en.add_argument(
        "--quick", action="store_true", help="M = 60, T in {40, 50} s, 5 m grid, no SCA, 3 budgets"
    )
    en.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_backend_arguments(en)
    return parser


def check_out(
    parser: argparse.ArgumentParser, args: argparse.Namespace, out: Path, shipped: Path, hint: str = ""
) -> None:
    """Exit through ``parser.error`` unless ``out`` may be written: not the ``shipped`` results
    folder without ``--overwrite``, and writable (``baselines.runner.check_writable``)."""
    if out.resolve() == shipped and not args.overwrite:
        parser.error(
            f"argument --out: {out} holds the shipped results; pass --overwrite to replace them{hint}"
        )
    try:
        check_writable(out)
    except OSError as exc:
        parser.error(f"argument --out: {exc}")


def multinode_main(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """``python -m experiments multinode``: solve (cached), write CSV, figures and claims."""
    from experiments import multinode

    spec = multinode.QUICK if args.quick else multinode.MultiSpec()
    out = args.out or Path("out/multinode-quick" if args.quick else "results/multinode")
    check_out(parser, args, out, RESULTS_DIR / "multinode")
    t0 = time.perf_counter()
    jobs = args.jobs or (None if args.backend == "ray" else 1)
    records = multinode.run(spec, out / "cache", jobs=jobs, backend=args.backend, address=args.address)
    csv = multinode.write_csv(records, out / "multinode.csv")
    figures = multinode.make_figures(records, out)
    text = multinode.claims(records)
    atomic_write_text(out / "claims_multinode.md", text)
    print(text)
    print(f"{len(records)} points in {time.perf_counter() - t0:.1f} s; wrote {csv}, "
          + ", ".join(str(p) for p in figures))  # fmt: skip
    return 0 if all(r["feasible"] for r in records) else 1


def energy_main(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """``python -m experiments energy``: solve (cached), write the CSV and the figures."""
    from experiments import energy

    spec = energy.QUICK if args.quick else energy.EnergySpec()
    out = args.out or (Path("out/energy-quick") if args.quick else RESULTS_DIR / "energy")
    check_out(parser, args, out, RESULTS_DIR / "energy")
    t0 = time.perf_counter()
    jobs = args.jobs or (None if args.backend == "ray" else 1)
    try:
        records = energy.run(spec, out / "cache", jobs=jobs, backend=args.backend, address=args.address,
                             progress=not args.no_progress)  # fmt: skip
    except KeyboardInterrupt:
        return 130
    csv = energy.write_csv(records, out / "energy.csv")
    figures = energy.make_figures(records, spec, out)
    text = energy.summary(records)
    print(text)
    print(f"{len(records)} points in {time.perf_counter() - t0:.1f} s; wrote {csv}, "
          + ", ".join(str(p) for p in figures))  # fmt: skip
    feasible = all(r["feasible"] for r in energy.rows(records))
    return 0 if feasible and "NO" not in text else 1


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.jobs is not None and args.jobs < 1:
        parser.error(f"argument --jobs: must be >= 1, got {args.jobs}")
    check_backend_arguments(parser, args)
    if args.command == "multinode":
        return multinode_main(args, parser)
    if args.command == "energy":
        return energy_main(args, parser)
    if args.out is None:
        args.out = QUICK_OUT if args.quick else Path("results")
    check_out(parser, args, args.out, RESULTS_DIR, " (or --out another folder)")
    spec = QUICK if args.quick else SweepSpec()
    t0 = time.perf_counter()
    try:
        records = with_pct_of_dp(
            run_sweep(
                spec,
                args.out / "cache",
                jobs=args.jobs,
                progress=not args.no_progress,
                backend=args.backend,
                address=args.address,
            )
        )
    except KeyboardInterrupt:
        return 130
    csv = write_csv(records, args.out / "sweep.csv")
    agents = {} if args.no_agents else agent_trajectories(spec)
    figures = make_figures(records, spec, args.out, agents)
    claims, ok = check_claims(records, spec)
    write_claims(claims, args.out / "claims.md")
    infeasible = [f"{r['scheme']} T={r['T']:g} M={r['M']}" for r in records if not r["feasible"]]
    print(claims)
    print(
        f"{len(records)} points in {time.perf_counter() - t0:.1f} s; wrote {csv}, {args.out / 'claims.md'}, "
        + ", ".join(str(p) for p in figures)
    )
    if infeasible:
        print(f"INFEASIBLE plans: {infeasible}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
