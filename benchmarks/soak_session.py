"""The fault sessions the soak benchmarks (``soak_faults.py``, ``soak_fast.py``) share: a command
run in a process group of its own (:class:`Session`), killed by SIGKILL after a random delay or run
under a random file-size limit (RLIMIT_FSIZE) (:func:`fault_plan`, :func:`run_session`); the check
that a run's result files read back (:func:`torn_files`); the file identity that shows a rewrite
(:func:`identity`); the report helpers; and the command-line options every soak takes
(:func:`add_fault_arguments`, :func:`check_fault_arguments`).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pickle
import random
import resource
import signal
import subprocess
import sys
import threading
import time
import zipfile
from collections.abc import Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: When a SIGKILL comes (s after the session starts; startup, the imports included, takes a few).
KILL_AFTER = {"imitation": (2.0, 14.0), "sweep": (4.0, 16.0), "fast": (4.0, 16.0)}
#: The file-size limit of a disk-full session, log-uniform between these (bytes): from below the
#: smallest result file to below the largest (checkpoints, datasets), so some write always fails.
LIMIT_RANGE = {"imitation": (600, 100_000), "sweep": (600, 140_000), "fast": (600, 100_000)}
CHECKED = (".json", ".yml", ".npz", ".zip", ".pkl")


class Session:
    """One command in a session (process group) of its own; its output lines read as they come."""

    def __init__(self, argv: list[str], limit: int | None = None) -> None:
        # no bytecode cache writes: under a file-size limit CPython renames a short .pyc into the
        # source tree's __pycache__ (it does not check the write's count), which breaks every import
        # of that module afterwards, in any process
        env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "OMP_NUM_THREADS": "1",
               "HOME": os.environ.get("HOME", "/tmp"), "PYTHONDONTWRITEBYTECODE": "1"}  # fmt: skip
        self.started_at = time.monotonic()
        self.proc = subprocess.Popen(
            [sys.executable, *argv], cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
            text=True, start_new_session=True,
        )  # fmt: skip
        if limit is not None:  # before the command writes anything (its imports take seconds)
            resource.prlimit(self.proc.pid, resource.RLIMIT_FSIZE, (limit, limit))
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    def wait(self, timeout: float) -> int | None:
        """The exit status, or None if it still runs after ``timeout`` s."""
        try:
            code = self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            return None
        self._reader.join(1)  # workers left running may hold the pipe: their lines come later
        return code

    def group(self) -> list[int]:
        """The live processes of this session's group (the command and the workers it started)."""
        pids = []
        for stat in Path("/proc").glob("[0-9]*/stat"):
            try:
                fields = stat.read_text().rsplit(")", 1)[1].split()
            except (OSError, IndexError):
                continue
            if int(fields[2]) == self.proc.pid and fields[0] != "Z":
                pids.append(int(stat.parent.name))
        return pids

    def end_group(self) -> None:
        """SIGKILL to whatever is left of this session's group."""
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        self.wait(30)

    def save(self, path: Path) -> None:
        """Its output so far into ``path`` (the soak's own log of the session)."""
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("\n".join(self.lines) + "\n")

    def tail(self, n: int = 15) -> str:
        return "\n".join("    | " + line for line in self.lines[-n:])


def torn_files(folder: Path) -> tuple[list[str], int]:
    """The result files of ``folder`` that do not read back, and the count of temporary files of
    atomic writes left behind."""
    import numpy as np
    import yaml

    torn, litter = [], 0
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        if path.name.startswith(".") and path.name.endswith(".tmp"):
            litter += 1
            continue
        if path.suffix not in CHECKED:
            continue
        try:
            if path.suffix == ".json":
                json.loads(path.read_text())
            elif path.suffix == ".yml":
                yaml.safe_load(path.read_text())
            elif path.suffix == ".npz":
                with np.load(path) as data:
                    [data[k] for k in data.files]
            elif path.suffix == ".zip":
                with zipfile.ZipFile(path) as archive:
                    if archive.testzip() is not None:
                        raise ValueError("a member fails its CRC")
            else:
                with path.open("rb") as fh:
                    pickle.load(fh)
        except Exception as exc:  # a torn file fails in many ways
            torn.append(f"{path.relative_to(folder)} ({type(exc).__name__})")
    return torn, litter


def identity(path: Path) -> tuple[int, int] | None:
    """What changes when a file is written again (atomic writes make a new inode)."""
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_ino, st.st_mtime_ns


def fault_plan(kind_count: int, rng: random.Random, target: str) -> list[tuple[str, float]]:
    """``kind_count`` faults, SIGKILL and disk full in turn: (kind, delay in s or limit in bytes)."""
    lo, hi = LIMIT_RANGE[target]
    out = []
    for k in range(kind_count):
        if k % 2 == 0:
            out.append(("SIGKILL", rng.uniform(*KILL_AFTER[target])))
        else:
            out.append(("disk full", float(int(math.exp(rng.uniform(math.log(lo), math.log(hi)))))))
    return out


def describe_fault(kind: str, value: float) -> str:
    return f"SIGKILL after {value:.1f} s" if kind == "SIGKILL" else f"disk full at {value / 1000:.1f} kB"


def run_session(argv: list[str], kind: str, value: float, timeout: float) -> tuple[Session, str]:
    """One fault session: killed after ``value`` s, or run under a file-size limit of ``value`` bytes.
    Returns the session and how it ended."""
    if kind == "SIGKILL":
        session = Session(argv)
        code = session.wait(value)
        if code is None:
            session.proc.kill()
            session.wait(30)
            return session, "killed"
        return session, f"ended first (exit {code})"
    session = Session(argv, limit=int(value))
    code = session.wait(timeout)
    if code is None:
        session.end_group()
        return session, "timed out (killed)"
    return session, f"exit {code}"


def error_line(session: Session) -> str | None:
    """The last line of a failed session that names an error, shortened, and whether a traceback
    came with it."""
    found = [line for line in session.lines if "rror" in line]
    if not found:
        return None
    traceback = any(line.startswith("Traceback") for line in session.lines)
    return f"{'after a traceback' if traceback else 'one line'}: {found[-1][:140]}"


def spans(numbers: Sequence[int]) -> str:
    """``[0, 1, 2, 5]`` -> ``0-2, 5``; empty -> ``none``."""
    out: list[str] = []
    for n in sorted(numbers):
        if out and int(out[-1].split("-")[-1]) == n - 1:
            out[-1] = f"{out[-1].split('-')[0]}-{n}"
        else:
            out.append(str(n))
    return ", ".join(out) or "none"


def add_fault_arguments(parser: argparse.ArgumentParser, max_seconds: float) -> None:
    """The options every soak takes: --faults, --seed, --session-timeout, --max-seconds, --keep."""
    parser.add_argument("--faults", type=int, default=4, help="faults per command, 1 to 20 (default 4)")
    parser.add_argument("--seed", type=int, default=0, help="seeds the fault times and sizes (default 0)")
    parser.add_argument("--session-timeout", type=float, default=300.0,
                        help="seconds one session may run, 10 to 3600 (default 300)")  # fmt: skip
    parser.add_argument(
        "--max-seconds", type=float, default=max_seconds,
        help=f"no new fault after this many seconds, 60 to 7200 (default {max_seconds:g})",
    )  # fmt: skip
    parser.add_argument(
        "--keep", type=Path, default=None, help="run in this new folder (kept), not a temporary one"
    )


def check_fault_arguments(parser: argparse.ArgumentParser, args: argparse.Namespace) -> float:
    """``args`` of :func:`add_fault_arguments` checked (a parser error naming the option); returns the
    monotonic deadline after which no new fault starts."""
    if not 1 <= args.faults <= 20:
        parser.error(f"argument --faults: must be 1 to 20, got {args.faults}")
    if not 10 <= args.session_timeout <= 3600:
        parser.error(f"argument --session-timeout: must be 10 to 3600 s, got {args.session_timeout}")
    if not 60 <= args.max_seconds <= 7200:
        parser.error(f"argument --max-seconds: must be 60 to 7200 s, got {args.max_seconds}")
    if args.keep is not None and args.keep.exists():
        parser.error(f"argument --keep: {args.keep} exists; give a new folder")
    return time.monotonic() + args.max_seconds
