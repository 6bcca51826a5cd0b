"""Quick suites frozen for a test module, and tampered copies of them (energy and mobile suites, and
the online suites normalised by the clairvoyant optimum)."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

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


def freeze_quick_online(tmp_path_factory: Any, multi: bool) -> Path:
    """A one-scenario quick suite normalised by the clairvoyant optimum, frozen by the references
    CLI: ``mobile --version 2 --quick`` (one node) or ``multi-node-mobile --quick`` (``multi``)."""
    kind = "multi-node-mobile" if multi else "mobile"
    out = tmp_path_factory.mktemp(f"{kind}-online")
    version = [] if multi else ["--version", "2"]
    argv = [kind, *version, "--quick", "--n", "1", "--cache", str(out / "cache"), "--dir", str(out)]
    assert references_main(argv) == 0
    return out / f"{kind}-quick-v{1 if multi else 2}.json"
