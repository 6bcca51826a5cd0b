"""``python -m baselines.references {single-node,multi-node}``: freeze a suite (module docstring of
:mod:`baselines.references`)."""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path

from baselines.references.content import (
    check_record,
    freeze,
    multinode_content,
    single_node_content,
    write_plans,
)
from baselines.references.draws import multinode_configs
from baselines.references.solve import solve_all
from ios_uav_env.benchmark.suite import SUITE_DIR

HELDOUT = Path("agents/suite/heldout.json")
MULTI_CACHE = Path("out/multi-node-v1")


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m baselines.references", description=__doc__.splitlines()[0])
    kinds = p.add_subparsers(dest="kind", required=True)
    single = kinds.add_parser("single-node", help="freeze a single-node suite from its held-out plan file")
    single.add_argument("--heldout", type=Path, default=HELDOUT, help=f"the plan file (default {HELDOUT})")
    multi = kinds.add_parser("multi-node", help="solve the multi-node held-out scenarios and freeze them")
    multi.add_argument("--n", type=int, default=48, help="scenarios (default 48)")
    multi.add_argument(
        "--cache", type=Path, default=MULTI_CACHE, help=f"per-scenario records ({MULTI_CACHE})"
    )
    multi.add_argument("--jobs", type=int, default=1, help="parallel solves (default 1: this process)")
    multi.add_argument("--plans", type=Path, default=None, help="also write the tour's and SCA's plans here")
    multi.add_argument("--compute-only", action="store_true", help="fill the cache, write no suite")
    for sub in (single, multi):
        sub.add_argument("--name", default=None, help="suite name (default <kind>-v1)")
        sub.add_argument("--version", type=int, default=1)
        sub.add_argument("--dir", type=Path, default=SUITE_DIR, help="folder of the suite file")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    name = args.name or f"{args.kind}-v1"
    if args.version < 1:
        raise SystemExit(f"--version must be >= 1, got {args.version}")
    if args.kind == "single-node":
        if not args.heldout.is_file():
            raise SystemExit(
                f"--heldout {args.heldout}: no such file (python -m agents.suite build writes it)"
            )
        content = single_node_content(json.loads(args.heldout.read_text()), name, args.version)
    else:
        if args.n < 1 or args.jobs < 1:
            raise SystemExit(f"--n and --jobs must be >= 1, got {args.n} and {args.jobs}")
        records = solve_all(multinode_configs(args.n), args.cache, jobs=args.jobs, desc=name)
        notes = [n for r in records for n in check_record(r)]
        print("\n".join(notes) if notes else "checks: SCA >= tour and every value <= bound on every scenario")
        if args.compute_only:
            return 0
        content = multinode_content(records, name, args.version)
        if args.plans is not None:
            print("plans: " + ", ".join(str(p) for p in write_plans(records, args.plans)))
    path, digest = freeze(content, args.dir)
    print(f"{path} ({path.stat().st_size / 1024:.0f} KB), sha256 {digest}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
