"""Packaging: the wheel installs ``ios_uav_env`` alone; the top-level tools run from a checkout."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TOOLS = ("agents", "baselines", "experiments")


def _copy_sources(dest: Path) -> None:
    """The files a build reads (Python sources and metadata; no models, caches or results)."""
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, dest / name)
    for top in ("ios_uav_env", *TOOLS):
        for path in (ROOT / top).rglob("*.py"):
            target = dest / path.relative_to(ROOT)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy(path, target)
    shutil.copy(ROOT / "train.py", dest / "train.py")


def test_the_wheel_holds_only_ios_uav_env(tmp_path):
    src, dist = tmp_path / "src", tmp_path / "dist"
    src.mkdir()
    _copy_sources(src)
    code = "import setuptools.build_meta as b, sys; print(b.build_wheel(sys.argv[1]))"
    proc = subprocess.run(
        [sys.executable, "-c", code, str(dist)], cwd=src, capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    (wheel,) = dist.glob("*.whl")
    with zipfile.ZipFile(wheel) as zf:
        names = zf.namelist()
    top = {name.split("/")[0] for name in names if not name.split("/")[0].endswith(".dist-info")}
    assert top == {"ios_uav_env"}
    assert "ios_uav_env/__init__.py" in names and not any(n.endswith((".zip", ".pkl", ".yml")) for n in names)
    (top_level,) = [n for n in names if n.endswith(".dist-info/top_level.txt")] or [None]
    if top_level is not None:
        with zipfile.ZipFile(wheel) as zf:
            assert zf.read(top_level).decode().split() == ["ios_uav_env"]


def _run(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    env.pop("PYTHONPATH", None)
    return subprocess.run(
        [sys.executable, *args], cwd=ROOT, capture_output=True, text=True, timeout=120, env=env
    )


def test_the_tools_run_from_a_checkout():
    proc = _run("-c", "import agents, baselines, experiments; print(agents.__file__, baselines.__file__)")
    assert proc.returncode == 0, proc.stderr
    assert all(Path(p).is_relative_to(ROOT) for p in proc.stdout.split())
    show = _run("-m", "agents.suite", "show")
    assert show.returncode == 0 and "held-out suite" in show.stdout, show.stderr
    train = _run("train.py", "--help")
    assert train.returncode == 0 and "--algo" in train.stdout, train.stderr
