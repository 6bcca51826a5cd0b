"""``python -m agents.suite build|show|report|curve``: the held-out suite's command line (see
:mod:`agents.suite`)."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from agents.hyperparams import positive_int
from agents.loading import ALGOS
from baselines.ray_backend import add_backend_arguments, check_backend_arguments
from baselines.references.heldout import (
    CACHE_DIR,
    DEFAULT_SIZE,
    HELDOUT_SEED,
    SUITE_PATH,
    build_suite,
    load_suite,
    show_text,
)
from baselines.runner import check_writable
from ios_uav_env.benchmark import DEFAULT_SUITE
from ios_uav_env.benchmark import load_suite as load_benchmark
from ios_uav_env.benchmark.outputs import claim

SUITE_HELP = f"benchmark suite, a name or a file (default {DEFAULT_SUITE})"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m agents.suite",
        description="The held-out suite of generalist policies: build, show, report, curve.",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    b = sub.add_parser("build", help="draw the suite and precompute its DP and SCA plans (resumable)")
    b.add_argument("--n", type=positive_int, default=DEFAULT_SIZE, help=f"scenarios (default {DEFAULT_SIZE})")
    b.add_argument("--seed", type=int, default=HELDOUT_SEED, help=f"suite seed (default {HELDOUT_SEED})")
    b.add_argument("--jobs", type=positive_int, default=2, help="worker processes (default 2)")
    b.add_argument(
        "--out", type=Path, default=None,
        help="suite file (default: agents/suite/heldout.json for the default --n and --seed, "
             "else out/suite_n<n>_seed<seed>.json)",
    )  # fmt: skip
    b.add_argument("--overwrite", action="store_true", help="replace an existing suite file")
    b.add_argument("--cache", type=Path, default=CACHE_DIR, help=f"per-scenario cache (default {CACHE_DIR})")
    b.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_backend_arguments(b)
    s = sub.add_parser("show", help="print the suite's summary")
    s.add_argument("--suite", type=Path, default=SUITE_PATH, help="suite file")
    s.add_argument("--table", action="store_true", help="one line per scenario")
    r = sub.add_parser("report", help="score a trained policy on the suite (see agents.suite.report)")
    r.add_argument(
        "--model", required=True, help="run or model folder, a model .zip, 'heuristic' or 'peak-heuristic'"
    )
    r.add_argument("--algo", choices=list(ALGOS), default=None, help="algorithm (default: the run's)")
    r.add_argument(
        "--suite", default=DEFAULT_SUITE, help=f"benchmark suite, a name or a file (default {DEFAULT_SUITE})"
    )
    r.add_argument("--n", type=positive_int, default=None, help="only the first n scenarios")
    r.add_argument("--out", type=Path, default=Path("out/suite"), help="folder of the table and figures")
    r.add_argument("--overwrite", action="store_true", help="replace a report in --out (and its stale files)")
    r.add_argument(
        "--allow-task-change", action="store_true",
        help="run the model's env arguments that change the suite's task (the outputs name it)",
    )  # fmt: skip
    r.add_argument(
        "--node-orders", action="store_true",
        help="a multi-node model: its action averaged over every order of the nodes (agents.node_orders)",
    )  # fmt: skip
    c = sub.add_parser("curve", help="score every checkpoint of a training run (the learning curve)")
    c.add_argument("--run", type=Path, required=True, help="run folder (with checkpoints/)")
    c.add_argument(
        "--suite", default=DEFAULT_SUITE, help=f"benchmark suite, a name or a file (default {DEFAULT_SUITE})"
    )
    c.add_argument("--n", type=positive_int, default=None, help="only the first n scenarios")
    c.add_argument("--out", type=Path, default=Path("out/suite_curve"), help="folder of the CSV and PNG")
    c.add_argument("--overwrite", action="store_true", help="replace a curve in --out")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command == "build":
        check_backend_arguments(parser, args)
        if args.out is None:
            default = args.n == DEFAULT_SIZE and args.seed == HELDOUT_SEED
            args.out = SUITE_PATH if default else Path(f"out/suite_n{args.n}_seed{args.seed}.json")
        if args.out.exists() and not args.overwrite:
            parser.error(f"argument --out: {args.out} exists; pass --overwrite to replace it")
        try:
            check_writable(args.out.parent)
        except OSError as exc:
            parser.error(f"argument --out: {exc}")
        start = time.perf_counter()
        try:
            suite = build_suite(args.out, args.n, args.seed, jobs=args.jobs, cache_dir=args.cache,
                                progress=not args.no_progress, backend=args.backend,
                                address=args.address)  # fmt: skip
        except KeyboardInterrupt:  # the solved scenarios are cached (baselines.runner said where)
            return 130
        print(show_text(suite, args.out))
        print(f"wrote {args.out} in {time.perf_counter() - start:.1f} s")
        return 0
    if args.command == "show":
        try:
            plans = load_suite(args.suite)
        except (FileNotFoundError, ValueError) as exc:
            parser.error(f"argument --suite: {exc}")
        print(show_text(plans, args.suite, table=args.table))
        return 0
    try:
        suite = load_benchmark(args.suite)
    except (FileNotFoundError, KeyError, ValueError) as exc:
        parser.error(f"argument --suite: {exc}")
    if suite.multi_node:
        parser.error(f"argument --suite: {suite.name} is a multi-node suite (a multi-node --model is scored "
                     "on multi-node-v1 by itself)")  # fmt: skip
    if args.command == "curve":
        from agents.suite.curve import CURVE_FILES, learning_curve, write_curve

        try:  # a previous curve's files go when the new curve's first row is written
            stale = claim(args.out, CURVE_FILES, args.overwrite)
        except FileExistsError as exc:
            parser.error(f"argument --out: {exc}")
        try:
            rows = learning_curve(args.run, suite, args.n, out=args.out, stale=stale)
        except FileNotFoundError as exc:
            parser.error(f"argument --run: {exc}")
        except ValueError as exc:  # the run's env arguments on the suite (ios_uav_env.benchmark.overrides)
            parser.error(f"argument --run: {exc}")
        except KeyboardInterrupt:
            print(f"interrupted: the checkpoints scored so far are in {args.out / 'suite_curve.csv'}",
                  file=sys.stderr)  # fmt: skip
            return 130
        if not rows:
            print(f"no checkpoint of {args.run} loads", file=sys.stderr)
            return 1
        print("wrote " + ", ".join(str(p) for p in write_curve(rows, args.out)))
        return 0
    from agents.suite.report import REPORT_FILES, load_policy, run_report

    try:
        claim(args.out, REPORT_FILES, args.overwrite)
    except FileExistsError as exc:
        parser.error(f"argument --out: {exc}")
    try:
        policy = load_policy(args.model, args.algo)
    except (FileNotFoundError, ValueError) as exc:
        parser.error(f"argument --model: {exc}")
    if args.node_orders:
        from agents.evaluate_multi import is_multinode

        if not is_multinode(policy):
            parser.error(f"argument --node-orders: {args.model} is a one-node model (the orders are a "
                         "multi-node model's nodes')")  # fmt: skip
    try:
        run_report(policy, args.out, n=args.n, suite=suite, node_orders=args.node_orders,
                   overwrite=args.overwrite, allow_task_change=args.allow_task_change)  # fmt: skip
    except ValueError as exc:  # the model's env arguments on the suite (ios_uav_env.benchmark.overrides)
        parser.error(f"argument --model: {exc}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
