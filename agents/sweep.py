"""``python -m agents.sweep``: a training sweep, seeds x algorithms x env ids x hyperparameter overrides.

    python -m agents.sweep --algos ppo sac --seeds 0 1 2 --timesteps 200000 --out out/sweep
    python -m agents.sweep --algos ppo --seeds 0 1 --set learning_rate=1e-4 --set learning_rate=3e-4 \\
        --set n_epochs=5 --timesteps 100000 --out out/lr --backend ray [--address HOST:6379]

Every trial is one ``train.py`` run (:func:`agents.training.train`) in its own folder
``OUT/runs/<trial>``, named by its parameters (``IOSUAV-v0__ppo__seed0__learning_rate-0.0001``).
``--set KEY=VALUE`` overrides a key of the algorithm's zoo-format hyperparameters (the value is
read as YAML: ``1e-4``, ``lin_3e-4``, ``"dict(net_arch=[64, 64])"``); giving a key more than once
makes its values a dimension of the sweep. A trial's hyperparameters are written to
``OUT/hyperparams/<trial>.yml`` (the shipped entry with the overrides), so the run is a plain
``train.py`` run: ``python train.py --resume OUT/runs/<trial>`` continues one by hand.

Resumable: a finished trial is read back (``OUT/results/<trial>__t<timesteps>__<digest>.json``,
written atomically when it ends; the digest covers every setting of the trial: its algorithm,
env id, seed and overrides, the hyperparameters they resolve to, the env kwargs, the steps and
the evaluation and checkpoint periods); an interrupted one continues from its newest checkpoint
(:func:`agents.training.resume`); running the command again with a larger ``--timesteps``
extends the finished runs. A run folder trained with other settings (say other ``--env-kwargs``)
is never read back nor continued: the command refuses it, naming the settings that differ (use
another ``--out``). A run folder another process is writing (its lock,
:func:`agents.training.lock_run_dir`) is refused too. The backends:

- ``local`` (default): a pool of ``--jobs`` worker processes (``baselines.runner.run_tasks``;
  in this process with ``--jobs 1``); a worker whose parent dies (killed, even by SIGKILL)
  checkpoints its training, as on SIGTERM, and exits;
- ``ray``: Ray Tune, one trial per run (``tune.Tuner`` with a function trainable that runs the
  same code and reports the final evaluation; Tune's records in ``OUT/tune``), on a local Ray
  or the cluster at ``--address``. The run folders are the checkpoints: a trial of a new
  Tuner resumes from its folder, so a sweep interrupted on one backend goes on on either.

Either way ``OUT/sweep.csv`` has one row per trial: algorithm, env id, seed, overrides, the
final deterministic evaluation's average rate, its % of the DP optimum (the default scenario
of the fixed ids, from ``results/sweep.csv``; empty otherwise), feasibility, steps and wall
time. The records and the CSV do not depend on the backend (the wall times aside).

SIGINT or SIGTERM checkpoints the trainings in progress and ends the command with status 130
or 143 and a note on stderr saying how to resume, no traceback (one line with ``--jobs 1``).
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import multiprocessing
import os
import signal
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from agents.hyperparams import positive_int
from agents.sweep_trials import (  # noqa: F401 (the trials, re-exported)
    CSV_COLUMNS,
    DP_RESULTS,
    DP_SCHEME,
    RECORD_KEYS,
    ROOT,
    RUN_FIELDS,
    Trial,
    check_run_folder,
    dp_rate,
    make_trials,
    parse_overrides,
    record_key,
    trial_entry,
    trial_hyperparams,
    trial_settings,
    write_csv,
)
from baselines.ray_backend import add_backend_arguments, check_backend_arguments
from baselines.runner import cached_records, check_writable, run_tasks
from ios_uav_env.io import atomic_write_text

#: A worker process looks whether its parent is alive this often (s); once it is gone, a training
#: in progress gets this long to checkpoint before the worker exits anyway (s).
PARENT_POLL_S = 0.5
ORPHAN_GRACE_S = 30.0


_orphaned = threading.Event()  # set in a worker process once its parent has died
_watching = threading.Lock()


def exit_with_parent() -> None:
    """In a worker process (started by ``multiprocessing``; nothing elsewhere): a daemon thread
    that, once the parent has died, sends this process SIGTERM (a training in progress saves a
    checkpoint and stops, as under ``train.py``) and ends it after :data:`ORPHAN_GRACE_S` at
    the latest, so that no orphaned worker trains on, writes the sweep's folders or waits for
    its dead parent. Started once per process."""
    parent = multiprocessing.parent_process()
    if parent is None or not _watching.acquire(blocking=False):
        return
    ppid = os.getppid()

    def watch() -> None:
        while os.getppid() == ppid and parent.is_alive():
            time.sleep(PARENT_POLL_S)
        _orphaned.set()
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(ORPHAN_GRACE_S)
        os._exit(128 + signal.SIGTERM)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


def run_trial(
    trial: Trial,
    *,
    out: str | Path,
    timesteps: int,
    env_kwargs: dict[str, Any] | None = None,
    eval_freq: int = 10_000,
    checkpoint_freq: int = 25_000,
) -> dict[str, Any]:
    """Run one trial to ``timesteps`` (or read it back if its run has finished them; resume it
    from its checkpoint if interrupted) and return its record (a row of ``sweep.csv``).
    ``ValueError`` if its run folder holds a run of other settings (:func:`check_run_folder`).
    In a worker process, the worker exits once its parent has died (:func:`exit_with_parent`)."""
    exit_with_parent()
    try:
        return _run_trial(trial, out=out, timesteps=timesteps, env_kwargs=env_kwargs, eval_freq=eval_freq,
                          checkpoint_freq=checkpoint_freq)  # fmt: skip
    except BaseException:
        if _orphaned.is_set():  # the checkpoint is saved; nobody waits for the outcome
            os._exit(128 + signal.SIGTERM)
        raise


def _run_trial(
    trial: Trial, *, out: str | Path, timesteps: int, env_kwargs: dict[str, Any] | None, eval_freq: int,
    checkpoint_freq: int,
) -> dict[str, Any]:  # fmt: skip
    from agents.training import TrainSettings, resume, train

    out = Path(out).resolve()
    env_kwargs = dict(env_kwargs or {})
    run_dir = check_run_folder(trial, out, timesteps=timesteps, env_kwargs=env_kwargs, eval_freq=eval_freq,
                               checkpoint_freq=checkpoint_freq)  # fmt: skip
    summary_path = run_dir / "summary.json"
    summary = json.loads(summary_path.read_text()) if summary_path.exists() else None
    if summary is not None and summary.get("steps", 0) >= timesteps:
        pass  # finished
    elif (run_dir / "config.json").exists():
        summary = resume(run_dir, timesteps=timesteps, progress_bar=False).summary
    else:
        hp_file = trial_hyperparams(trial, out)
        settings = TrainSettings(
            algo=trial.algo,
            env_id=trial.env_id,
            timesteps=timesteps,
            seed=trial.seed,
            env_kwargs=env_kwargs,
            out=str(run_dir),
            hyperparams_file=None if hp_file is None else str(hp_file),
            checkpoint_freq=checkpoint_freq,
            eval_freq=eval_freq,
            progress_bar=False,
        )
        summary = train(settings).summary
    final = summary["final_eval"]
    dp = dp_rate(trial.env_id, env_kwargs)
    return {
        "trial": trial.name,
        "algo": trial.algo,
        "env_id": trial.env_id,
        "seed": trial.seed,
        "overrides": trial.overrides_text,
        "average_rate": float(final["average_rate"]),
        "pct_of_dp": None if dp is None else 100.0 * float(final["average_rate"]) / dp,
        "feasible": bool(final["feasible"]),
        "steps": int(summary["steps"]),
        "wall_time_s": float(summary["wall_time_s"]),
        "run_dir": str(run_dir.relative_to(out)),
    }


def _tune_trainable(config: dict[str, Any]) -> None:
    """Ray Tune's function trainable: one trial, its record reported once at the end."""
    from ray import tune

    tune.report(run_trial(Trial.from_dict(config["trial"]), **config["run"]))


def _run_tune(
    trials: list[Trial],
    run: dict[str, Any],
    jobs: int | None,
    address: str | None,
    progress: bool,
    done: Callable[[Trial, dict[str, Any]], None],
) -> None:
    """Run the trials as Ray Tune trials (one CPU each, at most ``jobs`` at once) and call
    ``done(trial, record)`` for each that finished; ``RuntimeError`` naming the others (failed,
    or stopped by an interrupt) after that."""
    from baselines.ray_backend import init_ray

    init_ray(address)
    from ray import tune

    tuner = tune.Tuner(
        tune.with_resources(_tune_trainable, {"cpu": 1}),
        param_space={"trial": tune.grid_search([t.to_dict() for t in trials]), "run": run},
        tune_config=tune.TuneConfig(num_samples=1, max_concurrent_trials=jobs),
        run_config=tune.RunConfig(
            name=f"sweep-{time.strftime('%Y%m%d-%H%M%S')}",
            storage_path=str(Path(run["out"]) / "tune"),
            failure_config=tune.FailureConfig(max_failures=0),
            verbose=1 if progress else 0,
        ),
    )
    # Tune's fit installs a SIGINT handler of its own in the main thread and leaves it there: the
    # caller's Ctrl-C (KeyboardInterrupt, or its own handler) is restored when the trials end
    main_thread = threading.current_thread() is threading.main_thread()
    sigint = signal.getsignal(signal.SIGINT) if main_thread else None
    try:
        results = tuner.fit()
    finally:
        if sigint is not None:
            signal.signal(signal.SIGINT, sigint)
    by_name = {t.name: t for t in trials}
    finished = set()
    errors = [f"{Trial.from_dict(r.config['trial']).name}: {r.error}" for r in results if r.error is not None]
    for result in results:
        if result.error is None and result.metrics and result.metrics.get("trial") in by_name:
            finished.add(result.metrics["trial"])
            done(by_name[result.metrics["trial"]], {k: result.metrics[k] for k in CSV_COLUMNS})
    unfinished = [t.name for t in trials if t.name not in finished]
    if unfinished:
        first = errors[0] if errors else "stopped before its end"
        raise RuntimeError(
            f"{len(unfinished)} of {len(trials)} Tune trials did not finish ({first}); run the command "
            "again to resume them from their run folders"
        )


def run_sweep(
    trials: Sequence[Trial],
    out: str | Path,
    *,
    timesteps: int,
    env_kwargs: dict[str, Any] | None = None,
    eval_freq: int = 10_000,
    checkpoint_freq: int = 25_000,
    jobs: int | None = None,
    backend: str = "local",
    address: str | None = None,
    progress: bool = True,
) -> list[dict[str, Any]]:
    """Run (or read back, or resume) every trial and return their records in order; each record
    is cached in ``OUT/results`` as soon as its trial ends (the same file on both backends), under
    a name that covers every setting of the trial (:func:`record_key`). ``ValueError`` if a run
    folder holds a run of other settings (:func:`check_run_folder`)."""
    if backend not in ("local", "ray"):
        raise ValueError(f"backend: unknown backend {backend!r}; choose from local, ray")
    if address is not None and backend != "ray":
        raise ValueError(f"address: a Ray cluster's address needs backend='ray', got backend={backend!r}")
    out = Path(out).resolve()
    trials = list(trials)
    run = {"out": str(out), "timesteps": timesteps, "env_kwargs": dict(env_kwargs or {}),
           "eval_freq": eval_freq, "checkpoint_freq": checkpoint_freq}  # fmt: skip
    key = functools.partial(record_key, {k: v for k, v in run.items() if k != "out"})
    cache_dir = out / "results"
    if backend == "local":
        return run_tasks(
            functools.partial(run_trial, **run), trials, cache_dir, key=key, jobs=jobs, progress=progress,
            desc="sweep", unit="trial", required=RECORD_KEYS,
            describe=lambda i, r: f"{r['trial']}: {r['average_rate']:.3f} bps/Hz",
        )  # fmt: skip
    cache_dir.mkdir(parents=True, exist_ok=True)
    records = cached_records(trials, cache_dir, key, RECORD_KEYS)
    todo = [t for i, t in enumerate(trials) if i not in records]
    index = {t.name: i for i, t in enumerate(trials)}

    def done(trial: Trial, record: dict[str, Any]) -> None:  # the same file as run_tasks writes
        atomic_write_text(cache_dir / f"{key(trial)}.json", json.dumps(record))
        records[index[trial.name]] = record

    if todo:
        _run_tune(todo, run, jobs, address, progress, done)
    return [records[i] for i in range(len(trials))]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m agents.sweep",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    from agents.loading import ALGOS
    from agents.training import DEFAULT_ENV_ID

    parser.add_argument("--algos", nargs="+", choices=list(ALGOS), default=["ppo"], help="algorithms")
    parser.add_argument("--seeds", nargs="+", type=int, default=[0], help="seeds (default 0)")
    parser.add_argument(
        "--env", nargs="+", default=[DEFAULT_ENV_ID], help=f"env ids (default {DEFAULT_ENV_ID})"
    )
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="overrides",
                        help="a hyperparameter override (YAML); a key again: another value")  # fmt: skip
    parser.add_argument("--env-kwargs", nargs="*", default=[], metavar="KEY:VALUE",
                        help="env arguments for every trial, as train.py's")  # fmt: skip
    parser.add_argument("--timesteps", type=positive_int, required=True, help="env steps per trial")
    parser.add_argument("--eval-freq", type=int, default=10_000, help="steps between evaluations (0: none)")
    parser.add_argument(
        "--checkpoint-freq", type=positive_int, default=25_000, help="steps between checkpoints"
    )
    parser.add_argument("--out", type=Path, required=True, help="sweep folder (runs/, results/, sweep.csv)")
    parser.add_argument("--jobs", type=positive_int, default=None,
                        help="trials at once (default: all cores, or the Ray cluster's CPUs)")  # fmt: skip
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_backend_arguments(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    check_backend_arguments(parser, args)
    from agents.hyperparams import parse_env_kwargs
    from agents.training import check_env_id, check_env_kwargs

    for env_id in args.env:
        try:
            check_env_id(env_id)
        except ValueError as exc:
            parser.error(f"argument --env: {exc}")
    try:
        overrides = parse_overrides(args.overrides)
    except ValueError as exc:
        parser.error(f"argument --set: {exc}")
    try:
        env_kwargs = parse_env_kwargs(args.env_kwargs)
        for env_id in args.env:
            check_env_kwargs(env_id, env_kwargs)
    except ValueError as exc:
        parser.error(f"argument --env-kwargs: {exc}")
    try:
        check_writable(args.out)
    except OSError as exc:
        parser.error(f"argument --out: {exc}")
    trials = make_trials(args.algos, args.env, args.seeds, overrides)
    from agents.training import RunFolderInUse, TrainingInterrupted, check_hyperparams

    with tempfile.TemporaryDirectory() as tmp:  # bad overrides fail here, before any training
        for trial in {t.name: t for t in (dataclasses.replace(t, seed=0) for t in trials)}.values():
            try:
                check_hyperparams(
                    trial.algo, trial.env_id, trial_hyperparams(trial, Path(tmp)), env_kwargs=env_kwargs
                )
            except ValueError as exc:
                parser.error(f"argument --set: {exc}")
    for trial in trials:  # a folder of other settings, or one another process writes: before any training
        try:
            check_run_folder(trial, args.out, timesteps=args.timesteps, env_kwargs=env_kwargs,
                             eval_freq=args.eval_freq, checkpoint_freq=args.checkpoint_freq)  # fmt: skip
        except (ValueError, OSError) as exc:
            parser.error(f"argument --out: {exc}")
    start = time.perf_counter()
    try:
        records = run_sweep(
            trials, args.out, timesteps=args.timesteps, env_kwargs=env_kwargs, eval_freq=args.eval_freq,
            checkpoint_freq=args.checkpoint_freq, jobs=args.jobs, backend=args.backend, address=args.address,
            progress=not args.no_progress,
        )  # fmt: skip
    except KeyboardInterrupt:
        print(f"interrupted: run the command again to resume {args.out}", file=sys.stderr)
        return 130
    except TrainingInterrupted as stop:  # a trial trained in this process (--jobs 1) checkpointed
        print(f"interrupted: {signal.Signals(stop.signum).name} at step {stop.steps_at_signal} of "
              f"{stop.run_dir.name} (checkpoint of {stop.steps} steps saved); run the command again to "
              f"resume {args.out}", file=sys.stderr)  # fmt: skip
        return stop.exit_status
    except RunFolderInUse as exc:  # another process took a run folder after the check above
        print(f"python -m agents.sweep: error: argument --out: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # a write that failed (e.g. a full disk): every file written is whole
        print(f"python -m agents.sweep: error: {exc}; the finished trials and the checkpoints are kept: "
              f"run the same command again to resume {args.out}", file=sys.stderr)  # fmt: skip
        return 1
    path = write_csv(records, args.out / "sweep.csv")
    print(path.read_text(), end="")
    print(f"{len(records)} trials in {time.perf_counter() - start:.1f} s ({args.backend}); wrote {path}")
    return 0


if __name__ == "__main__":
    from agents.sweep import main as _main  # the module's own functions: Ray pickles them by name

    sys.exit(_main())
