"""Quick suites frozen for a test module, and tampered copies of them (energy and mobile suites, and
the online suites normalised by the clairvoyant optimum)."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from baselines.references.__main__ import main as references_main


def freeze_quick(tmp_path_factory: Any, kind: str) -> Path:
    """A one-scenario quick suite of ``kind`` ("energy", "mobile"), frozen by the references CLI."""
    out = tmp_path_factory.mktemp(kind)
    argv = [kind, "--quick", "--n", "1", "--cache", str(out / "cache"), "--dir", str(out)]
    assert references_main(argv) == 0
    return out / f"{kind}-quick-v1.json"


def tampered(frozen: Path, tmp_path: Path, change: Callable[[dict], Any]) -> Path:
    """A copy of the suite file ``frozen`` with ``change`` applied to its JSON data."""
    data = json.loads(frozen.read_text())
    change(data)
    path = tmp_path / "tampered.json"
    path.write_text(json.dumps(data))
    return path


def _online_argv(multi: bool) -> list[str]:
    return ["multi-node-mobile"] if multi else ["mobile", "--version", "2"]


def freeze_quick_online(tmp_path_factory: Any, multi: bool) -> Path:
    """A one-scenario quick suite normalised by the clairvoyant optimum, frozen by the references
    CLI: ``mobile --version 2 --quick`` (one node) or ``multi-node-mobile --quick`` (``multi``)."""
    kind = "multi-node-mobile" if multi else "mobile"
    out = tmp_path_factory.mktemp(f"{kind}-online")
    argv = [*_online_argv(multi), "--quick", "--n", "1", "--cache", str(out / "cache"), "--dir", str(out)]
    assert references_main(argv) == 0
    return out / f"{kind}-quick-v{1 if multi else 2}.json"


def rerun_tampered_online(frozen: Path, tmp_path: Path, change: Callable[[dict], Any], multi: bool) -> str:
    """The references CLI on a copy of the quick online suite's cache whose one record ``change``
    edits: the message it stops with (``SystemExit``); no suite file is written."""
    cache = tmp_path / "cache"
    shutil.copytree(frozen.parent / "cache", cache)
    (record,) = cache.glob("online_*.json")
    data = json.loads(record.read_text())
    change(data)
    record.write_text(json.dumps(data))
    argv = [*_online_argv(multi), "--quick", "--n", "1", "--cache", str(cache), "--dir", str(tmp_path)]
    with pytest.raises(SystemExit) as stop:
        references_main(argv)
    assert not list(tmp_path.glob("*.json")), "a suite that fails a check is never written"
    return str(stop.value)


def shipped_copy(tmp_path: Path, suite: str, name: str, n: int) -> Path:
    """A copy of the shipped ``suite``'s first ``n`` scenarios under the new ``name`` (it loads with
    its own hash, so a test may change it)."""
    from ios_uav_env.benchmark.suite_registry import suite_path

    data = json.loads(suite_path(suite).read_text())
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps({**data, "name": name, "scenarios": data["scenarios"][:n]}))
    return path
