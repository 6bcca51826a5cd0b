"""Several ground nodes: tour heuristic vs SCA (BCD), the DP's best plan and certified bound.

    python benchmarks/multinode.py [--scenarios 8] [--seed 13] [--bound-resolution 2.5] [--quick]

Scenarios: the default 3-node scenario (model.md) at T = 150 s, then ``--scenarios`` random
ones drawn with ``--seed``: K = 2..4 nodes uniform in [-250, 250] x [-150, 150] m, IOS or
RIS, T in {100, 110, ..., 200} s, every other field at the paper's default (M = 6000).
Per scenario it prints the tour's and SCA's max-min rates, SCA's seconds (its multi-start
includes the DP's plan), the DP's best plan, the certified upper bound, the certified gap
upper_bound / best plan - 1, and the scorer's worst |primal - dual| over the plans (the LP
value against g(w) of its dual weights: two independent computations).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a script: make the repository importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import ios_uav_env as ie  # noqa: E402
from baselines import sca, tour  # noqa: E402
from baselines.dp_bound import solve_multinode  # noqa: E402
from ios_uav_env import ScenarioConfig  # noqa: E402

DEFAULT_NODES = ((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0))


def scenarios(count: int, seed: int) -> list[tuple[str, ScenarioConfig]]:
    """The default 3-node scenario and ``count`` random ones (fixed ``seed``)."""
    out = [("default-3", ScenarioConfig(ground_nodes=DEFAULT_NODES))]
    rng = np.random.default_rng(seed)
    for i in range(count):
        k = int(rng.integers(2, 5))
        nodes = tuple(
            (float(x), float(y)) for x, y in np.round(rng.uniform([-250, -150], [250, 150], (k, 2)))
        )
        surface = ("ios", "ris")[i % 2]
        t = float(rng.choice(np.arange(100, 201, 10)))
        out.append((f"rand{i}", ScenarioConfig(ground_nodes=nodes, surface=surface, T=t)))
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenarios", type=int, default=8)
    p.add_argument("--seed", type=int, default=13)
    p.add_argument("--resolution", type=float, default=5.0, help="DP plans' grid (m)")
    p.add_argument("--bound-resolution", type=float, default=2.5, help="relaxed DP cell side (m)")
    p.add_argument("--quick", action="store_true", help="M = 60 (ios_shape 10 x 6), 2 random scenarios")
    args = p.parse_args()
    cases = scenarios(2 if args.quick else args.scenarios, args.seed)
    if args.quick:
        cases = [(n, c.replace(ios_shape=(10, 6))) for n, c in cases]
    head = (f"{'scenario':<10} {'K':>2} {'surf':>4} {'T':>4}  {'tour':>9} {'SCA':>9} {'SCA s':>6} "
            f"{'DP plan':>9} {'bound':>9} {'gap %':>7} {'DP s':>6} {'|P-D|':>8}  nodes")  # fmt: skip
    print(head)
    for name, config in cases:
        t_plan = tour.solve(config)
        d_plan = solve_multinode(config, resolution=args.resolution, bound_resolution=args.bound_resolution)
        s_plan = sca.solve(config, init=[d_plan.trajectory])
        plans = (t_plan, d_plan, s_plan)
        assert all(pl.feasible for pl in plans), name
        worst = max(abs(ie.schedule(config, pl.trajectory).gap) for pl in plans)
        best = max(pl.mean_rate for pl in plans)
        ub = d_plan.info["upper_bound"]
        assert ub >= best, (name, ub, best)
        flag = "" if s_plan.mean_rate >= t_plan.mean_rate - 1e-12 else "  SCA < tour!"
        print(
            f"{name:<10} {config.K:>2} {config.surface:>4} {config.T:>4g}  {t_plan.mean_rate:9.6f} "
            f"{s_plan.mean_rate:9.6f} {s_plan.seconds:6.1f} {d_plan.mean_rate:9.6f} {ub:9.6f} "
            f"{100 * (ub / best - 1):7.3f} {d_plan.seconds:6.1f} {worst:8.1e}  {list(config.nodes)}{flag}",
            flush=True,
        )


if __name__ == "__main__":
    t0 = time.perf_counter()
    main()
    print(f"total {time.perf_counter() - t0:.0f} s")
