"""Moving, roughly known nodes: the clairvoyant bound and planner against MPC(k) and plan once.

    python benchmarks/mobile.py [--scenarios 3] [--seed 5] [--T 60] [--quick] [--single]

Scenarios: ``--scenarios`` seeded ones, K = 2..4 nodes uniform in [-150, 150] x [-100, 100] m,
pedestrian Gauss-Markov motion (``GaussMarkov()`` defaults), q0 = (-150, 20), qF = (150, 20) m,
T = ``--T`` s, reports with the default error (``REPORT_SIGMA``). Per scenario, one episode
(``baselines.mpc.run_online`` at the scenario's seed) draws the true paths; on them it prints
the clairvoyant bound (``dp_bound.clairvoyant_bound``), the clairvoyant tour
(``tour.solve(paths=...)``), MPC k = 1, MPC k = 10 and plan once: the max-min rate, % of the
bound and the planning seconds per episode. ``--quick``: M = 60 (ios_shape 10 x 6), 2
scenarios, T = 30 s.

``--single``: one node, scenarios of the mobile id ``ios_uav_env/IOSUAV-Mobile-v0`` (its ranges
drawn from ``--seed``, T = ``--T``; ``--quick``: T = 40 s), and two more rows played in that
env with the episode's seed: the env draws the same path, reports and measured-rate noise as
``run_online`` (tested), so every row faces the same truth and the same noise.
``hover at G (reports)`` flies ``HoverAt("ground")`` on the reported position, ``hover at G
(exact)`` on the true one.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a script: make the repository importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from baselines import tour  # noqa: E402
from baselines.dp_bound import clairvoyant_bound  # noqa: E402
from baselines.mpc import MPC, run_online  # noqa: E402
from ios_uav_env import ScenarioConfig  # noqa: E402
from ios_uav_env.model.mobility import GaussMarkov  # noqa: E402


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


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenarios", type=int, default=3)
    p.add_argument("--seed", type=int, default=5)
    p.add_argument("--T", type=float, default=60.0, help="mission duration (s)")
    p.add_argument("--bound-resolution", type=float, default=5.0, help="relaxed DP cell side (m)")
    p.add_argument("--quick", action="store_true", help="M = 60, 2 scenarios, T = 30 s")
    p.add_argument("--single", action="store_true", help="one node: the mobile id's scenarios and env rows")
    args = p.parse_args()
    draw = single_scenarios if args.single else scenarios
    quick_t = 40.0 if args.single else 30.0  # (the mobile id's q0 and qF are 800 m apart: T >= 34 s)
    cases = draw(2 if args.quick else args.scenarios, args.seed, quick_t if args.quick else args.T)
    if args.quick:
        cases = [(n, s, c.replace(ios_shape=(10, 6))) for n, s, c in cases]
    planners = (MPC(k=1), MPC(k=10), MPC(k=None))
    print(f"{'scenario':<8} {'K':>2} {'T':>4}  {'row':<16} {'rate':>9} {'% bound':>8} {'s/episode':>10}")
    shares: dict[str, list[float]] = {}
    for name, seed, config in cases:
        runs = [run_online(config, planner, seed) for planner in planners]
        truth = runs[0].paths
        t0 = time.perf_counter()
        bound = clairvoyant_bound(config, truth, resolution=args.bound_resolution)
        t_bound = time.perf_counter() - t0
        clair = tour.solve(config, paths=truth)
        rows = [("bound", bound, t_bound), ("clairvoyant tour", clair.mean_rate, clair.seconds)]
        rows += [(run.scheme, run.rate, run.seconds) for run in runs]
        if args.single:
            assert all(np.array_equal(run.paths, truth) for run in runs)  # one seed, one truth
            rows += env_rows(config, seed)
        for row, rate, secs in rows:
            pct = 100.0 * rate / bound if bound > 0 else float("nan")
            shares.setdefault(row, []).append(pct)
            print(
                f"{name:<8} {config.K:>2} {config.T:>4.0f}  {row:<16} {rate:>9.5f} {pct:>7.2f}% {secs:>10.2f}"
            )
    print()
    for row, pcts in shares.items():
        print(f"mean % of the bound  {row:<16} {np.mean(pcts):>7.2f}%  (min {np.min(pcts):.2f}%)")


if __name__ == "__main__":
    main()
