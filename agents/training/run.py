"""The training loop: a run starts (new, or from its newest checkpoint that loads), learns with
the checkpoint and evaluation callbacks until its total or a signal, and ends with its model,
VecNormalize statistics and ``summary.json``. A full disk ends it with
``ios_uav_env.io.DiskFullError`` naming the file (or the run folder, for a write of a library's
own, e.g. a monitor file); every file of the run is whole, its newest whole checkpoint kept."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

from agents.hyperparams import Hyperparams, load_hyperparams
from agents.loading import ALGOS, CHECKPOINT_PREFIX
from agents.training.envs import make_venv
from agents.training.folder import (
    RUNS_DIR,
    check_new_run_dir,
    lock_run_dir,
    run_name,
    start_fresh,
    write_config,
)
from agents.training.interrupt import StopFlag, TrainingInterrupted, stop_on_signals
from agents.training.resuming import RunStart, TrainResult, continue_run, resume_settings
from agents.training.settings import TrainSettings
from ios_uav_env.io import DiskFullError, atomic_write_bytes, atomic_write_text, is_no_room


def train(settings: TrainSettings, *, _resume: bool = False) -> TrainResult:
    """Train (or, through :func:`resume`, continue) a run; return its folder, model and summary.

    The run holds its folder's lock while it runs (:func:`agents.training.folder.lock_run_dir`):
    :class:`agents.training.folder.RunFolderInUse` if another process is writing the folder.
    Raises :class:`TrainingInterrupted` after saving a checkpoint if SIGINT or SIGTERM arrives
    (in the main thread), and ``ios_uav_env.io.DiskFullError`` if the disk fills up."""
    with stop_on_signals() as stop:
        try:
            return _train(settings, stop, _resume)
        except OSError as exc:  # a library's own write (a monitor file, TensorBoard's) names no file
            if isinstance(exc, DiskFullError) or not is_no_room(exc):
                raise
            path = exc.filename or settings.out or RUNS_DIR
            raise DiskFullError(exc.errno, path, exc.strerror or "") from exc


def resume(run_dir: str | Path, *, timesteps: int | None = None, progress_bar: bool = True) -> TrainResult:
    """Continue the run in ``run_dir`` from its newest checkpoint that loads (same folder, same
    settings; from step 0 if it has none); ``timesteps`` changes the total number of steps
    (default: the run's own) and must not be below the steps already done (``ValueError``)."""
    return train(resume_settings(run_dir, timesteps, progress_bar), _resume=True)


def _train(settings: TrainSettings, stop: StopFlag, _resume: bool) -> TrainResult:
    if not _resume:  # a resumed run keeps the env arguments its config.json recorded
        settings.resolve_env_kwargs()
    hp, total, run_dir = _resolve(settings)
    if not _resume:
        check_new_run_dir(run_dir)  # before the lock makes the folder
    with lock_run_dir(run_dir):  # a second process on this folder is refused until the run ends
        if settings.trainer == "fast":
            from agents.fast.run import train_fast

            return train_fast(settings, stop, _resume, hp, total, run_dir)
        return _train_locked(settings, stop, _resume, hp, total, run_dir)


def _train_locked(
    settings: TrainSettings, stop: StopFlag, _resume: bool, hp: Hyperparams, total: int, run_dir: Path
) -> TrainResult:
    start = continue_run(run_dir, settings, hp, total) if _resume else None
    resumed = start is not None
    if start is None:
        start = _new_start(run_dir, settings, hp, total, again=_resume)
    checkpoint, evaluation = _learn(settings, hp, run_dir, start, total, resumed, stop)
    if checkpoint.stopped_at is not None:  # SIGINT / SIGTERM: keep this moment, then stop
        path = checkpoint.save()
        start.venv.close()
        assert stop.signum is not None
        steps = int(start.model.num_timesteps)
        raise TrainingInterrupted(stop.signum, run_dir, checkpoint.stopped_at, path, steps)
    checkpoint.save()  # the final state too, so that --resume can extend a finished run
    return _finish(run_dir, hp, start, evaluation)


def _resolve(settings: TrainSettings) -> tuple[Hyperparams, int, Path]:
    """Validate ``settings`` and fill in what the hyperparameter file decides (``n_envs``) and the
    run folder (``out``); return the hyperparameters, the total steps and the folder."""
    import torch

    settings.validate()
    torch.set_num_threads(1)
    hp = load_hyperparams(settings.algo, settings.env_id, settings.hyperparams_path())
    settings.n_envs = settings.n_envs or hp.n_envs
    total = settings.timesteps or hp.n_timesteps
    run_dir = Path(settings.out) if settings.out else RUNS_DIR / run_name(settings)
    settings.out = str(run_dir)
    return hp, total, run_dir


def _new_start(run_dir: Path, settings: TrainSettings, hp: Hyperparams, total: int, again: bool) -> RunStart:
    """A new model at step 0 in a fresh ``run_dir`` with its ``config.json`` (``again``: a resume
    of a run that has no checkpoint)."""
    from stable_baselines3.common.utils import set_random_seed

    from agents.callbacks import Clock

    clock = Clock()
    start_fresh(run_dir, again)
    set_random_seed(settings.seed)
    venv = make_venv(settings, hp, run_dir, None)
    model = ALGOS[settings.algo](
        hp.policy,
        venv,
        seed=settings.seed,
        verbose=0,
        device="cpu",
        tensorboard_log=str(run_dir / "tb"),
        **hp.model_kwargs,
    )
    write_config(run_dir, settings, hp, total)
    return RunStart(model, venv, 0, clock, [])


def _learn(
    settings: TrainSettings,
    hp: Hyperparams,
    run_dir: Path,
    start: RunStart,
    total: int,
    resumed: bool,
    stop: StopFlag,
) -> tuple[Any, Any]:
    """Train ``start.model`` from ``start.steps`` to ``total`` steps (or the step ``stop`` is seen);
    return the checkpoint and evaluation callbacks."""
    from stable_baselines3.common.callbacks import CallbackList

    from agents.callbacks import RateEvalCallback, TimedCheckpointCallback

    start.clock.start()
    checkpoint = TimedCheckpointCallback(
        settings.checkpoint_freq,
        run_dir / "checkpoints",
        start.clock,
        start.history,
        stop=stop,
        name_prefix=CHECKPOINT_PREFIX,
        save_replay_buffer=settings.algo == "sac",
        save_vecnormalize=hp.normalize is not None,
    )
    evaluation = RateEvalCallback(
        settings.eval_freq,
        settings.env_id,
        settings.env_kwargs,
        start.clock,
        start.history,
        repeat=hp.repeat,
        memory=hp.memory,
    )
    print(f"training {run_dir}: step {start.steps} of {total}", file=sys.stderr, flush=True)
    start.model.learn(
        total_timesteps=max(0, total - start.steps),
        callback=CallbackList([*hp.callbacks, checkpoint, evaluation]),
        tb_log_name=settings.algo.upper(),
        reset_num_timesteps=not resumed,
        progress_bar=settings.progress_bar,
    )
    return checkpoint, evaluation


def _finish(run_dir: Path, hp: Hyperparams, start: RunStart, evaluation: Any) -> TrainResult:
    """Save the model (and VecNormalize statistics), evaluate it and write ``summary.json``."""
    model, history = start.model, start.history
    seconds = start.clock.seconds()
    model_path = _save_model(run_dir, model, hp)
    if history and history[-1]["steps"] == model.num_timesteps:
        history.pop()  # evaluated during the last rollout, before the last update: not the saved model
    final = evaluation.evaluate()
    summary = {
        "steps": int(model.num_timesteps),
        "wall_time_s": round(seconds, 2),
        "steps_per_s": round((model.num_timesteps - start.steps) / max(seconds - start.clock.prior, 1e-9), 1),
        "final_eval": final,
        "eval_history": history,
    }
    atomic_write_text(run_dir / "summary.json", json.dumps(summary, indent=1))
    start.venv.close()
    return TrainResult(run_dir, model_path, summary)


def _save_model(run_dir: Path, model: Any, hp: Hyperparams) -> Path:
    """``model.zip`` (and ``vecnormalize.pkl`` when the hyperparameters normalise), written atomically."""
    import pickle

    from agents.callbacks import replace_into

    model_path = run_dir / "model.zip"
    replace_into(model_path, model.save)
    if hp.normalize is not None:
        atomic_write_bytes(run_dir / "vecnormalize.pkl", pickle.dumps(model.get_vec_normalize_env()))
    return model_path
