"""The multi-antenna UAV hovering at one point: sum rate (and max-min rate) against the transmit power.

    python benchmarks/miso_sweep.py                          # N_t = 4, K in {2, 4}, P = -10 ... 60 dBm
    python benchmarks/miso_sweep.py --plot sweep.png         # and the figure (matplotlib; a new file)
    python benchmarks/miso_sweep.py --quick                  # a 10 x 6 surface, K = 2, 3 powers

The default: the paper's scenario (noise -80 dBm, UAV altitude 100 m, the IOS centred at
(0, 0, 40) m in the plane x = 0) with a 40 x 30 surface (M = 1200, 1 m x 0.75 m), the UAV hovering
at (-60, 0) m with a 4-antenna ULA along x (lambda / 2, ``steering="centre"``), and the users
(-120, -20), (110, -10), (-40, -40), (40, 30) m (the first K): on the UAV's side (served by
reflection) and across the IOS (by transmission). The surface's paths there are 0.05 to 1.9 times
the direct ones in amplitude; a 10 x 10 surface's would be 0.004 to 0.16 times (at most 1.3 dB
of gain when aligned), too weak for the phases to matter much.

For each K and objective it prints, per power P (dBm; eta = P / sigma^2, in dB P - noise_dbm):
the largest single-user receive SNR max_k G_k (dB), the rates (bps/Hz) of AO (the per-slot optimum
of ``ios_uav_env.model.miso_slot``, several starts and the previous power's solution), MRT and ZF
with the best user's aligned phases and with random phases (equal powers), TDMA, the certified
bound (``miso.slot_bounds``), AO's gap to it and AO's seconds; then the slopes between the two
highest powers (bps/Hz per dB) against K log2(10) / 10 (K streams), and at the lowest power
equal-power MRT's share of the bound against its predicted limit (``miso_sweep`` docstring).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ios_uav_env import ScenarioConfig  # noqa: E402  (after the root is on the path)
from ios_uav_env.model import miso  # noqa: E402
from ios_uav_env.model.array import ArrayConfig  # noqa: E402
from ios_uav_env.model.miso_sweep import (  # noqa: E402
    SCHEMES,
    PowerSweep,
    dof_slope,
    low_power_mrt_ratio,
    power_sweep,
    sweep_channel,
)

USERS = ((-120.0, -20.0), (110.0, -10.0), (-40.0, -40.0), (40.0, 30.0))  # m, the first K are served
HOVER = (-60.0, 0.0)  # m, the UAV's hover point (altitude: the scenario's 100 m)
SURFACE = (40, 30)  # (M_y, M_z) elements
POWERS = tuple(float(p) for p in range(-10, 61, 5))  # dBm
COLUMNS = ("G max dB", *SCHEMES, "bound", "AO gap", "AO s")
DECIMALS = {"G max dB": 1, "AO s": 2}  # the others: 4 (bps/Hz)

try:
    from tqdm import tqdm
except ImportError:  # pragma: no cover - tqdm comes with the planners and rl extras
    tqdm = None


def setup(K: int, quick: bool = False) -> ScenarioConfig:
    """The default scenario with the first ``K`` users (``quick``: a 10 x 6 surface)."""
    if not 1 <= K <= len(USERS):
        raise ValueError(f"K must be an integer in [1, {len(USERS)}] (users), got {K!r}")
    return ScenarioConfig(ios_shape=(10, 6) if quick else SURFACE, ground_nodes=USERS[:K])


def _cell(value: float, decimals: int) -> str:
    return f"{value:>11.{decimals}f}" if np.isfinite(value) else f"{'-':>11}"


def table(sweep: PowerSweep) -> list[str]:
    """The rows of one sweep: P, then :data:`COLUMNS`."""
    rows = []
    for i, p in enumerate(sweep.powers_dbm):
        cells = {"G max dB": 10 * np.log10(sweep.gains[i].max()), "bound": sweep.bound[i]}
        cells |= {name: sweep.values[name][i] for name in SCHEMES}
        gap = sweep.gap("AO")[i]  # (a rounding-sized negative gap printed as 0)
        cells |= {"AO gap": gap if abs(gap) > 1e-12 * sweep.bound[i] else 0.0, "AO s": sweep.seconds[i]}
        text = [_cell(cells[c], DECIMALS.get(c, 4)) for c in COLUMNS]
        rows.append(f"{p:>6g} " + " ".join(text))
    return rows


def summary(sweep: PowerSweep, config: ScenarioConfig, array: ArrayConfig) -> list[str]:
    """The high-power slopes and the low-power MRT share of one sweep."""
    if sweep.powers_dbm.size < 2:
        return []
    top = ", ".join(
        f"{name} {sweep.slope(name)[-1]:.3f}" for name in ("AO", "MRT aligned", "ZF aligned", "TDMA", "bound")
    )
    streams = min(config.K, array.n_t) if sweep.objective == "sum" else 1
    lines = [f"slope {sweep.powers_dbm[-2]:g} -> {sweep.powers_dbm[-1]:g} dBm (bps/Hz per dB): {top}; "
             f"{streams} stream(s): {dof_slope(streams):.3f}"]  # fmt: skip
    if sweep.objective == "sum":
        low = sweep_channel(config, array, HOVER, float(sweep.powers_dbm[0]))
        share, tdma = (sweep.values[name][0] / sweep.bound[0] for name in ("MRT aligned", "TDMA"))
        lines.append(
            f"at {sweep.powers_dbm[0]:g} dBm: MRT aligned / bound {share:.4f} "
            f"(low-power limit {low_power_mrt_ratio(low):.4f}), TDMA / bound {tdma:.6f}"
        )
    return lines


def plot(sweeps: dict[tuple[int, str], PowerSweep], path: Path, n_t: int) -> Path:
    """The curves, one panel per (objective, K), written atomically to ``path`` (PNG)."""
    from ios_uav_env.plotting import figure_classes, save_png

    figure_cls, canvas_cls = figure_classes()
    users = sorted({K for K, _ in sweeps})
    objectives = [o for o in miso.SLOT_OBJECTIVES if any(obj == o for _, obj in sweeps)]
    fig = figure_cls(figsize=(3.6 * len(users), 2.9 * len(objectives)), dpi=90)
    canvas = canvas_cls(fig)
    styles = {
        "AO": "-o",
        "MRT aligned": "-s",
        "ZF aligned": "-^",
        "MRT random": ":s",
        "ZF random": ":^",
        "TDMA": "-x",
    }
    for r, objective in enumerate(objectives):
        for c, K in enumerate(users):
            ax = fig.add_subplot(len(objectives), len(users), r * len(users) + c + 1)
            sweep = sweeps[(K, objective)]
            for name in SCHEMES:
                ax.plot(sweep.powers_dbm, sweep.values[name], styles[name], ms=3, lw=1, label=name)
            ax.plot(sweep.powers_dbm, sweep.bound, "k--", lw=1, label="bound")
            ax.set_title(f"N_t = {n_t}, K = {K}", fontsize=8)
            ax.set_xlabel("P (dBm)", fontsize=8)
            ax.set_ylabel(f"{'sum' if objective == 'sum' else 'max-min'} rate (bps/Hz)", fontsize=8)
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3)
    fig.axes[0].legend(fontsize=6, loc="upper left")
    fig.tight_layout()
    canvas.draw()
    return save_png(np.array(canvas.buffer_rgba())[:, :, :3], path, colors=64)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="a 10 x 6 surface, K = 2, powers 0, 20, 40 dBm")
    parser.add_argument("--n-t", type=int, default=4, help="UAV antennas N_t (default 4)")
    parser.add_argument("--users", type=int, nargs="+", default=None, help="K values (default 2 4)")
    parser.add_argument("--powers", type=float, nargs="+", default=None, help="P in dBm (default -10 ... 60)")
    parser.add_argument(
        "--objectives", choices=miso.SLOT_OBJECTIVES, nargs="+", default=list(miso.SLOT_OBJECTIVES)
    )
    parser.add_argument("--random-starts", type=int, default=2, help="AO's random phase starts (default 2)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--plot", type=Path, default=None, help="draw the curves here (PNG; never overwritten)"
    )
    args = parser.parse_args(argv)
    if args.plot is not None and args.plot.exists():
        parser.error(f"--plot {args.plot} exists: give a new path (figures are never overwritten)")
    users = args.users or ([2] if args.quick else [2, 4])
    powers = args.powers or ([0.0, 20.0, 40.0] if args.quick else list(POWERS))
    try:
        array = ArrayConfig(n_t=args.n_t)
        configs = {K: setup(K, args.quick) for K in users}
    except ValueError as err:
        parser.error(str(err))
    base = configs[users[0]]
    print(f"surface {base.ios_shape[0]} x {base.ios_shape[1]} (M = {base.M}), UAV at {HOVER} m, "
          f"altitude {base.uav_altitude:g} m, N_t = {array.n_t} (ULA along x, lambda/2), noise "
          f"{base.noise_dbm:g} dBm; eta (dB) = P (dBm) - ({base.noise_dbm:g}); rates in bps/Hz")  # fmt: skip
    total = len(users) * len(args.objectives) * len(powers)
    bar = tqdm(total=total, desc="powers", unit="P", mininterval=1.0) if tqdm is not None else None
    sweeps: dict[tuple[int, str], PowerSweep] = {}
    for K in users:
        config = configs[K]
        for objective in args.objectives:
            sweep = power_sweep(
                config, array, HOVER, powers, objective, random_starts=args.random_starts, seed=args.seed,
                on_power=(lambda _p: bar.update(1)) if bar is not None else None,
            )  # fmt: skip
            sweeps[(K, objective)] = sweep
            lines = [
                "",
                f"K = {K} users at {', '.join(str(u) for u in config.nodes)}; {objective} rate",
                f"{'P dBm':>6} " + " ".join(f"{c:>11}" for c in COLUMNS),
                *table(sweep),
                *summary(sweep, config, array),
            ]
            (tqdm.write if bar is not None else print)("\n".join(lines))
    if bar is not None:
        bar.close()
    if args.plot is not None:
        print(f"plot: {plot(sweeps, args.plot, array.n_t)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
