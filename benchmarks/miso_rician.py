"""The multi-antenna UAV's per-slot optimum, MRT and the bound on Rician slot channels.

    python benchmarks/miso_rician.py              # 8 slots per cell, the sum rate
    python benchmarks/miso_rician.py --quick      # 2 slots per cell

The scenario is ``MISOControl-v0``'s (an IOS of M = M_y M_z elements, default 8 x 8, in the plane
x = 0, its centre 5 m up; noise -110 dBm; the ULA's axis along y) with its first K users (default
2: one served by reflection, one by transmission). The slots are UAV positions on its lines
(x ~ U[-250, -100] m, y ~ U[-150, 150] m, seeded). For kappa in {0, 3, 10} and the LoS channel
(kappa -> infinity), N_t in {1, 2, 4, 8} and both scatterings of ``ios_uav_env.model.miso_fading``
("link": the paper's eqs. (4)-(8) per antenna; "element": i.i.d. per element and antenna), each
slot's channel is one seeded draw (``rician_slot_channel``; the LoS rows are ``miso.slot_channel``,
the same for both scatterings) and the script prints the means over the slots (bps/Hz) of the
per-slot AO (``miso_slot.slot_optimum``, the env's reference), equal-power MRT with the best user's
aligned phases (``miso.baselines``), the certified bound (``miso.slot_bounds``) and AO's share of it.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ios_uav_env.envs.miso_control import ORIENTATION, USERS, X_RANGE, Y_SPAN  # noqa: E402
from ios_uav_env.envs.star_control import BASE_CONFIG  # noqa: E402
from ios_uav_env.model import miso, miso_fading, miso_slot  # noqa: E402
from ios_uav_env.model.array import ArrayConfig  # noqa: E402

KAPPAS: tuple[float | None, ...] = (0.0, 3.0, 10.0, None)  # None: the LoS channel
ANTENNAS = (1, 2, 4, 8)


def cell(kappa: float | None, n_t: int, scattering: str, args: argparse.Namespace) -> tuple[float, ...]:
    """Mean AO, MRT aligned and bound (bps/Hz) over the seeded slots of one (kappa, N_t, scattering)."""
    config = BASE_CONFIG.replace(ios_shape=tuple(args.elements), ground_nodes=USERS[: args.users])
    config = config if kappa is None else config.replace(kappa=kappa)
    array = ArrayConfig(n_t=n_t, orientation_rad=ORIENTATION)
    places, draws = np.random.default_rng(args.seed), np.random.default_rng(args.seed + 1)
    values = []
    for _ in range(args.slots):
        q = np.array([places.uniform(*X_RANGE), places.uniform(*Y_SPAN)])
        if kappa is None:
            slot = miso.slot_channel(config, array, q)
        else:
            slot = miso_fading.rician_slot_channel(config, array, q, draws, scattering)
        best = miso_slot.slot_optimum(slot, args.objective)
        mrt = miso.baselines(slot, args.objective, np.random.default_rng(0))["MRT aligned"]
        values.append((best.value, mrt, miso.slot_bounds(slot).of(args.objective)))
    return tuple(np.mean(values, axis=0))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="2 slots per cell")
    parser.add_argument("--slots", type=int, default=8, help="seeded slots per cell (default 8)")
    parser.add_argument(
        "--users", type=int, default=2, choices=range(1, len(USERS) + 1), help="K (default 2)"
    )
    parser.add_argument("--elements", type=int, nargs=2, default=(8, 8), help="M_y M_z (default 8 8)")
    parser.add_argument("--objective", default="sum", choices=miso.SLOT_OBJECTIVES)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    if args.quick:
        args.slots = 2
    print(
        f"K = {args.users}, M = {args.elements[0]} x {args.elements[1]}, objective {args.objective}, "
        f"{args.slots} slots per cell, seed {args.seed} (bps/Hz)"
    )
    print(f"{'scattering':>10} {'kappa':>6} {'N_t':>4} {'AO':>9} {'MRT al.':>9} {'bound':>9} {'AO/bound':>9}")
    for scattering in miso_fading.SCATTERINGS:
        for kappa in KAPPAS:
            for n_t in ANTENNAS:
                ao, mrt, bound = cell(kappa, n_t, scattering, args)
                label = "LoS" if kappa is None else f"{kappa:g}"
                figures = f"{ao:>9.4f} {mrt:>9.4f} {bound:>9.4f} {ao / bound:>9.3f}"
                print(f"{scattering:>10} {label:>6} {n_t:>4} {figures}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
