"""NOMA (SIC in the stated decoding order) against SDMA, TDMA and the certified bound, per slot.

    python benchmarks/miso_noma.py            # a grid of (N_t, K, M), 3 drawn slots each
    python benchmarks/miso_noma.py --quick    # two grid points, one slot

Each slot is a ``MISOControl-v0`` slot (``ios_uav_env.envs.miso_control``: the small IOS, the
first K of its users, the UAV at slot 8 of the line x ~ U[-250, -100] m drawn by ``reset(seed=s)``,
s = 0, 1, ...). For the sum rate and the max-min rate it prints the means over the slots (bps/Hz) of:
the NOMA AO (``miso_noma_slot.noma_optimum``, the default decoding order: ascending single-user gain
bound), the SDMA AO (``miso_slot.slot_optimum``), TDMA (``miso.tdma_value``: each user alone with its
own surface, the best shares), the certified bound (``miso.slot_bounds``, which bounds both), and
each AO's seconds per slot.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ios_uav_env.envs.miso_control import MISOControlEnv  # noqa: E402  (after the root is on the path)
from ios_uav_env.model import miso, miso_noma_slot, miso_slot  # noqa: E402

#: (N_t, K, (M_y, M_z)) of the default grid.
GRID = ((1, 2, (4, 4)), (2, 2, (4, 4)), (4, 2, (4, 4)), (2, 3, (4, 4)), (4, 3, (4, 4)), (4, 4, (4, 4)),
        (4, 2, (8, 8)))  # fmt: skip
QUICK = ((2, 2, (2, 2)), (2, 3, (2, 2)))
COLUMNS = ("NOMA", "SDMA", "TDMA", "bound", "NOMA/bound", "NOMA s", "SDMA s")


def slots(n_t: int, K: int, shape: tuple[int, int], count: int) -> list[miso.SlotChannel]:
    """Slot 8 of ``count`` seeded episodes of ``MISOControl-v0`` with these settings."""
    env = MISOControlEnv(antennas=n_t, users=K, elements=shape, optimum=False)
    out = []
    for seed in range(count):
        env.reset(seed=seed)
        out.append(env.channels[8])
    return out


def row(channel: miso.SlotChannel, objective: str) -> dict[str, float]:
    """One slot's figures for ``objective``."""
    start = time.perf_counter()
    noma = miso_noma_slot.noma_optimum(channel, objective).value
    middle = time.perf_counter()
    sdma = miso_slot.slot_optimum(channel, objective).value
    end = time.perf_counter()
    bound = miso.slot_bounds(channel).of(objective)
    tdma = miso.tdma_value(miso.tdma_rates(channel), objective)
    return {"NOMA": noma, "SDMA": sdma, "TDMA": tdma, "bound": bound, "NOMA/bound": noma / bound,
            "NOMA s": middle - start, "SDMA s": end - middle}  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="two grid points, one slot")
    parser.add_argument("--slots", type=int, default=3, help="drawn slots per grid point (default 3)")
    args = parser.parse_args(argv)
    grid, count = (QUICK, 1) if args.quick else (GRID, args.slots)
    if count < 1:
        parser.error(f"--slots must be an integer >= 1, got {count}")
    miso_noma_slot.noma_optimum(slots(2, 2, (2, 2), 1)[0], "maxmin")  # compile the kernels first
    for objective in miso.SLOT_OBJECTIVES:
        print(f"\n{objective} rate (bps/Hz), mean over {count} slot(s)")
        print(f"{'N_t':>4} {'K':>2} {'M':>3} " + " ".join(f"{c:>10}" for c in COLUMNS))
        for n_t, K, shape in grid:
            rows = [row(ch, objective) for ch in slots(n_t, K, shape, count)]
            mean = {c: float(np.mean([r[c] for r in rows])) for c in COLUMNS}
            print(
                f"{n_t:>4} {K:>2} {shape[0] * shape[1]:>3} " + " ".join(f"{mean[c]:>10.4f}" for c in COLUMNS)
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
