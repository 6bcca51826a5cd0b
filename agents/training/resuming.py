"""Continuing a run in its folder: the settings of :func:`agents.training.resume`, the newest
checkpoint that loads whole (an unreadable newer one set aside as ``*.unreadable``), the wall
time and evaluation history it stopped at, and the resume noted in ``config.json``."""

from __future__ import annotations

import json
import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from agents.hyperparams import Hyperparams
from agents.loading import ALGOS, checkpoint_file, checkpoints
from agents.training.envs import make_venv
from agents.training.folder import check_resumable, read_config
from agents.training.settings import TrainSettings
from ios_uav_env.io import atomic_write_text

if TYPE_CHECKING:
    from agents.callbacks import Clock


@dataclass
class RunStart:
    """Where training starts: the model and its envs, the steps done, the wall-time clock and the
    evaluation history so far."""

    model: Any
    venv: Any
    steps: int
    clock: Clock
    history: list[dict[str, Any]]


@dataclass
class TrainResult:
    """A finished run: its folder, its model's file and its ``summary.json``."""

    run_dir: Path
    model_path: Path
    summary: dict[str, Any]


def resume_settings(run_dir: str | Path, timesteps: int | None, progress_bar: bool) -> TrainSettings:
    """The settings of the run in ``run_dir`` (its folder as ``out``); ``timesteps`` changes its total
    (default: the run's own) and must not be below the steps of its newest checkpoint (``ValueError``)."""
    run_dir = check_resumable(run_dir)
    config = read_config(run_dir)
    done = max((steps for steps, _ in checkpoints(run_dir)), default=0)
    if timesteps is not None and timesteps < done:
        raise ValueError(
            f"timesteps: {run_dir} is at {done} steps already (its total is {config['total_timesteps']}); "
            f"the new total must be at least {done}, got {timesteps}"
        )
    args = config["args"]
    args.update(out=str(run_dir), progress_bar=progress_bar)
    args["timesteps"] = config["total_timesteps"] if timesteps is None else timesteps
    return TrainSettings(**args)


def continue_run(
    run_dir: Path, settings: TrainSettings, hp: Hyperparams, total: int, loader: Any = None
) -> RunStart | None:
    """The start of training from the newest checkpoint of ``run_dir`` that loads, noted in its
    ``config.json`` (:func:`record_resume`), or None if it has none; ``ValueError`` if that
    checkpoint is past ``total`` steps already. ``loader``: as for :func:`load_checkpoint` (what
    it returns beside the model is the start's ``venv``)."""
    from agents.callbacks import Clock

    loaded = load_checkpoint(run_dir, settings, hp, loader)
    if loaded is None:
        return None
    steps, model, venv = loaded
    prior, history = _read_progress(run_dir, steps)
    clock = Clock(prior)
    if total < steps:
        venv.close()
        raise ValueError(
            f"timesteps: the run is at {steps} steps already; the total must be at least that, got {total}"
        )
    record_resume(run_dir, steps, total)
    return RunStart(model, venv, steps, clock, history)


class Unloadable(Exception):
    """A checkpoint's file that does not load, and why."""

    def __init__(self, path: Path, reason: str) -> None:
        self.path, self.reason = path, reason
        super().__init__(f"{path}: {reason}")


def load_checkpoint(
    run_dir: Path, settings: TrainSettings, hp: Hyperparams, loader: Any = None
) -> tuple[int, Any, Any] | None:
    """``(steps, model, venv)`` of the newest checkpoint of ``run_dir`` that loads whole (model,
    VecNormalize statistics, SAC's replay buffer), or None if the run has none. A newer one that
    does not load is renamed ``*.unreadable`` with a warning naming the file and the reason;
    ``ValueError`` naming them all if none loads. ``loader(run_dir, steps, zip, settings, hp)``
    loads one checkpoint (default SB3's: ``(model, venv)``) or raises :class:`Unloadable`."""
    failures: list[tuple[Path, str]] = []
    found = checkpoints(run_dir)
    for steps, ckpt in reversed(found):
        try:
            model, venv = (loader or _load)(run_dir, steps, ckpt, settings, hp)
        except Unloadable as bad:
            failures.append((bad.path, bad.reason))
            warnings.warn(f"checkpoint file {bad.path} cannot be loaded ({bad.reason}); trying an older one",
                          RuntimeWarning, stacklevel=2)  # fmt: skip
            continue
        for newer, zip_path in found:  # set the broken newer ones aside: their steps will be redone
            if newer > steps:
                zip_path.rename(zip_path.with_name(zip_path.name + ".unreadable"))
        return steps, model, venv
    if failures:
        listing = "; ".join(f"{p}: {r}" for p, r in failures)
        raise ValueError(f"no checkpoint of {run_dir} loads ({listing})")
    return None


def _load(run_dir: Path, steps: int, ckpt: Path, settings: TrainSettings, hp: Hyperparams) -> tuple[Any, Any]:
    """``(model, venv)`` of the checkpoint ``ckpt`` of ``steps``; :class:`Unloadable` naming the
    first of its files that is missing or does not load."""
    venv, current = None, ckpt
    try:
        vecnorm = None
        if hp.normalize is not None:
            vecnorm = current = checkpoint_file(run_dir, steps, "vecnormalize")
            if not vecnorm.exists():
                raise FileNotFoundError("missing")
        venv = make_venv(settings, hp, run_dir, str(vecnorm) if vecnorm else None, resumed=True)
        current = ckpt
        model = ALGOS[settings.algo].load(ckpt, env=venv, device="cpu", tensorboard_log=str(run_dir / "tb"))
        if settings.algo == "sac":
            current = checkpoint_file(run_dir, steps, "replay_buffer")
            if not current.exists():
                raise FileNotFoundError("missing")
            model.load_replay_buffer(str(current))
    except Exception as exc:  # a damaged file fails in many ways (zipfile, pickle, torch, SB3 asserts)
        if venv is not None:
            venv.close()
        reason = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
        raise Unloadable(current, reason) from exc
    return model, venv


def _read_progress(run_dir: Path, steps: int) -> tuple[float, list[dict[str, Any]]]:
    """Wall time and evaluation history at the checkpoint of ``steps`` (0 and [] if unknown)."""
    from agents.callbacks import PROGRESS_FILE

    for path in (checkpoint_file(run_dir, steps, "progress").with_suffix(".json"),
                 run_dir / "checkpoints" / PROGRESS_FILE):  # fmt: skip
        try:
            record = json.loads(path.read_text())
            if int(record["steps"]) == steps:
                history = [h for h in record["eval_history"] if h["steps"] <= steps]
                return float(record["wall_time_s"]), history
        except (OSError, ValueError, KeyError, TypeError):
            continue
    return 0.0, []


def record_resume(run_dir: Path, steps: int, total: int) -> None:
    """Note a resume in ``config.json``: the steps it started from and the total it aims at
    (``total_timesteps`` becomes that total; the rest of the config is kept)."""
    config = read_config(run_dir)
    config.setdefault("resumes", []).append(
        {
            "from_steps": steps,
            "total_timesteps": total,
            "command": sys.argv,
            "time": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        }  # fmt: skip
    )
    config["total_timesteps"] = total
    config["args"]["timesteps"] = total
    atomic_write_text(run_dir / "config.json", json.dumps(config, indent=1, default=str))
