"""The command line of ``train.py``: parse, validate (errors name the argument), train.

    python train.py --algo ppo                                   # the shipped recipe
    python train.py --algo sac --env ios_uav_env/IOSUAV-v0 --timesteps 60000 --seed 1 \\
        --env-kwargs arrival_guard:False channel:rician --out runs/sac_noguard
    python train.py --resume runs/sac_noguard                    # from its last checkpoint
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from agents.hyperparams import ALGOS, parse_env_kwargs


def _positive_int(text: str) -> int:
    try:
        value = int(float(text)) if "e" in text.lower() else int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="train.py", description="Train a PPO or SAC agent (Stable-Baselines3) on an ios_uav_env id."
    )
    parser.add_argument("--algo", choices=ALGOS, help="algorithm (required unless --resume)")
    parser.add_argument("--env", default=None, help="registered env id (default: ios_uav_env/IOSUAV-v0)")
    parser.add_argument(
        "--timesteps",
        type=_positive_int,
        default=None,
        help="total env steps (default: n_timesteps of the hyperparameter file)",
    )
    parser.add_argument("--seed", type=int, default=None, help="random seed (default: 0)")
    parser.add_argument(
        "--n-envs", type=_positive_int, default=None, help="parallel envs (default: the file's)"
    )
    parser.add_argument(
        "--env-kwargs",
        nargs="*",
        default=None,
        metavar="KEY:VALUE",
        help="env arguments, zoo style: arrival_guard:False channel:rician T:100",
    )
    parser.add_argument(
        "--out", default=None, help="run folder (default: runs/<env>__<algo>__<seed>__<time>)"
    )
    parser.add_argument(
        "--hyperparams", default=None, help="zoo-format YAML (default: agents/hyperparams/<algo>.yml)"
    )
    parser.add_argument(
        "--checkpoint-freq", type=_positive_int, default=25_000, help="steps between checkpoints"
    )
    parser.add_argument("--eval-freq", type=int, default=10_000, help="steps between evaluations (0: none)")
    parser.add_argument(
        "--resume",
        default=None,
        metavar="RUN_DIR",
        help="continue RUN_DIR from its last checkpoint (its own settings; --timesteps may change the total)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    import gymnasium as gym

    import ios_uav_env
    from agents.training import TrainSettings, resume, train

    parser = build_parser()
    args = parser.parse_args(argv)
    progress = not args.no_progress
    if args.resume is not None:
        given = [
            f"--{n.replace('_', '-')}"
            for n in ("algo", "env", "seed", "n_envs", "env_kwargs", "out", "hyperparams")
            if getattr(args, n) is not None
        ]
        if given:
            parser.error(f"argument --resume: the run's own settings are used; drop {', '.join(given)}")
        try:
            result = resume(args.resume, timesteps=args.timesteps, progress_bar=progress)
        except FileNotFoundError as exc:
            parser.error(f"argument --resume: {exc}")
    else:
        if args.algo is None:
            parser.error("argument --algo is required (unless --resume)")
        env_id = args.env or "ios_uav_env/IOSUAV-v0"
        if env_id not in gym.registry:
            ids = ", ".join(sorted(ios_uav_env.ENV_IDS))
            parser.error(f"argument --env: unknown env id {env_id!r}; registered ids: {ids}")
        try:
            env_kwargs = parse_env_kwargs(args.env_kwargs)
        except ValueError as exc:
            parser.error(f"argument --env-kwargs: {exc}")
        if args.hyperparams is not None and not Path(args.hyperparams).is_file():
            parser.error(f"argument --hyperparams: no such file {args.hyperparams!r}")
        settings = TrainSettings(
            algo=args.algo,
            env_id=env_id,
            timesteps=args.timesteps,
            seed=0 if args.seed is None else args.seed,
            n_envs=args.n_envs,
            env_kwargs=env_kwargs,
            out=args.out,
            hyperparams_file=args.hyperparams,
            checkpoint_freq=args.checkpoint_freq,
            eval_freq=args.eval_freq,
            progress_bar=progress,
        )
        try:
            settings.validate()
        except ValueError as exc:
            name, _, message = str(exc).partition(": ")
            parser.error(f"argument --{name.replace('_', '-').replace('env-id', 'env')}: {message}")
        try:
            result = train(settings)
        except FileExistsError as exc:
            parser.error(f"argument --out: {exc}".replace("out: ", "", 1))
        except KeyError as exc:  # no hyperparameters for this env id
            parser.error(f"argument --env: {str(exc).strip(chr(34) + chr(39))}; pass --hyperparams FILE")
    final = result.summary["final_eval"]
    print(f"run: {result.run_dir}")
    print(
        f"steps {result.summary['steps']}, wall time {result.summary['wall_time_s']:.1f} s, "
        f"{result.summary['steps_per_s']:.0f} steps/s"
    )
    print(
        f"deterministic episode: average rate {final['average_rate']:.6f} bps/Hz, "
        f"feasible {final['feasible']}, terminal miss {final['terminal_miss']:.3g} m"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
