"""What ``ios_uav_env/MISOControl-v0`` costs: a step without the per-slot AO, and the AO of a slot.

    python benchmarks/miso_control.py            # N_t in {2, 4, 8}, K in {2, 4}, M in {16, 64}
    python benchmarks/miso_control.py --quick    # N_t = 2, K = 2, M = 16

For each (N_t, K, M) and objective it prints: ``step ms``, the env's step with random actions and
``optimum=False`` (what training pays; resets included, amortised over the episode), and ``AO s``,
the seconds a slot of ``optimum=True`` adds (``miso_slot.slot_optimum`` warm-started from the
previous slot, and the baselines), over one episode (seed 0); ``AO/bound``, the AO value summed over
that episode as a share of the certified bound's sum. The first call of each compiled kernel is
made before timing.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ios_uav_env.envs.miso_control import N_SLOTS, MISOControlEnv  # noqa: E402  (after the root is on the path)

COLUMNS = ("step ms", "AO s", "AO/bound")


def measure(n_t: int, k: int, m: int, objective: str, episodes: int) -> dict[str, float]:
    """One row: the step's milliseconds without the AO, the AO's seconds a slot, AO / bound."""
    side = int(round(m**0.5))
    kwargs = {"antennas": n_t, "users": k, "elements": (side, m // side), "objective": objective}
    rng = np.random.default_rng(0)
    plain = MISOControlEnv(**kwargs, optimum=False)
    start = time.perf_counter()
    for episode in range(episodes):
        plain.reset(seed=episode)
        for _ in range(N_SLOTS):
            plain.step(rng.uniform(-1.0, 1.0, plain.action_space.shape))
    step = (time.perf_counter() - start) / (episodes * N_SLOTS)
    scored = MISOControlEnv(**kwargs)
    scored.reset(seed=0)
    start = time.perf_counter()
    for _ in range(N_SLOTS):
        _, _, _, _, info = scored.step(rng.uniform(-1.0, 1.0, scored.action_space.shape))
    ao = (time.perf_counter() - start) / N_SLOTS - step
    return {"step ms": 1e3 * step, "AO s": ao, "AO/bound": info["optimum_return"] / info["bound_return"]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="N_t = 2, K = 2, M = 16 only")
    parser.add_argument("--episodes", type=int, default=4, help="episodes of the step's timing (default 4)")
    args = parser.parse_args(argv)
    antennas, users, elements = ([2], [2], [16]) if args.quick else ([2, 4, 8], [2, 4], [16, 64])
    measure(2, 2, 16, "sum", 1)  # the compiled kernels' first calls
    measure(2, 2, 16, "maxmin", 1)
    print(f"{'N_t':>3} {'K':>2} {'M':>3} {'objective':>9} " + " ".join(f"{c:>9}" for c in COLUMNS))
    for n_t in antennas:
        for k in users:
            for m in elements:
                for objective in ("sum", "maxmin"):
                    row = measure(n_t, k, m, objective, args.episodes)
                    cells = f"{row['step ms']:9.2f} {row['AO s']:9.3f} {row['AO/bound']:9.3f}"
                    print(f"{n_t:>3} {k:>2} {m:>3} {objective:>9} {cells}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
