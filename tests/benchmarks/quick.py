"""Run a benchmark script's ``main`` in-process, as its tests do: the script loaded from
``benchmarks/`` under a private module name, removed from ``sys.modules`` afterwards."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[2]


def run_main(script: str, argv: list[str]) -> ModuleType:
    """Load ``benchmarks/<script>.py``, check that ``main(argv)`` returns 0, return the module."""
    spec = importlib.util.spec_from_file_location(
        f"benchmarks_{script}", ROOT / "benchmarks" / f"{script}.py"
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    try:
        spec.loader.exec_module(module)
        assert module.main(argv) == 0
    finally:
        sys.modules.pop(spec.name, None)
    return module
