"""A multi-antenna UAV serving users at once (SDMA): the scorer's runtime, dp-miso-sdma, ao-miso-sdma, bounds.

    python benchmarks/miso_sdma.py [--resolution 12.5] [--quick] [--ao] [--users 2 3] [--ao-rounds 30]

Scenario: the SDMA ids' (``ios_uav_env.envs.miso_sdma.SDMA_CONFIG``: an 8 x 8 IOS low on a facade,
user 0 behind it at (10, -10) m, user 1 at (-120, -10) m, a 4-antenna UAV from (-250, -150) to
(-250, 150) m in 16 s). It prints ``score_plan`` of the straight line at T = 16 s and 40 s with
its seconds (``model.miso_sdma.sdma_maxmin``) and the TDMA schedule of the same flight (each user
alone, time-shared: the users-alone settings only); then ``dp-miso-sdma``'s plan at
``--resolution`` (its score, the certified bound and gap, the grid dual, the grid points whose
settings it computed, its seconds) and the env's steps per second (``score=False``).
``--quick``: a 25 m grid.

``--ao``: instead of the dp-miso-sdma line, on the SDMA ids' scenarios of ``--users`` users (default
2 and 3: ``MISOUAV-SDMA-v0`` and ``-K3-v0``), the straight line's score, dp-miso-sdma's plan (its score, the
certified bound ``sdma_bound`` and its seconds) and ``ao-miso-sdma`` from that plan (its score, its
gain over dp-miso-sdma, the gap to the bound, its rounds and accepted steps, its seconds, the
ascent's alone), ``--ao-rounds`` rounds at most (the planner's default seconds cap).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a script: make the repository importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import gymnasium as gym  # noqa: E402

from baselines.ao_miso_sdma import solve as ao_miso_sdma  # noqa: E402
from baselines.dp_miso_sdma import solve  # noqa: E402
from ios_uav_env import MISO_SDMA_ID, score_plan  # noqa: E402
from ios_uav_env.envs.miso_sdma import SDMA_CONFIG, SDMA_CONFIGS  # noqa: E402
from ios_uav_env.model.miso_sdma import slot_points  # noqa: E402
from ios_uav_env.model.schedule import maxmin_schedule  # noqa: E402


def compare_ao(resolution: float, rounds: int, users: list[int]) -> None:
    """The ``--ao`` lines (module docstring): straight line, dp-miso-sdma and ao-miso-sdma on the SDMA
    ids' scenario of each number of ``users`` (``SDMA_CONFIGS``: ``MISOUAV-SDMA-v0``, ``-K3-v0``,
    ``-K4-v0``)."""
    for config in (SDMA_CONFIGS[k] for k in users):
        line = score_plan(config, np.linspace(config.q0, config.qF, config.N)).rate
        dp = solve(config, resolution=resolution)
        ub = dp.info["upper_bound"]
        print(
            f"K = {config.K}: straight line {line:.4f} bps/Hz; dp-miso-sdma at {resolution:g} m "
            f"{dp.mean_rate:.4f} in {dp.seconds:.1f} s, bound {ub:.4f} (gap {100 * dp.info['gap']:.1f} %)"
        )
        ao = ao_miso_sdma(config, dp, max_rounds=rounds)
        info, gain = ao.info, 100 * (ao.mean_rate / dp.mean_rate - 1)
        print(
            f"K = {config.K}: ao-miso-sdma {ao.mean_rate:.4f} bps/Hz (+{gain:.2f} % over dp-miso-sdma), "
            f"gap {100 * info['gap']:.1f} % to {info['upper_bound']:.4f}, {info['rounds']} rounds "
            f"({info['accepted']} accepted, stop {info['stop']}), {ao.seconds:.1f} s "
            f"(ascent {info['ascent_seconds']:.1f} s), feasible {ao.feasible}"
        )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=float, default=12.5)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--ao", action="store_true", help="compare ao-miso-sdma with dp-miso-sdma")
    parser.add_argument(
        "--users", type=int, nargs="+", default=[2, 3], choices=sorted(SDMA_CONFIGS), help="K of --ao's ids"
    )
    parser.add_argument("--ao-rounds", type=int, default=30)
    args = parser.parse_args(argv)
    resolution = 25.0 if args.quick else args.resolution
    for T in (16.0, 40.0):
        config = SDMA_CONFIG.replace(T=T)
        line = np.linspace(config.q0, config.qF, config.N)
        t0 = time.perf_counter()
        rate = score_plan(config, line).rate
        seconds = time.perf_counter() - t0
        points, _ = slot_points(config, line)
        tdma = maxmin_schedule(points[:, -2:].sum(axis=1).T).value
        print(
            f"straight line, N = {config.N}: SDMA score {rate:.4f} bps/Hz in {seconds:.2f} s; TDMA {tdma:.4f}"
        )
    if args.ao:
        compare_ao(resolution, args.ao_rounds, args.users)
    else:
        plan = solve(SDMA_CONFIG, resolution=resolution)
        info = plan.info
        print(
            f"dp-miso-sdma at {resolution:g} m: {plan.mean_rate:.4f} bps/Hz, bound {info['upper_bound']:.4f} "
            f"(gap {100 * info['gap']:.1f} %), grid dual {info['grid_dual']:.4f}, {info['grid_points']} grid "
            f"points, {plan.seconds:.1f} s, feasible {plan.feasible}"
        )
    env = gym.make(MISO_SDMA_ID, score=False)
    rng = np.random.default_rng(0)
    env.reset(seed=0)
    steps, t0 = 0, time.perf_counter()
    for episode in range(3):
        env.reset(seed=episode)
        done = False
        while not done:
            _, _, done, _, _ = env.step(rng.uniform(-1, 1, 3).astype(np.float32))
            steps += 1
    print(f"{MISO_SDMA_ID} (score=False): {steps / (time.perf_counter() - t0):.1f} steps/s")


if __name__ == "__main__":
    main()
