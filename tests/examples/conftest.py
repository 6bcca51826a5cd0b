"""Run the scripts of examples/ in a subprocess, from the repository root, with tiny budgets.

A library that an example needs (the ``clients`` and ``rl`` extras) is skipped when missing,
except under CI (``CI`` set), where a missing client is a failure: CI installs ``.[all]``.
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"


def require(*modules: str) -> None:
    """Skip (fail under CI) unless every module can be imported."""
    missing = [m for m in modules if importlib.util.find_spec(m) is None]
    if missing:
        message = f"examples need {missing} (pip install -e '.[clients]')"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)


@pytest.fixture
def run_example() -> Callable[..., str]:
    def run(script: str, *args: str, timeout: float = 300, env_vars: dict[str, str] | None = None) -> str:
        env = {**os.environ, "OMP_NUM_THREADS": "1", "MPLBACKEND": "Agg", "PYTHONWARNINGS": "ignore"}
        env.update(env_vars or {})
        proc = subprocess.run(
            [sys.executable, str(EXAMPLES / script), *args],
            cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout,
        )  # fmt: skip
        command = " ".join([script, *args])
        assert proc.returncode == 0, f"{command} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-5000:]}"
        return proc.stdout

    return run
