"""Cold numba compilation of registered ids: the seconds a first ``gym.make`` + ``reset`` + ``step``
and a first ``gym.make_vec`` + ``reset`` + ``step`` take with nothing in numba's disk cache.

Each id runs in a fresh Python process (nothing compiled in memory) with ``NUMBA_CACHE_DIR`` set
to a fresh temporary directory (nothing compiled on disk: numba writes its ``*.nbi`` / ``*.nbc``
files there instead of next to the sources, and the directory is deleted afterwards). In that
process, after the imports (``ios_uav_env`` and numba; timed apart as "import"): the single env
(``gym.make(id)``, ``reset(seed=0)``, one ``step`` of a seeded sampled action), then the vector
env (``gym.make_vec(id, num_envs=B, vectorization_mode="vector_entry_point")``, its ``reset`` and
one ``step``; an id without a vector entry point: "-"). Each phase reports wall seconds and
the process's CPU seconds (``time.process_time``: every thread of the process, numba's
compiler included); on a shared machine the CPU seconds move far less than the wall seconds,
so compare those, and run the trees compared alternately (``--repeats``).

``--tree PATH`` (repeatable) measures the package of another checkout (its root put first on
``PYTHONPATH``): e.g. a worktree of the main branch against this one, taken in turns.

    python benchmarks/cold_compile.py [--ids ID ...] [--num-envs 4] [--repeats 1] [--tree PATH ...]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

DEFAULT_IDS = (
    "ios_uav_env/IOSUAV-v0",
    "ios_uav_env/IOSUAV-Energy-v0",
    "ios_uav_env/IOSUAV-MultiNode-v0",
    "ios_uav_env/IOSUAV-MultiNode-Mobile-v0",
)

#: The child's program: argv[1] the id, argv[2] B. Prints one JSON line of phase -> [wall, cpu].
_CHILD = r"""
import json, sys, time
w0, c0 = time.perf_counter(), time.process_time()
import gymnasium as gym
import numba  # noqa: F401
import ios_uav_env  # noqa: F401
out = {"import": [time.perf_counter() - w0, time.process_time() - c0]}
env_id, b = sys.argv[1], int(sys.argv[2])

def timed(name, run):
    w, c = time.perf_counter(), time.process_time()
    run()
    out[name] = [time.perf_counter() - w, time.process_time() - c]

def single():
    env = gym.make(env_id)
    env.reset(seed=0)
    env.action_space.seed(0)
    env.step(env.action_space.sample())
    env.close()

def vector():
    env = gym.make_vec(env_id, num_envs=b, vectorization_mode="vector_entry_point")
    env.reset(seed=0)
    env.action_space.seed(0)
    env.step(env.action_space.sample())
    env.close()

timed("single", single)
if gym.spec(env_id).vector_entry_point is not None:
    timed("vector", vector)
print(json.dumps(out))
"""


def measure(env_id: str, num_envs: int, tree: Path) -> dict[str, list[float]]:
    """Phase -> [wall s, CPU s] of ``env_id`` in a fresh process on the package of ``tree`` with an
    empty numba cache directory."""
    with tempfile.TemporaryDirectory(prefix="cold-numba-") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        env["PYTHONPATH"] = os.pathsep.join([str(tree), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
        done = subprocess.run(
            [sys.executable, "-c", _CHILD, env_id, str(num_envs)],
            env=env, cwd=str(tree), capture_output=True, text=True, check=False,
        )  # fmt: skip
    if done.returncode != 0:
        raise RuntimeError(f"{env_id} on {tree} failed:\n{done.stderr[-3000:]}")
    result: dict[str, list[float]] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


def _cell(phases: dict[str, list[float]], name: str) -> str:
    if name not in phases:
        return f"{'-':>15}"
    wall, cpu = phases[name]
    return f"{wall:6.1f} / {cpu:6.1f}"


def main(argv: list[str] | None = None) -> None:
    """Parse the arguments, measure each tree and id in turn, print a table."""
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--ids", nargs="+", default=list(DEFAULT_IDS), help="the ids to measure")
    parser.add_argument("--num-envs", type=int, default=4, help="B of the vector env (default 4)")
    parser.add_argument("--repeats", type=int, default=1, help="rounds over trees and ids (default 1)")
    parser.add_argument("--tree", action="append", type=Path, help="a checkout's root (default: this one)")
    args = parser.parse_args(argv)
    if args.num_envs < 1:
        parser.error(f"--num-envs must be >= 1, got {args.num_envs}")
    if args.repeats < 1:
        parser.error(f"--repeats must be >= 1, got {args.repeats}")
    trees = [t.resolve() for t in (args.tree or [ROOT])]
    for tree in trees:
        if not (tree / "ios_uav_env" / "__init__.py").is_file():
            parser.error(f"--tree {tree}: not a checkout of ios-uav-env (no ios_uav_env/__init__.py)")
    import gymnasium as gym

    import ios_uav_env  # noqa: F401  (registers the ids)

    unknown = [env_id for env_id in args.ids if env_id not in gym.registry]
    if unknown:
        parser.error(f"--ids: not registered: {', '.join(unknown)} (e.g. {DEFAULT_IDS[0]})")
    print(f"{'tree':<28} {'id':<40} {'import w/cpu s':>15} {'single w/cpu s':>15} {'vector w/cpu s':>15}")
    totals: dict[Path, list[float]] = {t: [0.0, 0.0] for t in trees}
    for _ in range(args.repeats):
        for env_id in args.ids:
            for tree in trees:
                phases = measure(env_id, args.num_envs, tree)
                for name in ("single", "vector"):
                    if name in phases:
                        totals[tree][0] += phases[name][0]
                        totals[tree][1] += phases[name][1]
                print(
                    f"{tree.name:<28} {env_id:<40} {_cell(phases, 'import')} {_cell(phases, 'single')} "
                    f"{_cell(phases, 'vector')}",
                    flush=True,
                )
    for tree, (wall, cpu) in totals.items():
        print(f"{tree.name}: single + vector, all ids and repeats: {wall:.1f} s wall, {cpu:.1f} s CPU")


if __name__ == "__main__":
    main()
