"""Train a PPO or SAC agent (Stable-Baselines3) on an ios_uav_env id, from a checkout of the repository.

    python train.py --algo ppo                                   # the shipped recipe
    python train.py --algo sac --env ios_uav_env/IOSUAV-v0 --timesteps 60000 --seed 1 \\
        --env-kwargs arrival_guard:False channel:rician --out runs/sac_noguard
    python train.py --resume runs/sac_noguard                    # from its last checkpoint
    python train.py --algo ppo --trainer fast --env ios_uav_env/IOSUAV-MultiNode-v0  # the recipe's env_kwargs
    python train.py --algo ppo --trainer fast --init-from runs/imitation  # from a trained model's weights

A recipe (an entry of the hyperparameter file) may carry the env arguments it is trained with
(the zoo's ``env_kwargs`` key); ``--env-kwargs`` overrides them key by key, and the resolved
ones are recorded in the run's ``config.json``. Every argument is checked as it is parsed,
before the run folder is made: the env kwargs by making the env and resetting it, the
hyperparameters by building the algorithm with them, the output folder by its permissions and
its lock (an error names the argument and exits with status 2). A run holds its folder's lock
(``RUN_DIR/.lock``) while it runs: a second ``train.py`` on the same folder, a new run or
``--resume``, is refused with the holder's pid.
SIGINT (Ctrl-C) or SIGTERM saves a checkpoint of that moment and exits with status 130 or
143; ``--resume`` then goes on from it. A full disk ends the run with a message naming the file
that did not fit and status 1, every file of the run whole; ``--resume`` goes on from its newest
checkpoint once there is room. The library is :mod:`agents.training`
(``TrainSettings``, ``train``, ``resume``).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

DEFAULT_ENV_ID = "ios_uav_env/IOSUAV-v0"
#: The arguments a resumed run takes from its own config.json.
RUN_SETTINGS = (
    "algo",
    "env",
    "seed",
    "n_envs",
    "vec_env",
    "env_kwargs",
    "out",
    "hyperparams",
    "trainer",
    "threads",
    "init_from",
)


def _checked(check: Callable[[str], Any]) -> Callable[[str], Any]:
    """An argparse ``type`` from a check that raises ``ValueError`` or ``OSError`` with the reason."""

    def convert(text: str) -> Any:
        try:
            return check(text)
        except (ValueError, OSError) as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    convert.__name__ = check.__name__
    return convert


def _count(text: str, minimum: int = 1) -> int:
    """An integer >= ``minimum``, also written as a float (``1e6``)."""
    try:
        value = float(text) if "e" in text.lower() else int(text)
    except ValueError:
        value = None
    if value is None or not math.isfinite(value) or value != int(value) or value < minimum:
        what = "a positive integer" if minimum == 1 else f"an integer >= {minimum}"
        raise ValueError(f"must be {what}, got {text!r}")
    return int(value)


def _existing_file(text: str) -> str:
    if not Path(text).is_file():
        raise ValueError(f"no such file {text!r}")
    return text


def _env_id(text: str) -> str:
    from agents.training import check_env_id

    return check_env_id(text)


def _env_kwarg(text: str) -> tuple[str, Any]:
    from agents.hyperparams import parse_env_kwarg

    return parse_env_kwarg(text)


def _new_run_dir(text: str) -> str:
    from agents.training import check_new_run_dir

    return str(check_new_run_dir(text))


def _resumable(text: str) -> str:
    from agents.training import check_resumable

    return str(check_resumable(text))


def build_parser() -> argparse.ArgumentParser:
    from agents.loading import ALGOS

    parser = argparse.ArgumentParser(
        prog="train.py",
        description=__doc__.splitlines()[0],
        epilog="Hyperparameters: agents/hyperparams/<algo>.yml (rl-baselines3-zoo format).",
    )
    add = parser.add_argument
    add("--algo", choices=list(ALGOS), help="algorithm (required unless --resume)")
    add("--env", type=_checked(_env_id), default=None, help=f"registered env id (default: {DEFAULT_ENV_ID})")
    add("--timesteps", type=_checked(_count), default=None,
        help="total env steps (default: n_timesteps of the hyperparameter file)")  # fmt: skip
    add("--seed", type=int, default=None, help="random seed (default: 0)")
    add("--n-envs", type=_checked(_count), default=None, help="parallel envs (default: the file's)")
    add("--vec-env", choices=("dummy", "batched"), default=None,
        help="dummy: SB3's DummyVecEnv of single envs (default); batched: the natively batched env "
             "(agents.vec_env.BatchedVecEnv: all envs as one array computation, rows staggered over the "
             "episode), for hundreds of envs, e.g. agents/hyperparams/ppo_fast.yml")  # fmt: skip
    add("--env-kwargs", type=_checked(_env_kwarg), nargs="*", default=None, metavar="KEY:VALUE",
        help="env arguments, zoo style: arrival_guard:False channel:rician T:100; each overrides the "
             "recipe's own (its env_kwargs key) of the same name")  # fmt: skip
    add("--out", type=_checked(_new_run_dir), default=None,
        help="run folder: new, empty, or one whose run stopped before its first checkpoint (its files "
             "are replaced) (default: runs/<env>__<algo>__<seed>__<time>)")  # fmt: skip
    add("--hyperparams", type=_checked(_existing_file), default=None,
        help="zoo-format YAML (default: agents/hyperparams/<algo>.yml)")  # fmt: skip
    add("--trainer", choices=("sb3", "fast"), default=None,
        help="sb3: Stable-Baselines3's own loop (default); fast: PPO on the batched env's arrays "
             "(agents.fast, docs/fast-training.md; --algo ppo; agents/hyperparams/fast_ppo.yml)")  # fmt: skip
    add("--threads", type=_checked(_count), default=None,
        help="torch threads of the fast trainer (default: 1; more pay on idle cores only)")  # fmt: skip
    add("--init-from", default=None, metavar="PATH",
        help="fast trainer: start from the weights and observation statistics of the PPO model at PATH "
             "(a model or run folder, e.g. agents.imitation's, or a .zip) if its network is the "
             "recipe's (agents.fast.init_from)")  # fmt: skip
    add("--checkpoint-freq", type=_checked(_count), default=25_000, help="steps between checkpoints")
    add("--eval-freq", type=_checked(lambda text: _count(text, 0)), default=10_000,
        help="steps between evaluations (0: none)")  # fmt: skip
    add("--resume", type=_checked(_resumable), default=None, metavar="RUN_DIR",
        help="continue RUN_DIR from its newest checkpoint that loads (older ones are the fallback; "
             "none: from step 0), with its own settings; --timesteps may raise the total")  # fmt: skip
    add("--no-progress", action="store_true", help="no progress bar")
    return parser


def parse_args(argv: Sequence[str] | None = None) -> tuple[argparse.Namespace, Any]:
    """The parsed arguments and, for a new run, its ``TrainSettings`` (None with ``--resume``);
    exits with status 2 and a message naming the argument on bad input."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.resume is not None:
        given = [f"--{name.replace('_', '-')}" for name in RUN_SETTINGS if getattr(args, name) is not None]
        if given:
            parser.error(f"argument --resume: the run's own settings are used; drop {', '.join(given)}")
        from agents.loading import checkpoints

        done = max((steps for steps, _ in checkpoints(args.resume)), default=0)
        if args.timesteps is not None and args.timesteps < done:
            parser.error(
                f"argument --timesteps: {args.resume} is at {done} steps already; the new total must be "
                f"at least {done}, got {args.timesteps}"
            )
        return args, None
    if args.algo is None:
        parser.error("argument --algo is required (unless --resume)")
    from agents.training import RUNS_DIR, TrainSettings, check_env_kwargs, check_hyperparams, check_writable

    env_id = args.env or DEFAULT_ENV_ID
    given = dict(args.env_kwargs or [])
    recipe = TrainSettings(algo=args.algo, env_id=env_id, hyperparams_file=args.hyperparams,
                           trainer=args.trainer or "sb3")  # fmt: skip
    env_kwargs = {**recipe.resolve_env_kwargs(), **given}  # the recipe's env_kwargs, --env-kwargs over them
    try:
        check_env_kwargs(env_id, env_kwargs)
    except ValueError as exc:
        where = f" (the recipe's env_kwargs {recipe.env_kwargs} with these)" if recipe.env_kwargs else ""
        parser.error(f"argument --env-kwargs{where}: {exc}")
    try:
        check_hyperparams(
            args.algo, env_id, args.hyperparams, env_kwargs, args.n_envs, args.vec_env or "dummy",
            args.trainer or "sb3",
        )  # fmt: skip
    except ValueError as exc:
        parser.error(f"argument {'--hyperparams' if args.hyperparams else '--env'}: {exc}")
    if args.out is None:
        try:
            check_writable(RUNS_DIR)
        except OSError as exc:
            parser.error(f"argument --out: the default run folder: {exc}")
    settings = TrainSettings(
        algo=args.algo,
        env_id=env_id,
        timesteps=args.timesteps,
        seed=0 if args.seed is None else args.seed,
        n_envs=args.n_envs,
        vec_env=args.vec_env or "dummy",
        env_kwargs=env_kwargs,
        out=args.out,
        hyperparams_file=args.hyperparams,
        checkpoint_freq=args.checkpoint_freq,
        eval_freq=args.eval_freq,
        progress_bar=not args.no_progress,
        trainer=args.trainer or "sb3",
        threads=args.threads,
        init_from=args.init_from,
    )
    if args.threads is not None and settings.trainer != "fast":
        parser.error("argument --threads: only the fast trainer takes it (add --trainer fast)")
    if args.init_from is not None:
        try:
            settings.check_init_from(args.init_from)
        except ValueError as exc:
            parser.error(f"argument --init-from: {exc}")
    return args, settings


def main(argv: Sequence[str] | None = None) -> int:
    try:
        args, settings = parse_args(argv)
    except KeyboardInterrupt:  # before the run started: nothing to save
        print("train.py: interrupted while checking the arguments; nothing was written", file=sys.stderr)
        return 130
    from agents.training import RunFolderInUse, TrainingInterrupted, resume, train
    from ios_uav_env.io import DiskFullError

    argument = "--resume" if settings is None else "--out"
    try:
        if settings is None:
            try:
                result = resume(args.resume, timesteps=args.timesteps, progress_bar=not args.no_progress)
            except ValueError as exc:  # the run's files, once read: no checkpoint loads, a bad --timesteps
                print(f"train.py: error: argument --resume: {exc}", file=sys.stderr)
                return 2
        else:
            result = train(settings)
    except RunFolderInUse as exc:  # another process took the folder after the arguments were checked
        print(f"train.py: error: argument {argument}: {exc}", file=sys.stderr)
        return 2
    except TrainingInterrupted as stop:
        print(f"train.py: {stop}", file=sys.stderr)
        return stop.exit_status
    except DiskFullError as exc:
        run_dir = args.resume if settings is None else settings.out
        print(f"train.py: error: {exc}\ntrain.py: the run folder {run_dir} keeps its newest whole "
              f"checkpoint; once there is room, continue with: python train.py --resume {run_dir}",
              file=sys.stderr)  # fmt: skip
        return 1
    summary = result.summary
    final = summary["final_eval"]
    print(f"run: {result.run_dir}")
    print(
        f"steps {summary['steps']}, wall time {summary['wall_time_s']:.1f} s, "
        f"{summary['steps_per_s']:.0f} steps/s"
    )
    # the score: the value of the id's objective (agents.scores.ScoreLabel), named, with its unit
    name, unit, rate = final["score_name"].replace("_", " "), final["score_unit"], final["average_rate"]
    if unit == "bps/Hz":
        score = f"{name} {final['score']:.6f} bps/Hz"
    else:
        score = f"{name} {final['score']:.6g} {unit} (average rate {rate:.6f} bps/Hz)"
    print(
        f"deterministic episode: {score}, feasible {final['feasible']}, "
        f"terminal miss {final['terminal_miss']:.3g} m"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
