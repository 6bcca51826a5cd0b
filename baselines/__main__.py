"""Command line: run benchmark schemes on a scenario, print a table, save plans and a figure.

Examples
--------
``python -m baselines --scheme ia --T 150 --M 6000``
``python -m baselines --scheme ia ra ia-ft cuc dp --T 100 --resolution 5 --out results/plans``
``python -m baselines --nodes="-100,-20;150,-60;-40,90" --scheme tour ia dp`` (several ground
nodes: max-min rates; ``dp`` also prints its certified upper bound and gap)
``python -m baselines --nodes="-5,2;5,-2" --ios-shape 8 8 --scheme dp-star dp-sta ...`` (a STAR
surface serving a user on each side at once, NOMA: ``dp-star`` sets ``--surface star --star-access
noma`` itself; ``--surface star --star-access noma`` runs the other schemes on that scenario, where
the TDMA planners refuse it, naming ``dp-star``)
``python -m baselines --objective energy_efficiency`` (the energy planners of
:data:`ENERGY_SCHEMES` that handle the scenario: ``dp-ee``, ``sca-ee``, ``loiter``, ``hover``;
each row gives the energy efficiency in bits/J, the energy, the average rate and the time, and
the certified EE bound of ``baselines.energy_bound`` with each plan's % of it, when that module
can run; with ``--nodes``: ``dp-ee-multi``, ``loiter`` and ``hover``, and dp-ee-multi's bound
over its grid paths)

For each scheme: ``<out>/<scheme>_T<T>_M<M>.json`` (the :class:`Plan`, written atomically)
and ``.csv`` (x, y per slot, m); one PNG of all trajectories over the rate map of the
scenario's surface (``--surface``, default IOS), drawn by ``ios_uav_env.plotting``.
Exit status: 0 if every scheme ran, 1 if some could not (e.g. SCA without cvxpy), 2 for
bad arguments.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from baselines import registry
from baselines.plan import Plan
from baselines.runner import check_writable
from baselines.schemes import SCHEMES, get_scheme, run_scheme, sca_unavailable_reason
from ios_uav_env import OBJECTIVES, ScenarioConfig, io
from ios_uav_env.model.config import STAR_ACCESS, SURFACE_KINDS

_HEADER = ("scheme", "T (s)", "M", "rate (bps/Hz)", "feasible", "worst viol. (m)", "seconds")
_WIDTHS = (8, 7, 6, 14, 9, 16, 8)
_ENERGY_HEADER = ("scheme", "T (s)", "M", "EE (bits/J)", "energy (J)", "rate (bps/Hz)", "feasible", "seconds")
_ENERGY_WIDTHS = (8, 7, 6, 12, 11, 14, 9, 8)

#: The planners of ``--objective energy_efficiency``: name -> (entry point, description), from
#: ``baselines.registry``; ``sca-ee`` (cvxpy) runs when it can be imported.
ENERGY_SCHEMES: dict[str, tuple[str, str]] = {
    name: (registry.PLANNERS[name].entry, registry.PLANNERS[name].description)
    for name in ("dp-ee", "dp-ee-multi", "sca-ee", "loiter", "hover")
}


def _elements(text: str) -> int:
    try:
        m = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"M must be a positive multiple of 100, got {text!r}") from None
    if m <= 0 or m % 100:
        raise argparse.ArgumentTypeError(
            f"M must be a positive multiple of 100 (ios_shape = (100, M/100)), got {m}"
        )
    return m


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number > 0, got {text!r}") from None
    if not (np.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text!r}")
    return value


def _nodes(text: str) -> tuple[tuple[float, float], ...]:
    """``"x,y;x,y;..."`` -> ((x, y), ...): K >= 1 finite pairs in m."""
    try:
        pairs = tuple(tuple(float(v) for v in item.split(",")) for item in text.split(";") if item.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f'must be "x,y;x,y;..." (numbers in m), got {text!r}') from None
    if not pairs or any(len(p) != 2 or not all(np.isfinite(p)) for p in pairs):
        raise argparse.ArgumentTypeError(f'must be K >= 1 finite pairs "x,y;x,y;..." (m), got {text!r}')
    return pairs  # type: ignore[return-value]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``python -m baselines``."""
    p = argparse.ArgumentParser(
        prog="python -m baselines",
        description="Plan UAV trajectories with the paper's benchmark schemes and the DP optimum.",
    )
    p.add_argument(
        "--scheme", nargs="+", default=None, choices=[*SCHEMES, *ENERGY_SCHEMES], metavar="SCHEME",
        help=f"scheme(s) to run: {', '.join(SCHEMES)} (default: ia); with --objective energy_efficiency: "
        f"{', '.join(ENERGY_SCHEMES)} (default: all)",
    )  # fmt: skip
    p.add_argument(
        "--objective", choices=OBJECTIVES, default="rate",
        help="what a plan is scored by: the average rate (default) or the energy efficiency (bits/J)",
    )  # fmt: skip
    p.add_argument("--T", type=_positive, default=150.0, help="mission duration T in s (default 150)")
    shape = p.add_mutually_exclusive_group()
    shape.add_argument(
        "--M", type=_elements, help="IOS elements, a multiple of 100: ios_shape = (100, M/100)"
    )
    shape.add_argument("--ios-shape", type=int, nargs=2, metavar=("MY", "MZ"), help="IOS columns and rows")
    p.add_argument(
        "--surface", choices=SURFACE_KINDS, default="ios", help="surface of scheme 'dp' and the map"
    )
    p.add_argument(
        "--star-access", choices=STAR_ACCESS, default="tdma",
        help="with --surface star: one node per slot share (tdma, default) or both sides' users at once "
        "(noma)",
    )  # fmt: skip
    p.add_argument("--q0", type=float, nargs=2, metavar=("X", "Y"), help="initial position (m)")
    p.add_argument("--qF", type=float, nargs=2, metavar=("X", "Y"), help="final position (m)")
    nodes = p.add_mutually_exclusive_group()
    nodes.add_argument("--ground", type=float, nargs=2, metavar=("X", "Y"), help="ground node G (m)")
    nodes.add_argument(
        "--nodes",
        type=_nodes,
        metavar='"X,Y;X,Y;..."',
        help='several ground nodes (m), max-min TDMA; write --nodes="-100,-20;150,-60"',
    )
    p.add_argument("--resolution", type=_positive, default=2.5, help="DP grid spacing in m (default 2.5)")
    p.add_argument("--margin", type=float, default=100.0, help="DP grid box margin in m (default 100)")
    p.add_argument("--out", type=Path, default=Path("results/plans"), help="output folder")
    p.add_argument("--no-plot", action="store_true", help="do not write the PNG figure")
    p.add_argument("--progress", action="store_true", help="show the planners' progress (DP, SCA)")
    p.add_argument(
        "--no-bound", action="store_true", help="--objective energy_efficiency: skip the certified EE bound"
    )
    return p


def _config(args: argparse.Namespace, parser: argparse.ArgumentParser) -> ScenarioConfig:
    changes: dict = {"T": args.T, "surface": args.surface, "objective": args.objective}
    if args.star_access != "tdma":
        if args.surface != "star":
            parser.error(f"argument --star-access: {args.star_access} needs --surface star")
        changes["star_access"] = args.star_access
    if args.M is not None:
        changes["ios_shape"] = (100, args.M // 100)
    elif args.ios_shape is not None:
        changes["ios_shape"] = tuple(args.ios_shape)
    for name, field in (("q0", "q0"), ("qF", "qF"), ("ground", "ground_node"), ("nodes", "ground_nodes")):
        if getattr(args, name) is not None:
            changes[field] = tuple(getattr(args, name))
    try:
        config = ScenarioConfig(**changes)
    except ValueError as exc:
        parser.error(f"invalid scenario: {exc}")
    if args.resolution > config.D:
        parser.error(f"argument --resolution: must be in (0, D={config.D:g}] m, got {args.resolution:g}")
    if not (np.isfinite(args.margin) and args.margin >= 0):
        parser.error(f"argument --margin: must be a finite number >= 0, got {args.margin:g}")
    return config


def _row(cells: Sequence[str], widths: Sequence[int] = _WIDTHS) -> str:
    return "  ".join(str(c).rjust(w) for c, w in zip(cells, widths, strict=True))


def format_row(plan: Plan) -> str:
    """One table row: scheme, T, M, average rate, feasible, worst violation, seconds."""
    c = plan.config
    return _row(
        (
            plan.scheme, f"{c.T:g}", c.M, f"{plan.mean_rate:.6f}", "yes" if plan.feasible else "NO",
            f"{plan.report.worst_violation:.3g}", f"{plan.seconds:.2f}",
        )
    )  # fmt: skip


def save_csv(path: Path, trajectory: np.ndarray) -> Path:
    """Write the (N, 2) trajectory as CSV columns x,y (m), atomically."""
    return io.save_csv(path, trajectory, header="x,y")


def plot_plans(path: Path, config: ScenarioConfig, plans: Sequence[Plan]) -> Path:
    """PNG of the plans' trajectories over the rate map of ``config``'s surface.

    Drawn with the shared helpers of ``ios_uav_env.plotting`` (matplotlib, Agg canvas).
    """
    from matplotlib.figure import Figure  # no pyplot: never touches the user's backend

    from ios_uav_env.plotting import (
        plot_multinode_map,
        plot_rate_map,
        plot_served_trajectories,
        plot_trajectories,
    )

    fig = Figure(figsize=(10, 5.5), layout="constrained")
    ax = fig.add_subplot()
    if config.K > 1 and config.star_access == "noma":  # both users served at once: no TDMA schedule
        plot_multinode_map(ax, config)
        plot_trajectories(ax, config, {f"{p.scheme}: {p.mean_rate:.3f} bps/Hz": p.trajectory for p in plans})
        ax.set_title(f"STAR, two users at once (NOMA, max-min), T = {config.T:g} s, M = {config.M}")
        return io.save_figure(fig, path, dpi=120)
    if config.K > 1:  # every node, trajectories coloured by the node served in each slot
        plot_multinode_map(ax, config)
        labels = {f"{p.scheme}: {p.mean_rate:.3f} bps/Hz": p.trajectory for p in plans}
        shares = {f"{p.scheme}: {p.mean_rate:.3f} bps/Hz": np.array(p.info["shares"]) for p in plans}
        plot_served_trajectories(ax, config, labels, shares)
        ax.set_title(
            f"{config.surface.upper()}, K = {config.K} nodes (max-min), T = {config.T:g} s, M = {config.M}"
        )
        return io.save_figure(fig, path, dpi=120)
    plot_rate_map(ax, config)
    if config.objective == "energy_efficiency":
        labels = {f"{p.scheme}: {p.energy_efficiency:.0f} bits/J": p.trajectory for p in plans}
    else:
        labels = {f"{p.scheme}: {p.mean_rate:.3f} bps/Hz": p.trajectory for p in plans}
    plot_trajectories(ax, config, labels)
    ax.set_title(f"{config.surface.upper()} rate map, T = {config.T:g} s, M = {config.M}")
    return io.save_figure(fig, path, dpi=120)


def format_energy_row(plan: Plan) -> str:
    """One row of the energy table: scheme, T, M, EE, energy, average rate, feasible, seconds."""
    c = plan.config
    return _row(
        (
            plan.scheme, f"{c.T:g}", c.M, f"{plan.energy_efficiency:.2f}", f"{plan.energy:.1f}",
            f"{plan.mean_rate:.6f}", "yes" if plan.feasible else "NO", f"{plan.seconds:.2f}",
        ),
        _ENERGY_WIDTHS,
    )  # fmt: skip


def run_energy_scheme(name: str, config: ScenarioConfig, resolution: float, margin: float) -> Plan:
    """Run energy planner ``name`` of :data:`ENERGY_SCHEMES` on ``config`` (``ImportError`` if its
    module cannot be imported, e.g. ``sca-ee`` without cvxpy)."""
    kwargs = {"resolution": resolution, "margin": margin} if name in ("dp-ee", "dp-ee-multi") else {}
    return dataclasses.replace(registry.solve(name, config, **kwargs), scheme=name)


def energy_bound(plans: Sequence[Plan], config: ScenarioConfig) -> float | None:
    """The certified EE upper bound (bits/J) of ``baselines.energy_bound`` with the best plan as
    its reference, or None (printed why) when it cannot run."""
    try:
        bound = importlib.import_module("baselines.energy_bound")
    except ImportError as exc:
        print(f"bound: skipped: baselines.energy_bound cannot be imported ({exc})", file=sys.stderr)
        return None
    best = max(plans, key=lambda p: p.energy_efficiency)
    try:
        return float(bound.solve(config, reference=best).upper_bound)
    except (ValueError, RuntimeError) as exc:
        print(f"bound: failed: {exc}", file=sys.stderr)
        return None


def _main_energy(args: argparse.Namespace, parser: argparse.ArgumentParser, config: ScenarioConfig) -> int:
    handled = [n for n in ENERGY_SCHEMES if registry.PLANNERS[n].problem(config) is None]
    names = list(dict.fromkeys(args.scheme or handled))
    if bad := [n for n in names if n not in ENERGY_SCHEMES]:
        parser.error(
            f"argument --scheme: {', '.join(bad)} score the rate; with --objective energy_efficiency "
            f"choose from {', '.join(handled)}"
        )
    if bad := [n for n in names if n not in handled]:
        why = "; ".join(f"{n}: {registry.PLANNERS[n].problem(config)}" for n in bad)
        parser.error(f"argument --scheme: {why}; for this scenario choose from {', '.join(handled)}")
    print(_row(_ENERGY_HEADER, _ENERGY_WIDTHS))
    plans: list[Plan] = []
    failed = 0
    for name in names:
        t0 = time.perf_counter()
        try:
            plan = run_energy_scheme(name, config, args.resolution, args.margin)
        except ImportError as exc:
            print(f"{name}: skipped: {exc}", file=sys.stderr)
            failed += 1
            continue
        except (ValueError, RuntimeError) as exc:
            print(f"{name}: failed after {time.perf_counter() - t0:.1f} s: {exc}", file=sys.stderr)
            failed += 1
            continue
        print(format_energy_row(plan), flush=True)
        _save(args, config, plan)
        plans.append(plan)
    if plans and not args.no_bound and config.K > 1:
        grid = [p for p in plans if p.scheme == "dp-ee-multi"]
        if grid:
            ub = grid[0].info["ee_upper_bound"]
            shares = ", ".join(f"{p.scheme} {100 * p.energy_efficiency / ub:.2f}%" for p in plans)
            print(f"bound: dp-ee-multi's EE upper bound over its grid paths {ub:.2f} bits/J; {shares}")
    elif plans and not args.no_bound:
        ub = energy_bound(plans, config)
        if ub is not None:
            shares = ", ".join(f"{p.scheme} {100 * p.energy_efficiency / ub:.2f}%" for p in plans)
            print(
                f"bound: certified EE upper bound {ub:.2f} bits/J (no feasible trajectory beats it); {shares}"
            )
    _plot(args, config, plans)
    return 1 if failed else 0


def _save(args: argparse.Namespace, config: ScenarioConfig, plan: Plan) -> None:
    stem = f"{plan.scheme}_T{config.T:g}_M{config.M}"
    plan.save_json(args.out / f"{stem}.json")
    save_csv(args.out / f"{stem}.csv", plan.trajectory)


def _plot(args: argparse.Namespace, config: ScenarioConfig, plans: Sequence[Plan]) -> None:
    if plans and not args.no_plot:
        figure = args.out / f"plans_T{config.T:g}_M{config.M}_{'_'.join(p.scheme for p in plans)}.png"
        plot_plans(figure, config, plans)
        print(f"wrote {len(plans)} plan(s) (.json, .csv) and {figure}")


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; return the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    config = _config(args, parser)
    try:  # before any planning: an unwritable --out would fail only after the solves
        check_writable(args.out)
    except OSError as exc:
        parser.error(f"argument --out: {exc}")
    if args.objective == "energy_efficiency":
        return _main_energy(args, parser, config)
    names = list(dict.fromkeys(args.scheme or ["ia"]))  # keep order, drop repeats
    if bad := [n for n in names if n not in SCHEMES]:
        parser.error(f"argument --scheme: {', '.join(bad)} need --objective energy_efficiency")
    print(_row(_HEADER))
    plans: list[Plan] = []
    failed = 0
    for name in names:
        scheme = get_scheme(name)
        kwargs: dict = {"progress": args.progress} if scheme.planner not in ("fixed", "tour") else {}
        if scheme.planner in ("dp", "dp-star"):
            kwargs = {"resolution": args.resolution, "margin": args.margin, "progress": args.progress}
        if scheme.planner == "sca" and (reason := sca_unavailable_reason()) is not None:
            print(f"{name}: skipped: {reason}", file=sys.stderr)
            failed += 1
            continue
        t0 = time.perf_counter()
        try:
            plan = run_scheme(name, config, **kwargs)
        except (ValueError, RuntimeError, ImportError) as exc:
            print(f"{name}: failed after {time.perf_counter() - t0:.1f} s: {exc}", file=sys.stderr)
            failed += 1
            continue
        print(format_row(plan), flush=True)
        if "upper_bound" in plan.info:
            ub, gap = plan.info["upper_bound"], 100 * plan.info["gap"]
            print(f"{name}: certified upper bound {ub:.6f} bps/Hz (no feasible trajectory beats it; gap to "
                  f"this plan {gap:.3f}%)", flush=True)  # fmt: skip
        _save(args, config, plan)
        plans.append(plan)
    _plot(args, config, plans)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
