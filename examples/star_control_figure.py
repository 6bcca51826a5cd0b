"""The figure of PPO setting the STAR surface with direct and residual control, in one command.

Run:  python examples/star_control_figure.py --out docs/star_control_residual.png
            [--elements 16 64 256] [--bits none 1 2] [--steps 60000] [--episodes 20]
            [--seeds 0 1 2] [--target-kl 0.02]
The attempt of ``docs/star_control_residual.png`` (docs/envs.md, "Making it work at M = 256"):
``examples/star_control_ppo.py`` with the recipe's linear actor and ``--control direct
residual``, run for every M and b at seed 0 and, at the smallest M, at every seed of ``--seeds``
(the mean of those seeds is drawn, their range the error bar), then its ``plot_rows``. The
defaults are the shipped figure's: 30 runs of 60 000 slots, 45 to 75 s each on one core (about
half an hour). An existing file is never overwritten.

Needs the ``rl`` extra and matplotlib.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import star_control_ppo  # examples/ is the script's own folder, so on the path


def run_attempt(args: argparse.Namespace) -> list[dict]:
    """The table's rows: every M and b at the first seed, the smallest M at the other seeds too."""
    common = ["--bits", *args.bits, "--control", "direct", "residual", "--steps", str(args.steps),
              "--episodes", str(args.episodes)]  # fmt: skip
    if args.target_kl is not None:
        common += ["--target-kl", str(args.target_kl)]
    small, *rest = sorted(args.elements)
    seeds = [str(s) for s in args.seeds]
    rows = star_control_ppo.main(["--elements", str(small), "--seed", *seeds, *common])
    if rest:
        rows += star_control_ppo.main(["--elements", *map(str, rest), "--seed", seeds[0], *common])
    return rows


def main(argv: list[str] | None = None) -> Path:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="the figure (PNG; never overwritten)")
    parser.add_argument("--elements", type=int, nargs="+", default=[16, 64, 256], help="surface sizes M")
    parser.add_argument(
        "--bits", nargs="+", default=["none", "1", "2"], help="phase bits ('none': continuous)"
    )
    parser.add_argument("--steps", type=int, default=60_000, help="training slots per run")
    parser.add_argument("--episodes", type=int, default=20, help="held-out evaluation episodes")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="the seeds at the smallest M")
    parser.add_argument("--target-kl", type=float, default=0.02, help="PPO's early stop")
    args = parser.parse_args(argv)
    if args.out.exists():
        parser.error(f"--out {args.out} exists: give a new path (shipped figures are never overwritten)")
    if args.steps < 1 or args.episodes < 1:
        parser.error(f"--steps and --episodes must be >= 1, got {args.steps} and {args.episodes}")
    rows = run_attempt(args)
    title = (
        f"PPO (linear actor) setting the STAR surface: direct and residual control ({args.steps:,} slots "
        f"a run)".replace(",", " ")
    )
    path = star_control_ppo.plot_rows(rows, args.out, title)
    print(f"figure: {path}")
    return path


if __name__ == "__main__":
    main()
