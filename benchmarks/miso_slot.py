"""The multi-antenna UAV's per-slot optimum against its certified bound and the baselines.

    python benchmarks/miso_slot.py            # N_t in {2, 4, 8}, K in {2, 4}, 2 slots each; the power sweep
    python benchmarks/miso_slot.py --quick    # one slot per pair, a 20 x 10 surface, a 3-point sweep

Each slot is the default scenario (M = 6000 elements, P = 0.1 W, -80 dBm) with K users drawn on
both sides of the IOS (|x| in [20, 120] m, |y| <= 80 m) and the UAV anywhere within 60 m of the
surface's centre (seeded). For the sum rate and the max-min rate it prints the means over the
slots (bps/Hz) of: AO (``ios_uav_env.model.miso_slot.optimise_slot``), the certified bound
(``miso.slot_bounds``; AO's share of it), MRT and ZF with the best user's aligned phases and with
random phases (equal powers; ZF needs N_t >= K), and TDMA (each user alone with its own surface, the
best shares), and AO's seconds per slot. The sweep: one fixed UAV and K = 4 users, N_t = 4, the sum
rate against the transmit power P.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ios_uav_env import ScenarioConfig  # noqa: E402  (after the root is on the path)
from ios_uav_env.model import miso, miso_slot  # noqa: E402
from ios_uav_env.model.array import ArrayConfig  # noqa: E402

COLUMNS = ("AO", "bound", "AO/bound", "MRT aligned", "ZF aligned", "MRT random", "ZF random", "TDMA", "AO s")


def draw_slot(rng: np.random.Generator, K: int, base: ScenarioConfig) -> tuple[ScenarioConfig, np.ndarray]:
    """K users on both sides of the surface and a UAV position (m), drawn from ``rng``."""
    sides = np.where(np.arange(K) % 2 == 0, -1.0, 1.0)
    nodes = tuple((float(s * rng.uniform(20.0, 120.0)), float(rng.uniform(-80.0, 80.0))) for s in sides)
    return base.replace(ground_nodes=nodes), rng.uniform(-60.0, 60.0, 2)


def row(channel: miso.SlotChannel, objective: str, seed: int) -> dict[str, float]:
    """One slot's figures for ``objective``."""
    start = time.perf_counter()
    best = miso_slot.optimise_slot(channel, objective, rng=np.random.default_rng(seed))
    seconds = time.perf_counter() - start
    bound = miso.slot_bounds(channel).of(objective)
    out = {"AO": best.value, "bound": bound, "AO/bound": best.value / bound, "AO s": seconds}
    return out | miso.baselines(channel, objective, np.random.default_rng(seed))


def fmt(values: dict[str, float]) -> str:
    return " ".join(f"{values[c]:>11.4f}" if np.isfinite(values[c]) else f"{'-':>11}" for c in COLUMNS)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="one slot per pair, a small surface, 3 powers")
    parser.add_argument("--slots", type=int, default=2, help="drawn slots per (N_t, K) (default 2)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    base = ScenarioConfig(ios_shape=(20, 10)) if args.quick else ScenarioConfig()
    slots = 1 if args.quick else args.slots
    print(f"surface {base.surface}, M = {base.M}, P = {base.power_w} W, noise {base.noise_dbm} dBm; "
          f"means over {slots} slot(s); bps/Hz")  # fmt: skip
    header = f"{'N_t':>3} {'K':>2} {'objective':>9} " + " ".join(f"{c:>11}" for c in COLUMNS)
    print(header)
    rng = np.random.default_rng(args.seed)
    for K in (2, 4):
        draws = [draw_slot(rng, K, base) for _ in range(slots)]
        for n_t in (2, 4, 8):
            channels = [miso.slot_channel(c, ArrayConfig(n_t=n_t), q) for c, q in draws]
            for objective in miso.SLOT_OBJECTIVES:
                rows = [row(ch, objective, args.seed + i) for i, ch in enumerate(channels)]
                mean = {c: float(np.mean([r[c] for r in rows])) for c in COLUMNS}
                print(f"{n_t:>3} {K:>2} {objective:>9} {fmt(mean)}")
    print()
    config, q = draw_slot(np.random.default_rng(args.seed + 1), 4, base)
    powers = (0.01, 0.1, 1.0) if args.quick else (0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0)
    print(f"sum rate against P: N_t = 4, K = 4, UAV at ({q[0]:.1f}, {q[1]:.1f}) m, nodes {config.nodes}")
    print(f"{'P (W)':>7} " + " ".join(f"{c:>11}" for c in COLUMNS))
    for power in powers:
        channel = miso.slot_channel(config.replace(power_w=power), ArrayConfig(n_t=4), q)
        print(f"{power:>7g} {fmt(row(channel, 'sum', args.seed))}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
