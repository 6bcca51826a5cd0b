"""What the process tests share: the children of a process, whether one is alive, its command
line (read from /proc, Linux), a bounded wait for a condition, and a fresh interpreter without
numba (the plain-Python kernels)."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest


def children(pid: int) -> list[int]:
    """The pids whose parent is ``pid``."""
    kids = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            kids.append(int(stat.parent.name))
    return kids


def alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie does not)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def cmdline(pid: int) -> str:
    """The command line of ``pid`` (NUL-separated), "" if it is gone."""
    try:
        return Path(f"/proc/{pid}/cmdline").read_text()
    except OSError:
        return ""


def wait_for(condition: Callable[[], object], seconds: float, what: str) -> None:
    """Poll ``condition`` every 0.1 s; fail the test naming ``what`` after ``seconds``."""
    deadline = time.monotonic() + seconds
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"gave up waiting for {what}")
        time.sleep(0.1)


def run_without_numba(code: str, stdin: str | None = None, timeout: float = 600) -> str:
    """Run ``code`` in a fresh interpreter with ``IOS_UAV_ENV_NO_NUMBA=1`` (so ``ios_uav_env.jit``
    runs the plain-Python kernels), feeding it ``stdin``; its stdout, after asserting it exited 0
    (the failure shows the end of its stderr)."""
    env = {**os.environ, "IOS_UAV_ENV_NO_NUMBA": "1"}
    run = subprocess.run(
        [sys.executable, "-c", code], input=stdin, env=env, capture_output=True, text=True, timeout=timeout
    )
    assert run.returncode == 0, run.stderr[-3000:]
    return run.stdout
