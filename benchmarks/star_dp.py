"""A STAR surface serving a user on each side at once (NOMA): the dp-star planner and its bound.

    python benchmarks/star_dp.py [--resolution 5] [--bound-resolution 2.5] [--flights 20] [--quick]
                                 [--ao] [--limit K]

Scenarios: the STARControl scenario (``ios_uav_env.envs.star_control.BASE_CONFIG``: an 8 x 8
surface low on a facade, its two users 5 m either side of the plane, -110 dBm, the UAV from
(-250, -150) to (-250, 150) m in 16 s) as a STAR surface with energy splitting, independent phases
and NOMA, at M = 64, 256 and 1024 elements; and the same with user r moved next to the flight
((-200, 0) m: unequal SNRs, where NOMA gains over TDMA). Per scenario it prints dp-star's plan
(``score_plan``), the best candidate's score before the refinement and which candidate it was,
the TDMA plan (``dp-sta``) by its TDMA score and by its NOMA score, the certified upper bound and
the gap to the plan, the grid DP's dual (no grid path scores more), the best of ``--flights``
random feasible flights (must stay below the bound) and the planner's seconds. ``--quick``:
M = 16 and a 12.5 m grid, one scenario. ``--ao``: after each row, ``ao-star``'s polish of that
plan (``baselines.ao_star``: AO with a trust-region SCA step on a continuous trajectory), its
score, gain over dp-star, gap to the same bound, rounds and seconds. ``--limit K``: the first K
scenarios only (``--limit 1``: STARControl at M = 64).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a script: make the repository importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from baselines.ao_star import solve as ao_star  # noqa: E402
from baselines.dp_star import solve  # noqa: E402
from ios_uav_env import ScenarioConfig, check_trajectory, score_plan  # noqa: E402
from ios_uav_env.envs.star_control import BASE_CONFIG  # noqa: E402

HEADER = (
    "scenario",
    "M",
    "dp-star",
    "candidate",
    "source",
    "tdma",
    "tdma@noma",
    "bound",
    "gap %",
    "grid dual",
    "random",
    "s",
)


def random_flights(config: ScenarioConfig, count: int, seed: int) -> list[np.ndarray]:
    """Feasible flights: the straight line plus a random-walk bridge (0 at both ends) whose steps
    keep every move within D."""
    rng = np.random.default_rng(seed)
    line = np.linspace(config.q0, config.qF, config.N)
    spare = (config.D - np.linalg.norm(line[1] - line[0])) / 2 * (1 - 1e-9)
    out = []
    for _ in range(count):
        angle, size = rng.uniform(0, 2 * np.pi, config.N - 1), spare * rng.uniform(0, 1, config.N - 1)
        steps = size[:, None] * np.column_stack([np.cos(angle), np.sin(angle)])
        walk = np.vstack([[0.0, 0.0], np.cumsum(steps, axis=0)])
        out.append(line + walk - np.linspace(0, 1, config.N)[:, None] * walk[-1])
    return out


def scenarios(quick: bool) -> list[tuple[str, ScenarioConfig]]:
    base = BASE_CONFIG.replace(surface="star", star_access="noma")
    if quick:
        return [("star-control", base.replace(ios_shape=(4, 4)))]
    near = base.replace(ground_nodes=((-200.0, 0.0), base.nodes[1]))
    shapes = ((8, 8), (16, 16), (32, 32))
    return [("star-control", base.replace(ios_shape=s)) for s in shapes] + [
        ("user-r-near", near.replace(ios_shape=s)) for s in shapes[:2]
    ]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--resolution", type=float, default=5.0, help="the plain DPs' grid (m)")
    p.add_argument("--bound-resolution", type=float, default=None, help="the bound's cell side (m)")
    p.add_argument("--flights", type=int, default=20, help="random feasible flights per scenario")
    p.add_argument("--quick", action="store_true", help="one small scenario on a coarse grid")
    p.add_argument("--ao", action="store_true", help="also polish each plan with ao-star")
    p.add_argument("--limit", type=int, default=None, help="the first LIMIT scenarios only")
    args = p.parse_args(argv)
    resolution = 12.5 if args.quick else args.resolution
    print("  ".join(f"{h:>11}" for h in HEADER))
    for name, config in scenarios(args.quick)[: args.limit]:
        t0 = time.perf_counter()
        plan = solve(config, resolution=resolution, bound_resolution=args.bound_resolution)
        seconds = time.perf_counter() - t0
        tdma = plan.info["candidates"]["tdma"]
        flights = random_flights(config, args.flights, seed=0)
        assert all(check_trajectory(config, q).feasible for q in flights)
        random = max(score_plan(config, q).rate for q in flights)
        ub = plan.info["upper_bound"]
        if not (plan.feasible and plan.mean_rate <= ub and random <= ub):
            raise SystemExit(f"{name}: a plan or a flight above the certified bound, or an infeasible plan")
        cells = (
            name, config.M, f"{plan.mean_rate:.5f}", f"{plan.info['candidate_rate']:.5f}",
            plan.info["plan_source"],
            f"{plan.info['tdma_rate']:.5f}", f"{tdma:.5f}", f"{ub:.5f}", f"{100 * plan.info['gap']:.2f}",
            f"{plan.info['grid_dual']:.5f}", f"{random:.5f}", f"{seconds:.1f}",
        )  # fmt: skip
        print("  ".join(f"{c:>11}" for c in map(str, cells)), flush=True)
        if args.ao:
            ao = ao_star(config, plan)
            if not (ao.feasible and plan.mean_rate <= ao.mean_rate <= ub):
                raise SystemExit(f"{name}: ao-star below its start, above the bound or infeasible")
            gain = 100 * (ao.mean_rate / plan.mean_rate - 1)
            print(
                f"{'':>11}  ao-star {ao.mean_rate:.5f} (+{gain:.2f} % over "
                f"dp-star, gap {100 * ao.info['gap']:.2f} %), {ao.info['rounds']} rounds, "
                f"{ao.info['accepted']} accepted, stop {ao.info['stop']}, {ao.seconds:.1f} s",
                flush=True,
            )
    print(f"grid {resolution:g} m, bound cells {plan.info['bound_resolution']:g} m")
    return 0


if __name__ == "__main__":
    sys.exit(main())
