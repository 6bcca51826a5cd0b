"""Moving, roughly known nodes: the clairvoyant bound and optimum against the online planners.

    python benchmarks/mobile.py [--scenarios 3] [--seed 5] [--T 60] [--quick] [--single] [--suite]

Scenarios: ``--scenarios`` seeded ones, K = 2..4 nodes uniform in [-150, 150] x [-100, 100] m,
pedestrian Gauss-Markov motion (``GaussMarkov()`` defaults), q0 = (-150, 20), qF = (150, 20) m,
T = ``--T`` s, reports with the default error (``REPORT_SIGMA``). Per scenario, one episode
(``baselines.mpc.run_online`` at the scenario's seed) draws the true paths; on them it prints
the clairvoyant bound (``dp_bound.clairvoyant_bound``), the clairvoyant optimum
(``baselines.dp_moving.solve``, the DP on the exact per-slot rate maps at ``--dp-resolution``;
K > 1: ``dp_bound.solve_multinode``'s plan, whose bound is the row ``bound``), the clairvoyant
tour (``tour.solve(paths=...)``), MPC k = 1, MPC k = 10 and plan once over the tour, and
MPC-DP k = 1 and k = 10 (``MPC(planner="dp")`` at ``--mpc-resolution`` with ``--mpc-refine``
corridor levels): the max-min rate, % of the bound, % of the clairvoyant optimum and the
planning seconds per episode. ``--quick``: M = 60 (ios_shape 10 x 6), 2 scenarios, T = 30 s.

``--single``: one node, scenarios of the mobile id ``ios_uav_env/IOSUAV-Mobile-v0`` (its ranges
drawn from ``--seed``, T = ``--T``; ``--quick``: T = 40 s), and two more rows played in that
env with the episode's seed: the env draws the same path, reports and measured-rate noise as
``run_online`` (tested), so every row faces the same truth and the same noise.
``hover at G (reports)`` flies ``HoverAt("ground")`` on the reported position, ``hover at G
(exact)`` on the true one (``baselines.references.mobile.track``, the suite's own rows).

``--suite``: the first ``--scenarios`` scenarios of the frozen ``mobile-v1`` suite (their
configs and episode seeds; ``--T``, ``--seed`` and ``--quick`` do not apply), with the env rows
of ``--single``; the bound is recomputed at the suite's own resolution unless
``--bound-resolution`` is given.

The summary gives per row the mean, 10th percentile and minimum % of the bound, the mean and
minimum % of the clairvoyant optimum and the mean seconds per episode, then the checks: the
bound above the clairvoyant optimum, the clairvoyant optimum at least 99.5% of every online row
on every scenario, and MPC-DP k = 1 against tracking on the reports (mean).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a script: make the repository importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from baselines import dp_moving, tour  # noqa: E402
from baselines.dp_bound import clairvoyant_bound  # noqa: E402
from baselines.mpc import DP_REFINE, DP_RESOLUTION, MPC, run_online  # noqa: E402
from ios_uav_env import ScenarioConfig  # noqa: E402
from ios_uav_env.model.mobility import GaussMarkov  # noqa: E402

BOUND, CLAIR = "bound", "clairvoyant DP"
#: The rows that know the true paths in advance (the rest are online).
OFFLINE = (BOUND, CLAIR, "clairvoyant tour")
#: The clairvoyant optimum must reach this share of every online row.
ONLINE_SHARE = 0.995


def scenarios(count: int, seed: int, horizon: float) -> list[tuple[str, int, ScenarioConfig]]:
    """``count`` seeded mobile scenarios (name, episode seed, config)."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        k = int(rng.integers(2, 5))
        nodes = tuple(
            (float(x), float(y)) for x, y in np.round(rng.uniform([-150, -100], [150, 100], (k, 2)))
        )
        config = ScenarioConfig(
            ground_nodes=nodes, T=horizon, q0=(-150.0, 20.0), qF=(150.0, 20.0), motion=GaussMarkov()
        )
        out.append((f"mob{i}", seed + i, config))
    return out


def single_scenarios(count: int, seed: int, horizon: float) -> list[tuple[str, int, ScenarioConfig]]:
    """``count`` one-node scenarios of the mobile id's family with T = ``horizon`` (name, seed, config)."""
    from ios_uav_env import MOBILE_ID, MOBILE_IDS
    from ios_uav_env.envs.random_env import RandomIOSUAVEnv
    from ios_uav_env.model.scenarios import sample_scenario

    options = {k: v for k, v in MOBILE_IDS[MOBILE_ID].items() if k != "knowledge"}
    ranges = RandomIOSUAVEnv(**options).ranges
    rng = np.random.default_rng(seed)
    return [(f"one{i}", seed + i, sample_scenario(rng, ranges).replace(T=horizon)) for i in range(count)]


def suite_scenarios(count: int) -> tuple[list[tuple[str, int, ScenarioConfig]], float]:
    """The first ``count`` scenarios of ``mobile-v1`` (name, episode seed, config) and the
    resolution (m) of its stored bound."""
    from ios_uav_env.benchmark.suite import load_suite

    suite = load_suite("mobile-v1")
    picked = suite.scenarios[:count]
    resolution = float(picked[0].reference["bound"]["resolution"])
    return [(f"sc{s.index}", int(s.seed), s.config) for s in picked], resolution


def env_rows(config: ScenarioConfig, seed: int) -> list[tuple[str, float, float]]:
    """HoverAt("ground") in the single-node env pinned to ``config``, reset with ``seed``, on the
    reports and on exact knowledge (``baselines.references.mobile.track``, the suite's own rows):
    (row, rate on the true path, seconds per episode)."""
    from baselines.references.mobile import track
    from ios_uav_env import score_plan
    from ios_uav_env.model.motion import node_paths

    truth = node_paths(config, np.random.default_rng(seed))
    rows = []
    for knowledge in ("reports", "exact"):
        q, secs = track(config, seed, knowledge)
        rows.append((f"hover at G ({knowledge})", score_plan(config, q, paths=truth).rate, secs))
    return rows


def scenario_rows(
    config: ScenarioConfig, seed: int, args: argparse.Namespace, env: bool
) -> list[tuple[str, float, float]]:
    """(row, rate on the true paths, seconds per episode) of every row on one scenario."""
    mpc_dp = {"planner": "dp", "resolution": args.mpc_resolution, "refine": args.mpc_refine}
    planners = (MPC(k=1), MPC(k=10), MPC(k=None), MPC(k=1, **mpc_dp), MPC(k=10, **mpc_dp))
    runs = [run_online(config, planner, seed) for planner in planners]
    truth = runs[0].paths
    assert all(np.array_equal(run.paths, truth) for run in runs)  # one seed, one truth
    t0 = time.perf_counter()
    if config.K == 1:
        bound = clairvoyant_bound(config, truth, resolution=args.bound_resolution)
        t_bound = time.perf_counter() - t0
        clair = dp_moving.solve(config, truth, resolution=args.dp_resolution, bound=False)
    else:  # one solve: the certified bound and the best DP plan under it
        clair = dp_moving.solve(
            config, truth, resolution=args.dp_resolution, bound_resolution=args.bound_resolution
        )
        bound, t_bound = clair.info["upper_bound"], clair.seconds
    clair_tour = tour.solve(config, paths=truth)
    rows = [(BOUND, bound, t_bound), (CLAIR, clair.mean_rate, clair.seconds)]
    rows.append(("clairvoyant tour", clair_tour.mean_rate, clair_tour.seconds))
    rows += [(run.scheme, run.rate, run.seconds) for run in runs]
    if env and config.K == 1:
        rows += env_rows(config, seed)
    return rows


def summary(table: dict[str, dict[str, tuple[float, float]]]) -> None:
    """Per row: % of the bound (mean, p10, min), % of the clairvoyant optimum (mean, min), mean
    seconds; then the checks (module docstring)."""
    names = list(dict.fromkeys(row for rows in table.values() for row in rows))
    print(f"\n{'row':<22} {'mean %UB':>9} {'p10 %UB':>8} {'min %UB':>8}", end="")
    print(f" {'mean %opt':>10} {'min %opt':>9} {'s/ep':>7}")
    for row in names:
        have = [rows for rows in table.values() if row in rows]
        ub = np.array([100.0 * r[row][0] / r[BOUND][0] for r in have])
        opt = np.array([100.0 * r[row][0] / r[CLAIR][0] for r in have])
        secs = np.mean([r[row][1] for r in have])
        print(
            f"{row:<22} {ub.mean():>8.2f}% {np.percentile(ub, 10):>7.2f}% {ub.min():>7.2f}% "
            f"{opt.mean():>9.2f}% {opt.min():>8.2f}% {secs:>7.2f}"
        )
    above = [name for name, r in table.items() if r[CLAIR][0] > r[BOUND][0]]
    print(f"\nbound >= clairvoyant DP on every scenario: {'yes' if not above else 'NO: ' + ', '.join(above)}")
    short = [
        f"{name} {row} ({100.0 * r[CLAIR][0] / r[row][0]:.2f}%)"
        for name, r in table.items()
        for row in r
        if row not in OFFLINE and r[CLAIR][0] < ONLINE_SHARE * r[row][0]
    ]
    print(
        f"clairvoyant DP >= {100 * ONLINE_SHARE:g}% of every online row on every scenario: "
        + ("yes" if not short else "NO: " + "; ".join(short))
    )
    tracked = [r for r in table.values() if "hover at G (reports)" in r]
    if tracked:
        dp1 = np.mean([100.0 * r["mpc-dp-k1"][0] / r[BOUND][0] for r in tracked])
        rep = np.mean([100.0 * r["hover at G (reports)"][0] / r[BOUND][0] for r in tracked])
        verdict = "at least" if dp1 >= rep else "BELOW"
        print(f"mpc-dp-k1 mean {dp1:.2f}% of the bound: {verdict} tracking the reports ({rep:.2f}%)")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenarios", type=int, default=3)
    p.add_argument("--seed", type=int, default=5)
    p.add_argument("--T", type=float, default=60.0, help="mission duration (s)")
    p.add_argument("--bound-resolution", type=float, default=None, help="relaxed DP cell side (m; 5)")
    p.add_argument("--dp-resolution", type=float, default=2.5, help="clairvoyant DP grid spacing (m)")
    p.add_argument("--mpc-resolution", type=float, default=DP_RESOLUTION, help="MPC-DP grid spacing (m)")
    p.add_argument("--mpc-refine", type=int, default=DP_REFINE, help="MPC-DP corridor refinement levels")
    p.add_argument("--quick", action="store_true", help="M = 60, 2 scenarios, T = 30 s")
    p.add_argument("--single", action="store_true", help="one node: the mobile id's scenarios and env rows")
    p.add_argument("--suite", action="store_true", help="the mobile-v1 suite's first --scenarios scenarios")
    args = p.parse_args()
    if args.suite:
        cases, suite_resolution = suite_scenarios(args.scenarios)
        if args.bound_resolution is None:
            args.bound_resolution = suite_resolution
    else:
        draw = single_scenarios if args.single else scenarios
        quick_t = 40.0 if args.single else 30.0  # (the mobile id's q0 and qF are 800 m apart: T >= 34 s)
        cases = draw(2 if args.quick else args.scenarios, args.seed, quick_t if args.quick else args.T)
        if args.quick:
            cases = [(n, s, c.replace(ios_shape=(10, 6))) for n, s, c in cases]
    if args.bound_resolution is None:
        args.bound_resolution = 5.0
    print(f"{'scenario':<8} {'K':>2} {'T':>4}  {'row':<22} {'rate':>9}", end="")
    print(f" {'% bound':>8} {'% opt':>8} {'s/episode':>10}")
    table: dict[str, dict[str, tuple[float, float]]] = {}
    for name, seed, config in cases:
        rows = scenario_rows(config, seed, args, env=args.single or args.suite)
        table[name] = {row: (rate, secs) for row, rate, secs in rows}
        bound, clair = table[name][BOUND][0], table[name][CLAIR][0]
        for row, rate, secs in rows:
            pct = 100.0 * rate / bound if bound > 0 else float("nan")
            opt = 100.0 * rate / clair if clair > 0 else float("nan")
            print(
                f"{name:<8} {config.K:>2} {config.T:>4.0f}  {row:<22} {rate:>9.5f} {pct:>7.2f}% {opt:>7.2f}% "
                f"{secs:>10.2f}",
                flush=True,
            )
    summary(table)


if __name__ == "__main__":
    main()
