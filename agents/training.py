"""Training runs: SB3 PPO or SAC on a registered env id, one self-contained folder per run.

A run folder (``runs/<env>__<algo>__<seed>__<unix time>`` unless named) holds:

- ``config.json``: the resolved configuration (arguments, hyperparameters as written in the
  zoo-format file, env kwargs, scenario, library versions), written before training starts;
- ``model.zip`` (+ ``vecnormalize.pkl`` when the hyperparameters normalise) and
  ``summary.json`` (steps, wall time, steps/s, the final deterministic evaluation and the
  evaluation history), written at the end;
- ``checkpoints/`` (SB3 ``CheckpointCallback``: model, SAC replay buffer, VecNormalize
  statistics, plus ``progress.json``), ``monitor/`` (episode logs), ``tb/`` (TensorBoard).

:func:`resume` continues a run from its last checkpoint in the same folder: the step count,
the TensorBoard run, the monitor files and the wall-time clock go on where they stopped.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import platform
import re
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym

import ios_uav_env
from agents.hyperparams import Hyperparams, load_hyperparams
from agents.loading import ALGOS, CHECKPOINT_PREFIX, checkpoint_file, checkpoints
from agents.wrappers import apply_wrappers
from ios_uav_env.io import atomic_write_text

RUNS_DIR = Path("runs")
DEFAULT_ENV_ID = "ios_uav_env/IOSUAV-v0"


# --- checks of the settings (ValueError / FileNotFoundError / FileExistsError with the reason);
# --- TrainSettings.validate and train.py's argument parser both use them


def check_algo(algo: str) -> str:
    if algo not in ALGOS:
        raise ValueError(f"unknown algorithm {algo!r}; choose from {', '.join(ALGOS)}")
    return algo


def check_env_id(env_id: str) -> str:
    if env_id not in gym.registry:
        ours = ", ".join(sorted(ios_uav_env.ENV_IDS))
        raise ValueError(f"unknown env id {env_id!r}; registered ids of this package: {ours}")
    return env_id


def check_positive(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
        raise ValueError(f"must be a positive integer, got {value!r}")
    return value


def check_env_kwargs(env_id: str, env_kwargs: dict[str, Any]) -> dict[str, Any]:
    """``env_kwargs`` if ``gym.make(env_id, **env_kwargs)`` accepts them."""
    try:
        gym.make(env_id, **env_kwargs).close()
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{env_kwargs!r} rejected by {env_id}: {exc}") from exc
    return env_kwargs


def check_new_run_dir(run_dir: str | Path) -> Path:
    """``run_dir`` if a new run can start there (missing or empty)."""
    run_dir = Path(run_dir)
    if run_dir.exists() and (not run_dir.is_dir() or any(run_dir.iterdir())):
        raise FileExistsError(f"run folder {run_dir} exists and is not empty (resume it instead)")
    return run_dir


def check_resumable(run_dir: str | Path) -> Path:
    """``run_dir`` if it is a run folder with a checkpoint to resume from."""
    run_dir = Path(run_dir)
    if not (run_dir / "config.json").exists():
        raise FileNotFoundError(f"{run_dir} is not a run folder (no config.json)")
    if not checkpoints(run_dir):
        raise FileNotFoundError(f"{run_dir / 'checkpoints'} holds no checkpoint to resume from")
    return run_dir


@dataclass
class TrainSettings:
    """Everything a run needs; the fields are ``train.py``'s arguments."""

    algo: str  # "ppo" or "sac"
    env_id: str = DEFAULT_ENV_ID  # a registered id
    timesteps: int | None = None  # total env steps; None = the hyperparameter file's n_timesteps
    seed: int = 0  # seeds torch, numpy, the model and the envs (env i gets seed + i)
    n_envs: int | None = None  # parallel envs (DummyVecEnv); None = the file's n_envs
    env_kwargs: dict[str, Any] = field(default_factory=dict)  # IOSUAVEnv arguments
    out: str | None = None  # run folder; None = runs/<env>__<algo>__<seed>__<time>
    hyperparams_file: str | None = None  # None = agents/hyperparams/<algo>.yml
    checkpoint_freq: int = 25_000  # env steps between checkpoints
    eval_freq: int = 10_000  # env steps between deterministic evaluations (0: none)
    progress_bar: bool = True

    def validate(self) -> None:
        """Raise ``ValueError`` naming the first bad field."""
        checks: list[tuple[str, Any, Any]] = [
            ("algo", check_algo, self.algo),
            ("env_id", check_env_id, self.env_id),
        ]
        for name in ("timesteps", "n_envs", "checkpoint_freq"):
            if getattr(self, name) is not None:  # None: the hyperparameter file's value
                checks.append((name, check_positive, getattr(self, name)))
        checks.append(("env_kwargs", functools.partial(check_env_kwargs, self.env_id), self.env_kwargs))
        for name, check, value in checks:
            try:
                check(value)
            except ValueError as exc:
                raise ValueError(f"{name}: {exc}") from exc


@dataclass
class TrainResult:
    run_dir: Path
    model_path: Path
    summary: dict[str, Any]


def run_name(settings: TrainSettings) -> str:
    """CleanRL-style name: env, algorithm, seed and start time."""
    env = re.sub(r"[^A-Za-z0-9_.-]+", "-", settings.env_id)
    return f"{env}__{settings.algo}__{settings.seed}__{int(time.time())}"


def versions() -> dict[str, str]:
    import numpy
    import stable_baselines3
    import torch

    return {
        "python": platform.python_version(),
        "ios_uav_env": ios_uav_env.__version__,
        "stable_baselines3": stable_baselines3.__version__,
        "torch": torch.__version__,
        "gymnasium": gym.__version__,
        "numpy": numpy.__version__,
    }


def _make_venv(settings: TrainSettings, hp: Hyperparams, run_dir: Path, resume_from: str | None) -> Any:
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    wrap = functools.partial(apply_wrappers, wrappers=hp.env_wrappers) if hp.env_wrappers else None
    venv = make_vec_env(
        settings.env_id,
        wrapper_class=wrap,
        n_envs=settings.n_envs,
        seed=settings.seed,
        env_kwargs=settings.env_kwargs,
        monitor_dir=str(run_dir / "monitor"),
        monitor_kwargs={"override_existing": resume_from is None},
        vec_env_cls=DummyVecEnv,
    )
    if hp.normalize is None:
        return venv
    if resume_from is not None:
        return VecNormalize.load(resume_from, venv)
    return VecNormalize(venv, gamma=hp.model_kwargs.get("gamma", 0.99), **hp.normalize)


def train(settings: TrainSettings, *, _resume: bool = False) -> TrainResult:
    """Train (or, through :func:`resume`, continue) a run; return its folder, model and summary."""
    import torch
    from stable_baselines3.common.callbacks import CallbackList
    from stable_baselines3.common.utils import set_random_seed

    from agents.callbacks import PROGRESS_FILE, Clock, RateEvalCallback, TimedCheckpointCallback

    settings.validate()
    torch.set_num_threads(1)
    hp = load_hyperparams(settings.algo, settings.env_id, settings.hyperparams_file)
    settings.n_envs = settings.n_envs or hp.n_envs
    total = settings.timesteps or hp.n_timesteps
    run_dir = Path(settings.out) if settings.out else RUNS_DIR / run_name(settings)
    settings.out = str(run_dir)
    ckpt_dir = run_dir / "checkpoints"
    algo_cls = ALGOS[settings.algo]

    clock, history, start_steps = Clock(), [], 0
    if _resume:
        steps, ckpt = checkpoints(run_dir)[-1]
        vecnorm = str(checkpoint_file(run_dir, steps, "vecnormalize")) if hp.normalize is not None else None
        venv = _make_venv(settings, hp, run_dir, vecnorm)
        model = algo_cls.load(ckpt, env=venv, device="cpu", tensorboard_log=str(run_dir / "tb"))
        if settings.algo == "sac":
            model.load_replay_buffer(str(checkpoint_file(run_dir, steps, "replay_buffer")))
        progress = ckpt_dir / PROGRESS_FILE
        if progress.exists():
            record = json.loads(progress.read_text())
            clock = Clock(record["wall_time_s"])
            history = [h for h in record["eval_history"] if h["steps"] <= steps]
        start_steps = steps
    else:
        check_new_run_dir(run_dir)
        run_dir.mkdir(parents=True, exist_ok=True)
        set_random_seed(settings.seed)
        venv = _make_venv(settings, hp, run_dir, None)
        model = algo_cls(
            hp.policy,
            venv,
            seed=settings.seed,
            verbose=0,
            device="cpu",
            tensorboard_log=str(run_dir / "tb"),
            **hp.model_kwargs,
        )
    write_config(run_dir, settings, hp, total)

    clock.start()
    checkpoint = TimedCheckpointCallback(
        settings.checkpoint_freq,
        ckpt_dir,
        clock,
        history,
        name_prefix=CHECKPOINT_PREFIX,
        save_replay_buffer=settings.algo == "sac",
        save_vecnormalize=hp.normalize is not None,
    )
    evaluation = RateEvalCallback(settings.eval_freq, settings.env_id, settings.env_kwargs, clock, history)
    model.learn(
        total_timesteps=max(0, total - start_steps),
        callback=CallbackList([*hp.callbacks, checkpoint, evaluation]),
        tb_log_name=settings.algo.upper(),
        reset_num_timesteps=not _resume,
        progress_bar=settings.progress_bar,
    )
    checkpoint.save()  # the final state too, so that --resume can extend a finished run
    seconds = clock.seconds()
    model_path = run_dir / "model.zip"
    model.save(model_path)
    if hp.normalize is not None:
        model.get_vec_normalize_env().save(str(run_dir / "vecnormalize.pkl"))
    if history and history[-1]["steps"] == model.num_timesteps:
        history.pop()  # evaluated during the last rollout, before the last update: not the saved model
    final = evaluation.evaluate()
    summary = {
        "steps": int(model.num_timesteps),
        "wall_time_s": round(seconds, 2),
        "steps_per_s": round((model.num_timesteps - start_steps) / max(seconds - clock.prior, 1e-9), 1),
        "final_eval": final,
        "eval_history": history,
    }
    atomic_write_text(run_dir / "summary.json", json.dumps(summary, indent=1))
    venv.close()
    return TrainResult(run_dir, model_path, summary)


def write_config(run_dir: Path, settings: TrainSettings, hp: Hyperparams, total: int) -> Path:
    """Write the resolved configuration ``config.json`` atomically."""
    env = gym.make(settings.env_id, **settings.env_kwargs)
    base = env.unwrapped
    config = {
        "algo": settings.algo,
        "env_id": settings.env_id,
        "seed": settings.seed,
        "total_timesteps": total,
        "n_envs": settings.n_envs,
        "env_kwargs": settings.env_kwargs,
        "args": dataclasses.asdict(settings),
        "hyperparams": hp.raw,
        "hyperparams_file": str(settings.hyperparams_file or f"agents/hyperparams/{settings.algo}.yml"),
        "scenario": base.config.to_dict(),
        "arrival_guard": base.arrival_guard,
        "channel": base.channel,
        "versions": versions(),
        "command": sys.argv,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }
    env.close()
    return atomic_write_text(run_dir / "config.json", json.dumps(config, indent=1, default=str))


def resume(run_dir: str | Path, *, timesteps: int | None = None, progress_bar: bool = True) -> TrainResult:
    """Continue the run in ``run_dir`` from its last checkpoint (same folder, same settings);
    ``timesteps`` changes the total number of steps (default: the run's own)."""
    run_dir = check_resumable(run_dir)
    config = json.loads((run_dir / "config.json").read_text())
    args = config["args"]
    args.update(out=str(run_dir), progress_bar=progress_bar)
    args["timesteps"] = config["total_timesteps"] if timesteps is None else timesteps
    return train(TrainSettings(**args), _resume=True)
