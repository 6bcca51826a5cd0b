"""The benchmark from the wheel alone: a fresh virtual environment holding only the built wheel
(installed by pip, without dependencies) and the wheel's two dependencies, numpy and Gymnasium
(with theirs: cloudpickle, typing_extensions, farama_notifications), linked from this test's
environment instead of downloaded. In it ``evaluate`` scores a plain callable and the command
line scores a file of trajectories (``.npz`` and ``.csv``), importing nothing else: cvxpy,
torch, scipy and matplotlib cannot even be found there.
"""

from __future__ import annotations

import importlib.metadata
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: The wheel's dependencies and theirs (distribution names).
RUNTIME = ("numpy", "gymnasium", "cloudpickle", "typing_extensions", "farama-notifications")

SCRIPT = """
import sys
from pathlib import Path

import numpy as np

import ios_uav_env
from ios_uav_env.benchmark import evaluate, write_trajectories

out = Path(sys.argv[1])
assert Path(ios_uav_env.__file__).is_relative_to(Path(sys.prefix)), ios_uav_env.__file__
results = evaluate(lambda obs: np.array([0.5, 0.0]), n=4, name="east")   # a plain callable
assert results.aggregate.n == 4 and results.aggregate.feasible == 4, results.summary()
results.save(out / "policy")
plans = {r.index: r.trajectory for r in results.scenarios}
write_trajectories(out / "plans.csv", plans)
print(results.summary())
loaded = {"cvxpy", "torch", "scipy", "matplotlib", "baselines", "agents"} & set(sys.modules)
assert not loaded, loaded
import importlib.util
found = [m for m in ("cvxpy", "torch", "scipy", "matplotlib") if importlib.util.find_spec(m)]
assert not found, found
"""


def _env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "VIRTUAL_ENV"))}
    return {**env, "OMP_NUM_THREADS": "1"}


def _run(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    proc = subprocess.run(args, cwd=cwd, env=_env(), capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"{' '.join(map(str, args))}\n{proc.stdout[-2000:]}\n{proc.stderr[-4000:]}"
    return proc


def _copy_sources(dest: Path) -> None:
    """What the build reads: metadata and the package with its data files."""
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, dest / name)
    shutil.copytree(ROOT / "ios_uav_env", dest / "ios_uav_env", ignore=shutil.ignore_patterns("__pycache__"))


def _link_runtime(site: Path) -> None:
    """Link the installed numpy, Gymnasium and their dependencies into ``site``."""
    source = Path(sysconfig.get_paths()["purelib"])
    for name in RUNTIME:
        dist = importlib.metadata.distribution(name)
        tops = {Path(str(f)).parts[0] for f in dist.files or ()} - {"..", "__pycache__"}
        for top in tops:
            if (source / top).exists() and not (site / top).exists():
                (site / top).symlink_to(source / top)


def test_the_wheel_alone_scores_a_callable_and_a_trajectory_file(tmp_path):
    src, dist, venv, out = tmp_path / "src", tmp_path / "dist", tmp_path / "venv", tmp_path / "out"
    src.mkdir()
    _copy_sources(src)
    build = "import setuptools.build_meta as b, sys; print(b.build_wheel(sys.argv[1]))"
    _run([sys.executable, "-c", build, str(dist)], src)
    (wheel,) = dist.glob("*.whl")
    _run([sys.executable, "-m", "venv", "--without-pip", str(venv)], tmp_path)
    python = venv / "bin" / "python"
    pip = [sys.executable, "-m", "pip", "--python", str(python), "install", "-q", "--no-deps", "--no-index"]
    _run([*pip, str(wheel)], tmp_path)
    site = Path(_run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                     tmp_path).stdout.strip())  # fmt: skip
    _link_runtime(site)

    first = _run([str(python), "-I", "-c", SCRIPT, str(out)], tmp_path).stdout.splitlines()[0]
    assert first.startswith("east on single-node-v1 (4 scenarios): % of DP mean")
    assert (out / "policy" / "results.csv").exists() and not (out / "policy" / "pct_dp.png").exists()
    for name in ("policy/trajectories.npz", "plans.csv"):
        cli = [str(python), "-I", "-m", "ios_uav_env.benchmark", "evaluate", "--name", "east"]
        proc = _run(
            [*cli, "--trajectories", str(out / name), "--out", str(out / f"cli-{Path(name).stem}")], tmp_path
        )
        line = proc.stdout.splitlines()[0]
        assert line.split("; median plan")[0] == first.split("; median plan")[0], (line, first)
        assert "no figure: matplotlib is not installed" in proc.stdout
