"""A run's folder: its name, whether a new run may start there or an old one be resumed, what a
run stopped before its first checkpoint left, the lock a process holds while it writes the
folder, and the resolved configuration ``config.json``."""

from __future__ import annotations

import dataclasses
import json
import os
import platform
import re
import shutil
import socket
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
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

#: The lock file of a run folder: held (an exclusive ``flock``) by the process writing the folder.
LOCK_FILE = ".lock"
#: What a run leaves in its folder before its first checkpoint: such a folder can be reused (the
#: SB3 path's monitor files and TensorBoard events, the fast trainer's log and clone record), as
#: can the temporary files of atomic writes a killed process left (:func:`_litter`).
UNSTARTED_RUN = ("config.json", "monitor", "tb", "checkpoints", "progress.csv", "clone.json")

#: The run folders whose lock this process holds (resolved paths).
_HELD: set[Path] = set()


class RunFolderInUse(OSError):
    """Another process holds the run folder's lock: it is writing the folder (``pid`` and ``host``:
    the holder's, as it wrote them in the lock; None if unknown)."""

    def __init__(self, run_dir: Path, pid: int | None, host: str | None = None) -> None:
        self.run_dir, self.pid, self.host = run_dir, pid, host
        holder = "another process" if pid is None else f"process {pid}"
        if host is not None and host != socket.gethostname():
            holder += f" on {host}"
        super().__init__(
            f"run folder {run_dir} is in use by {holder} (it holds {run_dir / LOCK_FILE}); wait for it "
            "to end or stop it, then run again"
        )

    def __reduce__(self) -> tuple[Any, ...]:  # raised in a worker process, re-raised in its parent
        return type(self), (self.run_dir, self.pid, self.host)


def _try_lock(fd: int) -> bool:
    """Take the exclusive lock of the open file ``fd`` without waiting; False if another holds it."""
    try:
        import fcntl
    except ImportError:  # Windows: a lock on the file's first byte
        import msvcrt

        try:
            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
        except OSError:
            return False
        return True
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return False
    return True


def _holder(lock: Path) -> tuple[int | None, str | None]:
    """The pid and host the lock's holder wrote into it (None if unknown)."""
    try:
        words = lock.read_text().split()
        return int(words[0]), words[1] if len(words) > 1 else None
    except (OSError, ValueError, IndexError):
        return None, None


def check_unlocked(run_dir: str | Path) -> Path:
    """``run_dir`` unless another process holds its lock (:class:`RunFolderInUse` naming the folder
    and the holder's pid); writes nothing (a folder this process holds passes)."""
    run_dir = Path(run_dir)
    lock = run_dir / LOCK_FILE
    if run_dir.resolve() in _HELD or not lock.is_file():
        return run_dir
    fd = os.open(lock, os.O_RDONLY)
    try:
        if not _try_lock(fd):
            raise RunFolderInUse(run_dir, *_holder(lock))
    finally:
        os.close(fd)  # closing the file releases the lock just taken
    return run_dir


@contextmanager
def lock_run_dir(run_dir: str | Path) -> Iterator[Path]:
    """Hold ``run_dir``'s lock (``<run_dir>/.lock``, created with the folder if missing, with this
    process's pid and host in it) while the block runs; the system releases it when the process
    ends, killed or crashed included. :class:`RunFolderInUse` naming the folder and the holder's
    pid if another process holds it."""
    run_dir = Path(run_dir)
    resolved = run_dir.resolve()
    if resolved in _HELD:
        raise RunFolderInUse(run_dir, os.getpid())
    run_dir.mkdir(parents=True, exist_ok=True)
    lock = run_dir / LOCK_FILE
    fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        for attempt in range(5):  # a check_unlocked elsewhere holds it for an instant only
            if _try_lock(fd):
                break
            if attempt == 4:
                raise RunFolderInUse(run_dir, *_holder(lock))
            time.sleep(0.05)
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()} {socket.gethostname()}\n".encode())
        _HELD.add(resolved)
        try:
            yield run_dir
        finally:
            _HELD.discard(resolved)
    finally:
        os.close(fd)


def run_name(settings: TrainSettings) -> str:
    """CleanRL-style name: env, algorithm, seed and start time."""
    env = re.sub(r"[^A-Za-z0-9_.-]+", "-", settings.env_id)
    return f"{env}__{settings.algo}__{settings.seed}__{int(time.time())}"


def _litter(name: str) -> bool:
    """A temporary file of an atomic write cut short: ``.<name>.<random>.tmp``
    (``ios_uav_env.io``) or ``.<stem>.tmp<pid><suffix>`` (``agents.callbacks.replace_into``)."""
    return name.startswith(".") and re.search(r"\.tmp(\d+(\.\w+)?)?$", name) is not None


def _leftovers(run_dir: Path) -> list[str]:
    """What ``run_dir`` holds beside what a run leaves before its first checkpoint."""
    names = {p.name for p in run_dir.iterdir()} - {LOCK_FILE, *UNSTARTED_RUN}
    return sorted(name for name in names if not _litter(name))


def _unstarted(run_dir: Path) -> bool:
    """A run folder holding only what a run writes before its first checkpoint."""
    return not _leftovers(run_dir) and not checkpoints(run_dir)


def check_new_run_dir(run_dir: str | Path) -> Path:
    """``run_dir`` if a new run can start there: missing, empty, or the leftovers of a run stopped
    before its first checkpoint (:data:`UNSTARTED_RUN`, replaced by the new run), writable, and
    not in use by another process (:func:`check_unlocked`)."""
    run_dir = Path(run_dir)
    if run_dir.exists() and not run_dir.is_dir():
        raise FileExistsError(f"run folder {run_dir} is a file")
    check_unlocked(run_dir)
    if run_dir.exists() and any(run_dir.iterdir()) and not _unstarted(run_dir):
        raise FileExistsError(f"run folder {run_dir} exists and is not empty (resume it instead)")
    return check_writable(run_dir)


def clear_unstarted(run_dir: Path) -> None:
    """Remove what a run stopped before its first checkpoint left (see :func:`check_new_run_dir`)."""
    if not run_dir.exists():
        return
    check_new_run_dir(run_dir)
    litter = [p.name for p in run_dir.iterdir() if _litter(p.name)]
    for name in (*UNSTARTED_RUN, *litter):
        path = run_dir / name
        if path.is_dir():
            shutil.rmtree(path)
        elif path.exists():
            path.unlink()


def start_fresh(run_dir: Path, again: bool) -> None:
    """Make ``run_dir`` ready for a run from step 0: what a run stopped before its first
    checkpoint left is removed (:func:`clear_unstarted`) and the folder exists; ``again`` (a
    resume of a run with no checkpoint) says so on stderr."""
    if again:
        print(f"{run_dir} holds no checkpoint: starting it again from step 0 with its own settings",
              file=sys.stderr)  # fmt: skip
    clear_unstarted(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)


def check_resumable(run_dir: str | Path) -> Path:
    """``run_dir`` if it is a run folder (a readable ``config.json``) with a checkpoint to go on
    from, or one stopped before its first checkpoint (resumed from step 0), that can be written to
    and that no other process is writing (:func:`check_unlocked`); writes nothing. A folder with a
    finished model but no checkpoint (a shipped model, ``agents/models/*``) is refused
    (``ValueError``)."""
    run_dir = Path(run_dir)
    config = run_dir / "config.json"
    if not config.exists():
        raise FileNotFoundError(f"{run_dir} is not a run folder (no config.json)")
    read_config(run_dir)
    if not checkpoints(run_dir) and _leftovers(run_dir):
        raise ValueError(
            f"{run_dir} has no checkpoint to resume from, and it holds more than a run stopped before its "
            f"first checkpoint ({', '.join(_leftovers(run_dir))}): a finished model without checkpoints "
            "(e.g. a shipped one) cannot be resumed; train a new run with --out"
        )
    check_unlocked(run_dir)
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


def normalized(hp: Hyperparams) -> dict[str, bool]:
    """Whether the run's VecNormalize normalises the observations and the rewards (both False
    without VecNormalize; its defaults are True)."""
    kwargs = hp.normalize
    if kwargs is None:
        return {"obs": False, "reward": False}
    return {"obs": bool(kwargs.get("norm_obs", True)), "reward": bool(kwargs.get("norm_reward", True))}


def _relative(path: Path) -> Path:
    """``path`` relative to the repository (``agents/hyperparams/...``) when it is inside it."""
    root = Path(__file__).resolve().parents[2]
    try:
        return path.resolve().relative_to(root)
    except ValueError:
        return path


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
        "hyperparams_file": str(settings.hyperparams_file or _relative(settings.hyperparams_path())),
        "normalize": normalized(hp),
        "scenario": base.config.to_dict(),
        "arrival_guard": base.arrival_guard,
        "channel": base.channel,
        "versions": versions(),
        "command": sys.argv,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }
    env.close()
    return atomic_write_text(run_dir / "config.json", json.dumps(config, indent=1, default=str))
