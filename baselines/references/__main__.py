"""``python -m baselines.references <kind>``: freeze a suite (kinds: single-node, multi-node, energy,
mobile, multi-node-mobile, multi-uav, star, miso)
(module docstring of :mod:`baselines.references`)."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from baselines.references.content import (
    check_energy_record,
    check_record,
    energy_content,
    freeze,
    multinode_content,
    single_node_content,
    write_plans,
)
from baselines.references.draws import ENERGY_RANGES, ENERGY_SIZE, ENTROPY, energy_configs, multinode_configs
from baselines.references.fleet import FLEET_SIZE
from baselines.references.miso import MISO_SIZE
from baselines.references.mobile import (
    MOBILE_RANGES,
    MOBILE_SIZE,
    check_mobile_record,
    mobile_content,
    mobile_tasks,
)
from baselines.references.online import MULTI_MOBILE_RANGES, MULTI_MOBILE_SIZE
from baselines.references.solve import BOUND_RESOLUTION, DP_RESOLUTION, ENERGY_BOUND_RESOLUTION, solve_all
from baselines.references.star import STAR_SIZE
from ios_uav_env.benchmark.suite_registry import SUITE_DIR, check_suite_name

HELDOUT = Path("agents/suite/heldout.json")
MULTI_CACHE = Path("out/multi-node-v1")
ENERGY_CACHE = Path("out/energy-v1")
#: ``energy --quick``: a tiny suite for checks, not a benchmark: 2 scenarios of 40 to 45 s (the
#: shortest horizon that reaches every end point of the ranges is about 34 s), the DP on a 5 m
#: grid and the bound on 12.5 m cells, named energy-quick-v1, cached and written under out/.
QUICK = {"n": 2, "T": (40.0, 45.0), "dp_resolution": 5.0, "bound_resolution": 12.5}
QUICK_DIR = Path("out/energy-quick")
MOBILE_CACHE = Path("out/mobile-v1")
#: ``mobile --quick``: 2 scenarios of 40 to 45 s, the bound on 12.5 m cells, named
#: mobile-quick-v1, cached and written under out/mobile-quick.
MOBILE_QUICK = {"n": 2, "T": (40.0, 45.0), "bound_resolution": 12.5}
MOBILE_QUICK_DIR = Path("out/mobile-quick")
#: The suites normalised by the clairvoyant optimum (``mobile --version 2``, ``multi-node-mobile``),
#: by multi-node: their caches and quick folders; ``--quick``: 2 scenarios of 20 to 22 s, q0 and qF
#: 200 m apart, a surface of 4 x 10 elements, the optimum on a 2.5 m grid, the bound's cells and MPC-DP's
#: grid 12.5 m: a suite for checks, not for comparisons.
ONLINE_CACHE = {False: Path("out/mobile-v2"), True: Path("out/multi-node-mobile-v1")}
ONLINE_QUICK_DIR = {False: MOBILE_QUICK_DIR, True: Path("out/multi-node-mobile-quick")}
ONLINE_QUICK = {"n": 2, "dp_resolution": 2.5, "resolution": 12.5}
ONLINE_QUICK_RANGES = {"T": (20.0, 22.0), "start_x": (-100.0, -100.0), "end_x": (100.0, 100.0),
                       "ios_rows": (4, 4), "ios_columns": 10}  # fmt: skip
#: ``multi-uav``: its cache; ``--quick``: 2 scenarios of :data:`ONLINE_QUICK_RANGES`, the planner's
#: grids 12.5 m and no polishing, named multi-uav-quick-v1, cached and written under out/multi-uav-quick.
FLEET_CACHE = Path("out/multi-uav-v1")
FLEET_QUICK = {"n": 2, "resolution": 12.5, "bound_resolution": 12.5, "polish_budget": 0}
FLEET_QUICK_DIR = Path("out/multi-uav-quick")
#: ``star``: its cache; ``--quick``: the first 3 scenarios (M = 16, continuous phases: TDMA, ES-NOMA,
#: MS-NOMA) with one random episode each, named star-quick-v1, cached and written under out/star-quick.
STAR_CACHE = Path("out/star-v1")
STAR_QUICK = {"n": 3, "random_episodes": 1}
STAR_QUICK_DIR = Path("out/star-quick")
#: ``miso``: its cache; ``--quick``: the first 2 scenarios (N_t = 2, K = 2, M = 16: sum, max-min)
#: with one random episode each, named miso-quick-v1, cached and written under out/miso-quick.
MISO_CACHE = Path("out/miso-v1")
MISO_QUICK = {"n": 2, "random_episodes": 1}
MISO_QUICK_DIR = Path("out/miso-quick")


def _drawn_parser(
    kinds: Any, kind: str, what: str, size: int, cache: Path, quick: str
) -> argparse.ArgumentParser:
    """The subcommand of a suite drawn from a spawned seed sequence and solved here (energy, mobile)."""
    sub = kinds.add_parser(kind, help=what)
    sub.add_argument("--n", type=int, default=None, help=f"scenarios (default {size}; --quick: 2)")
    sub.add_argument("--seed", type=int, default=ENTROPY, help=f"the draws' entropy (default {ENTROPY})")
    sub.add_argument("--cache", type=Path, default=None, help=f"per-scenario records ({cache})")
    sub.add_argument("--jobs", type=int, default=1, help="parallel solves (default 1: this process)")
    sub.add_argument("--compute-only", action="store_true", help="fill the cache, write no suite")
    sub.add_argument("--quick", action="store_true", help=quick)
    return sub


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
    energy = _drawn_parser(
        kinds,
        "energy",
        "solve the energy held-out scenarios and freeze them",
        ENERGY_SIZE,
        ENERGY_CACHE,
        "a tiny check suite: 2 short scenarios, coarse grids, energy-quick-v1 in out/energy-quick",
    )
    mobile = _drawn_parser(
        kinds,
        "mobile",
        "solve the mobile held-out scenarios online and freeze them",
        MOBILE_SIZE,
        MOBILE_CACHE,
        "a tiny check suite: 2 short scenarios, a coarse bound, mobile-quick-v1 in out/mobile-quick",
    )
    multi_mobile = _drawn_parser(
        kinds,
        "multi-node-mobile",
        "solve the multi-node mobile held-out scenarios online and freeze them",
        MULTI_MOBILE_SIZE,
        ONLINE_CACHE[True],
        "a tiny check suite: 2 short scenarios, coarse grids, in out/multi-node-mobile-quick",
    )
    fleets = _drawn_parser(
        kinds,
        "multi-uav",
        "plan the several-UAV held-out scenarios (planner, bound, rows) and freeze them",
        FLEET_SIZE,
        FLEET_CACHE,
        "a tiny check suite: 2 short scenarios, coarse grids, in out/multi-uav-quick",
    )
    stars = _drawn_parser(
        kinds,
        "star",
        "play the STAR-control held-out episodes (optimum, bound, rows) and freeze them",
        STAR_SIZE,
        STAR_CACHE,
        "a tiny check suite: 3 scenarios of 16 elements, one random episode, in out/star-quick",
    )
    misos = _drawn_parser(
        kinds,
        "miso",
        "play the MISO-control held-out episodes (AO optimum, bound, rows) and freeze them",
        MISO_SIZE,
        MISO_CACHE,
        "a tiny check suite: 2 scenarios of N_t = K = 2, M = 16, one random episode, in out/miso-quick",
    )
    for sub in (single, multi, energy, mobile, multi_mobile, fleets, stars, misos):
        sub.add_argument("--name", default=None, help="suite name (default <kind>-v<version>)")
        sub.add_argument(
            "--version", type=int, default=1, help="mobile: 2 is the suite normalised by the optimum"
        )
        sub.add_argument("--dir", type=Path, default=None, help="folder of the suite file (the package's)")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    quick = args.kind in ("energy", "mobile", "multi-node-mobile", "multi-uav", "star", "miso") and args.quick
    name = args.name or (f"{args.kind}-quick-v{args.version}" if quick else f"{args.kind}-v{args.version}")
    quick_dir = MOBILE_QUICK_DIR if args.kind == "mobile" else QUICK_DIR
    directory = args.dir or (quick_dir if quick else SUITE_DIR)
    if args.version < 1:
        raise SystemExit(f"--version must be >= 1, got {args.version}")
    try:  # before any solve: a suite file under a non-canonical name would not load
        check_suite_name(name, "--name")
    except ValueError as err:
        raise SystemExit(str(err)) from None
    if args.kind == "energy":
        return _energy(args, name, directory)
    if args.kind == "multi-uav":
        return _fleet(args, name, args.dir or (FLEET_QUICK_DIR if quick else SUITE_DIR))
    if args.kind in ("star", "miso"):
        return _star(args, name, args.dir or (_surface(args.kind)["quick_dir"] if quick else SUITE_DIR))
    if args.kind == "multi-node-mobile" or (args.kind == "mobile" and args.version >= 2):
        multi = args.kind == "multi-node-mobile"
        return _online(args, name, args.dir or (ONLINE_QUICK_DIR[multi] if quick else SUITE_DIR), multi)
    if args.kind == "mobile":
        return _mobile(args, name, directory)
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
    return _freeze(content, directory)


def _freeze(content: dict, directory: Path) -> int:
    try:
        path, digest = freeze(content, directory)
    except ValueError as err:
        raise SystemExit(str(err)) from None
    print(f"{path} ({path.stat().st_size / 1024:.0f} KB), sha256 {digest}")
    return 0


def _size(args: argparse.Namespace, default: int, quick: int) -> int:
    """The scenario count of a drawn suite (``--n``, else its default or the quick one), with
    ``--n``, ``--jobs`` and ``--seed`` checked."""
    n = args.n if args.n is not None else (quick if args.quick else default)
    if n < 1 or args.jobs < 1:
        raise SystemExit(f"--n and --jobs must be >= 1, got {n} and {args.jobs}")
    if args.seed < 0:
        raise SystemExit(f"--seed must be an integer >= 0 (a seed sequence's entropy), got {args.seed}")
    return n


def _finish(
    args: argparse.Namespace, records: list, check: Callable, passed: str, content: Callable, directory: Path
) -> int:
    """Print the records' sanity notes (``check`` of each; ``passed`` if none), then, unless
    ``--compute-only``, build the suite (``content()``) and freeze it."""
    notes = [note for r in records for note in check(r)]
    print("\n".join(notes) if notes else passed)
    if args.compute_only:
        return 0
    try:
        built = content()
    except ValueError as err:
        raise SystemExit(str(err)) from None
    return _freeze(built, directory)


def _energy(args: argparse.Namespace, name: str, directory: Path) -> int:
    """``energy``: draw, solve (cached, resumable), check and freeze the energy suite."""
    import dataclasses

    n = _size(args, ENERGY_SIZE, QUICK["n"])
    ranges = dataclasses.replace(ENERGY_RANGES, T=QUICK["T"]) if args.quick else ENERGY_RANGES
    dp_res, bound_res = (
        (QUICK["dp_resolution"], QUICK["bound_resolution"])
        if args.quick
        else (DP_RESOLUTION, ENERGY_BOUND_RESOLUTION)
    )
    cache = args.cache or (QUICK_DIR / "cache" if args.quick else ENERGY_CACHE)
    configs = energy_configs(n, args.seed, ranges)
    records = solve_all(configs, cache, dp_resolution=dp_res, energy_bound_resolution=bound_res,
                        jobs=args.jobs, progress=not args.quick, desc=name)  # fmt: skip
    passed = "checks: every plan feasible, SCA-EE >= DP-EE and every EE <= bound"
    build = lambda: energy_content(records, name, args.version, seed=args.seed, ranges=ranges)  # noqa: E731
    return _finish(args, records, check_energy_record, passed, build, directory)


def _mobile(args: argparse.Namespace, name: str, directory: Path) -> int:
    """``mobile``: draw, solve (cached, resumable), check and freeze the mobile suite."""
    import dataclasses

    from ios_uav_env import ScenarioConfig

    n = _size(args, MOBILE_SIZE, MOBILE_QUICK["n"])
    ranges = dataclasses.replace(MOBILE_RANGES, T=MOBILE_QUICK["T"]) if args.quick else MOBILE_RANGES
    bound_res = MOBILE_QUICK["bound_resolution"] if args.quick else BOUND_RESOLUTION
    cache = args.cache or (MOBILE_QUICK_DIR / "cache" if args.quick else MOBILE_CACHE)
    tasks = mobile_tasks(n, args.seed, ranges)
    configs = [ScenarioConfig(**t["config"]) for t in tasks]
    records = solve_all(configs, cache, bound_resolution=bound_res, jobs=args.jobs, progress=not args.quick,
                        desc=name, seeds=[t["seed"] for t in tasks])  # fmt: skip
    passed = "checks: every plan feasible and every rate <= the clairvoyant bound"
    build = lambda: mobile_content(records, name, args.version, seed=args.seed, ranges=ranges)  # noqa: E731
    return _finish(args, records, check_mobile_record, passed, build, directory)


def _online(args: argparse.Namespace, name: str, directory: Path, multi: bool) -> int:
    """``mobile --version 2`` / ``multi-node-mobile``: draw, solve (cached, resumable), check and
    freeze a suite normalised by the clairvoyant optimum (:mod:`baselines.references.online`); a
    scenario that fails a check stops the freeze, named."""
    import dataclasses
    import functools

    from baselines.references import online
    from baselines.runner import run_tasks

    n = _size(args, MULTI_MOBILE_SIZE if multi else MOBILE_SIZE, ONLINE_QUICK["n"])
    family = MULTI_MOBILE_RANGES if multi else MOBILE_RANGES
    ranges = dataclasses.replace(family, **ONLINE_QUICK_RANGES) if args.quick else family
    full = (online.MULTI_DP_RESOLUTION, online.MULTI_BOUND_RESOLUTION) if multi else (
        online.DP_RESOLUTION, online.BOUND_RESOLUTION)  # fmt: skip
    grids = (ONLINE_QUICK["dp_resolution"], *(ONLINE_QUICK["resolution"],) * 2) if args.quick else (
        *full, online.MPC_RESOLUTION)  # fmt: skip
    settings = dict(zip(("dp_resolution", "bound_resolution", "mpc_resolution"), grids, strict=True))
    settings["dp_refine"] = online.DP_REFINE
    cache = args.cache or (ONLINE_QUICK_DIR[multi] / "cache" if args.quick else ONLINE_CACHE[multi])
    tasks = (online.multi_mobile_tasks if multi else mobile_tasks)(n, args.seed, ranges)
    records = run_tasks(
        functools.partial(online.solve_task, **settings), tasks, cache,
        key=functools.partial(online.online_key, **settings), jobs=args.jobs,
        order=online.longest_first,
        progress=not args.quick, desc=name, unit="scenario", describe=online.describe,
        required=("config", "seed", "optimum", "bound", *(online.MULTI_ONLINE if multi else online.ONLINE)),
    )  # fmt: skip
    share = f"{100 * online.ONLINE_SHARE:g}%"
    passed = (
        f"checks: every plan feasible, bound >= optimum >= {share} of every online row, every row <= bound"
    )
    build = lambda: online.online_content(  # noqa: E731
        records, name, args.version, seed=args.seed, ranges=ranges, multi=multi, settings=settings
    )
    return _finish(args, records, online.check_online_record, passed, build, directory)


def _fleet(args: argparse.Namespace, name: str, directory: Path) -> int:
    """``multi-uav``: draw, plan (cached, resumable), check and freeze the several-UAV suite
    (:mod:`baselines.references.fleet`); a scenario that fails a check stops the freeze, named."""
    import dataclasses
    import functools

    from baselines.references import fleet
    from baselines.runner import run_tasks

    n = _size(args, FLEET_SIZE, FLEET_QUICK["n"])
    ranges = (
        dataclasses.replace(fleet.FLEET_RANGES, **ONLINE_QUICK_RANGES) if args.quick else fleet.FLEET_RANGES
    )
    settings = (
        {k: FLEET_QUICK[k] for k in ("resolution", "bound_resolution", "polish_budget")}
        if args.quick
        else {
            "resolution": fleet.RESOLUTION,
            "bound_resolution": fleet.BOUND_RESOLUTION,
            "polish_budget": fleet.POLISH_BUDGET,
        }  # fmt: skip
    )
    cache = args.cache or (FLEET_QUICK_DIR / "cache" if args.quick else FLEET_CACHE)
    records = run_tasks(
        functools.partial(fleet.solve_fleet, **settings), fleet.fleet_tasks(n, args.seed, ranges), cache,
        key=functools.partial(fleet.fleet_key, **settings), jobs=args.jobs, order=fleet.longest_first,
        progress=not args.quick, desc=name, unit="scenario", describe=fleet.describe,
        required=("config", "fleet", *fleet.FLEET_REFERENCES),
    )  # fmt: skip
    passed = "checks: every planner plan feasible, no row above the planner, every row <= bound"
    build = lambda: fleet.fleet_content(  # noqa: E731
        records, name, args.version, seed=args.seed, ranges=ranges, settings=settings
    )
    return _finish(args, records, fleet.check_fleet_record, passed, build, directory)


def _surface(kind: str) -> dict[str, Any]:
    """The pieces of a surface-control suite (``star``, ``miso``): its module's draws, solve,
    cache key, checks and content, and its defaults."""
    from baselines.references import miso, star

    if kind == "miso":
        return {"size": MISO_SIZE, "quick": MISO_QUICK, "cache": MISO_CACHE, "quick_dir": MISO_QUICK_DIR,
                "episodes": miso.RANDOM_EPISODES, "tasks": miso.miso_tasks, "solve": miso.solve_miso,
                "key": miso.miso_key, "order": miso.longest_first, "describe": miso.describe,
                "required": ("config", "miso", "seed", *miso.MISO_REFERENCES),
                "check": miso.check_miso_record, "content": miso.miso_content,
                "passed": f"checks: AO optimum > 0, <= bound and within {100 * miso.AO_GAP:g}% of it, "
                "replayed, no row above it"}  # fmt: skip
    return {"size": STAR_SIZE, "quick": STAR_QUICK, "cache": STAR_CACHE, "quick_dir": STAR_QUICK_DIR,
            "episodes": star.RANDOM_EPISODES, "tasks": star.star_tasks, "solve": star.solve_star,
            "key": star.star_key, "order": star.longest_first, "describe": star.describe,
            "required": ("config", "star", "seed", *star.STAR_REFERENCES), "check": star.check_star_record,
            "content": star.star_content,
            "passed": "checks: optimum > 0 and <= bound (= under TDMA), replayed to rounding, no row above "
            "the optimum"}  # fmt: skip


def _star(args: argparse.Namespace, name: str, directory: Path) -> int:
    """``star`` / ``miso``: draw, play (cached, resumable), check and freeze a surface-control suite
    (:mod:`baselines.references.star`, :mod:`baselines.references.miso`); a scenario that fails a
    check stops the freeze, named."""
    import functools

    from baselines.runner import run_tasks

    p = _surface(args.kind)
    n = _size(args, p["size"], p["quick"]["n"])
    episodes = p["quick"]["random_episodes"] if args.quick else p["episodes"]
    settings = {"entropy": args.seed, "random_episodes": episodes}
    cache = args.cache or (p["quick_dir"] / "cache" if args.quick else p["cache"])
    records = run_tasks(
        functools.partial(p["solve"], **settings), p["tasks"](n, args.seed), cache,
        key=functools.partial(p["key"], **settings), jobs=args.jobs, order=p["order"],
        progress=not args.quick, desc=name, unit="scenario", describe=p["describe"], required=p["required"],
    )  # fmt: skip
    build = lambda: p["content"](records, name, args.version, seed=args.seed, random_episodes=episodes)  # noqa: E731
    return _finish(args, records, p["check"], p["passed"], build, directory)


if __name__ == "__main__":
    raise SystemExit(main())
