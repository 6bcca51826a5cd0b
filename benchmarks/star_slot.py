"""STAR surfaces, one slot: the certified per-slot optima of every protocol, phase model and access.

    python benchmarks/star_slot.py [--scenarios 12] [--seed 5] [--quick]

Scenarios (``--seed``): the UAV uniform in [-200, 200] x [-100, 100] m at the paper's altitude,
user r on its side of the surface plane and user t on the other, each at 20-200 m from the plane
and |y| <= 100 m; every other field at the paper's default (M = 6000; ``--quick``: 20 x 12
elements, 3 scenarios). Per surface (protocol / phase model / phase bits) and access scheme it
prints the mean max-min rate (bps/Hz) of the setting found, the mean and the largest certified gap
(upper bound - value), the mean rate with random phases, and the seconds per slot. Then, per
scenario, TS against ES and NOMA against TDMA (ES, independent phases), and the paper's IOS
(``fixed``: its own split, shared phases) beside them.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a script: make the repository importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ios_uav_env.model.config import ScenarioConfig  # noqa: E402
from ios_uav_env.model.star import StarChannels, StarSurface, star_channels  # noqa: E402
from ios_uav_env.model.star_slot import random_phase_value, slot_optimum  # noqa: E402

SURFACES = [
    StarSurface("es", "independent"),
    StarSurface("es", "coupled"),
    StarSurface("es", "shared"),
    StarSurface("ms", "independent"),
    StarSurface("ts", "independent"),
    StarSurface("es", "independent", 1),
    StarSurface("es", "independent", 2),
    StarSurface("es", "independent", 3),
    StarSurface("es", "coupled", 2),
    StarSurface("ms", "independent", 2),
    StarSurface("fixed", "shared"),
]


def scenarios(count: int, seed: int, config: ScenarioConfig) -> list[StarChannels]:
    """``count`` drawn geometries (see the module docstring) as per-element channels."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        q = rng.uniform([-200, -100], [200, 100])
        side = 1.0 if q[0] >= 0 else -1.0
        user_r = (side * rng.uniform(20, 200), rng.uniform(-100, 100))
        user_t = (-side * rng.uniform(20, 200), rng.uniform(-100, 100))
        out.append(star_channels(config, q, user_r, user_t))
    return out


def _name(surface: StarSurface) -> str:
    bits = "cont" if surface.bits is None else f"{surface.bits}-bit"
    return f"{surface.protocol}:{surface.phases}:{bits}"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenarios", type=int, default=12)
    p.add_argument("--seed", type=int, default=5)
    p.add_argument("--quick", action="store_true", help="M = 240 (ios_shape 20 x 12), 3 scenarios")
    args = p.parse_args()
    config = ScenarioConfig(ios_shape=(20, 12)) if args.quick else ScenarioConfig()
    channels = scenarios(3 if args.quick else args.scenarios, args.seed, config)
    rng = np.random.default_rng(args.seed)
    print(f"M = {config.M}, {len(channels)} scenarios (seed {args.seed}); max-min rate, bps/Hz")
    head = ("surface", "access", "rate", "mean gap", "max gap", "random", "s/slot")
    print(f"{head[0]:<22} " + " ".join(f"{h:>9}" for h in head[1:]))
    table: dict[tuple[str, str], list[float]] = {}
    for surface in SURFACES:
        for access in ("noma", "tdma"):
            values, gaps, randoms, seconds = [], [], [], 0.0
            for ch in channels:
                start = time.perf_counter()
                opt = slot_optimum(ch, surface, access)
                seconds += time.perf_counter() - start
                values.append(opt.value)
                gaps.append(opt.gap)
                randoms.append(random_phase_value(ch, surface, access, "maxmin", rng))
            table[_name(surface), access] = values
            print(
                f"{_name(surface):<22} {access:>9} {np.mean(values):9.5f} {np.mean(gaps):9.2e} "
                f"{np.max(gaps):9.2e} {np.mean(randoms):9.5f} {seconds / len(channels):9.3f}"
            )
    es_noma, es_tdma = table["es:independent:cont", "noma"], table["es:independent:cont", "tdma"]
    ts_noma, ios = table["ts:independent:cont", "noma"], table["fixed:shared:cont", "tdma"]
    print(f"\n{'scenario':>8} {'ES NOMA':>9} {'ES TDMA':>9} {'TS NOMA':>9} {'IOS TDMA':>9}  NOMA/TDMA  TS/ES")
    for i in range(len(channels)):
        print(
            f"{i:>8} {es_noma[i]:9.5f} {es_tdma[i]:9.5f} {ts_noma[i]:9.5f} {ios[i]:9.5f}  "
            f"{es_noma[i] / es_tdma[i]:9.4f} {ts_noma[i] / es_noma[i]:6.4f}"
        )
    wins = sum(a > b for a, b in zip(es_noma, es_tdma, strict=True))
    ts_wins = sum(a > b for a, b in zip(ts_noma, es_noma, strict=True))
    print(f"\nES: NOMA above TDMA in {wins} of {len(channels)} scenarios; TS above ES (NOMA) in {ts_wins}")


if __name__ == "__main__":
    main()
