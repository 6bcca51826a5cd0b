"""What the Makefile's recipes run with, whatever the shell exports."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_the_recipes_cache_bytecode_even_where_the_shell_says_not_to() -> None:
    """``make test`` starts a hundred or so interpreters: with PYTHONDONTWRITEBYTECODE reaching
    them, each would compile torch, Stable-Baselines3 and this package from source again."""
    make = shutil.which("make")
    if make is None:
        pytest.skip("no make on this machine")
    probe = 'probe-bytecode:\n\t@echo "[$$PYTHONDONTWRITEBYTECODE]"'
    # a make of its own (not a sub-make of `make test`'s: no inherited flags, no directory lines)
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MFLAGS", "MAKELEVEL")}
    env["PYTHONDONTWRITEBYTECODE"] = "1"
    proc = subprocess.run(
        [make, "-s", "--no-print-directory", "-f", "Makefile", f"--eval={probe}", "probe-bytecode"],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]", proc.stdout
