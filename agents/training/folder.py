"""A run's folder: its name, whether a new run may start there or an old one be resumed, what a
run stopped before its first checkpoint left, and the resolved configuration ``config.json``."""

from __future__ import annotations

import dataclasses
import json
import platform
import re
import shutil
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym

import ios_uav_env
from agents.hyperparams import Hyperparams
from agents.loading import checkpoints, read_json
from agents.training.settings import TrainSettings
from baselines.runner import check_writable
from ios_uav_env.io import atomic_write_text

RUNS_DIR = Path("runs")

#: What a run leaves in its folder before its first checkpoint: such a folder can be reused.
UNSTARTED_RUN = ("config.json", "monitor", "tb", "checkpoints")


def run_name(settings: TrainSettings) -> str:
    """CleanRL-style name: env, algorithm, seed and start time."""
    env = re.sub(r"[^A-Za-z0-9_.-]+", "-", settings.env_id)
    return f"{env}__{settings.algo}__{settings.seed}__{int(time.time())}"


def _unstarted(run_dir: Path) -> bool:
    """A run folder holding only what a run writes before its first checkpoint."""
    names = {p.name for p in run_dir.iterdir()}
    return names <= set(UNSTARTED_RUN) and not checkpoints(run_dir)


def check_new_run_dir(run_dir: str | Path) -> Path:
    """``run_dir`` if a new run can start there: missing, empty, or the leftovers of a run stopped
    before its first checkpoint (:data:`UNSTARTED_RUN`, replaced by the new run), and writable."""
    run_dir = Path(run_dir)
    if run_dir.exists() and not run_dir.is_dir():
        raise FileExistsError(f"run folder {run_dir} is a file")
    if run_dir.exists() and any(run_dir.iterdir()) and not _unstarted(run_dir):
        raise FileExistsError(f"run folder {run_dir} exists and is not empty (resume it instead)")
    return check_writable(run_dir)


def clear_unstarted(run_dir: Path) -> None:
    """Remove what a run stopped before its first checkpoint left (see :func:`check_new_run_dir`)."""
    if not run_dir.exists():
        return
    check_new_run_dir(run_dir)
    for name in UNSTARTED_RUN:
        path = run_dir / name
        if path.is_dir():
            shutil.rmtree(path)
        elif path.exists():
            path.unlink()


def check_resumable(run_dir: str | Path) -> Path:
    """``run_dir`` if it is a run folder (a readable ``config.json``) that can be written to."""
    run_dir = Path(run_dir)
    config = run_dir / "config.json"
    if not config.exists():
        raise FileNotFoundError(f"{run_dir} is not a run folder (no config.json)")
    read_config(run_dir)
    return check_writable(run_dir)


def read_config(run_dir: Path) -> dict[str, Any]:
    """A run's ``config.json`` (``ValueError`` naming it if unreadable or incomplete)."""
    path = run_dir / "config.json"
    config = read_json(path)
    missing = [k for k in ("args", "total_timesteps", "algo") if k not in config]
    if missing:
        raise ValueError(f"{path} is not a run's config (no {', '.join(missing)})")
    return config


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
        "vec_env": settings.vec_env,
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
