"""Soak test of interrupted training: a short ``train.py`` run is interrupted at random
moments by SIGINT and SIGTERM in turn, several times, and resumed each time; this prints, for every
interruption, the steps at the signal, the steps of the checkpoint it saved, the step the
next session resumed from and the steps lost (the unfinished rollout at most: n_steps x
n_envs for PPO, none for SAC), and checks that the run ends at its target step count.

    python benchmarks/soak_train.py                         # PPO, 4 interruptions, seed 0
    python benchmarks/soak_train.py --algo sac --interrupts 5 --seed 3

A benchmark, not a test (each session starts a Python with torch); exit status 0 if
every interruption lost no more than the bound and the run reached its target, 1 otherwise.
"""

from __future__ import annotations

import argparse
import json
import random
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: Tiny recipes in the zoo format (the hyperparameters of train.py), one rollout = ROLLOUT steps.
RECIPES = {
    "ppo": """
ios_uav_env/IOSUAV-v0:
  n_envs: 2
  policy: 'MlpPolicy'
  normalize: "{'norm_obs': True, 'norm_reward': True}"
  n_steps: 64
  batch_size: 64
  n_epochs: 2
  policy_kwargs: "dict(net_arch=[16, 16])"
""",
    "sac": """
ios_uav_env/IOSUAV-v0:
  n_envs: 1
  policy: 'MlpPolicy'
  learning_starts: 100
  batch_size: 32
  buffer_size: 10000
  train_freq: 1
  policy_kwargs: "dict(net_arch=[16, 16])"
""",
}
ROLLOUT = {"ppo": 64 * 2, "sac": 0}  # the steps an interruption may lose
TARGET = {"ppo": 8192, "sac": 2000}
STOPPED = re.compile(r"(SIGINT|SIGTERM) at step (\d+): saved checkpoint (\S+) \((\d+) steps\)")
STARTED = re.compile(r"training (.+): step (\d+) of (\d+)")


class Session:
    """One ``train.py`` process; its stderr lines are read as they come."""

    def __init__(self, argv: list[str], cwd: Path) -> None:
        env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "OMP_NUM_THREADS": "1"}
        self.proc = subprocess.Popen(
            [sys.executable, str(ROOT / "train.py"), "--no-progress", *argv],
            cwd=cwd, env=env, stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
        )  # fmt: skip
        self.lines: list[str] = []
        self.started = threading.Event()
        self.start_step: int | None = None
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            self.lines.append(line)
            match = STARTED.search(line)
            if match:
                self.start_step = int(match.group(2))
                self.started.set()

    def wait(self, timeout: float = 600) -> int:
        code = self.proc.wait(timeout)
        self._reader.join(10)
        return code


def newest_checkpoint(run: Path) -> int | None:
    from agents.loading import checkpoints

    found = checkpoints(run)
    return found[-1][0] if found else None


def soak(algo: str, interrupts: int, seed: int, workdir: Path, timesteps: int) -> bool:
    rng = random.Random(seed)
    (workdir / "hp.yml").write_text(RECIPES[algo])
    run = workdir / "run"
    bound = ROLLOUT[algo]
    print(f"soak: {algo.upper()}, {timesteps} steps, {interrupts} interruptions (seed {seed}), run {run}")
    print(f"  bound on the steps lost per interruption: {bound} ({'one rollout' if bound else 'none'})")
    print(f"  {'#':>2} {'signal':7} {'after s':>7} {'at step':>8} {'checkpoint':>10} {'resumed at':>10} "
          f"{'lost':>5}")  # fmt: skip
    first = ["--algo", algo, "--hyperparams", "hp.yml", "--out", "run", "--timesteps", str(timesteps),
             "--seed", str(seed), "--env-kwargs", "T:60", "--eval-freq", "0",
             "--checkpoint-freq", "1000000"]  # fmt: skip
    argv, ok, pending, done = first, True, None, 0
    while True:
        session = Session(argv, workdir)
        if not session.started.wait(300):
            session.proc.kill()
            print("  a session did not start:\n" + "".join(session.lines))
            return False
        if pending is not None:  # the previous interruption's row, now that we know where this one resumed
            n, name, delay, at, saved = pending
            lost = at - session.start_step
            good = session.start_step == saved and 0 <= lost <= bound
            ok &= good
            print(f"  {n:>2} {name:7} {delay:7.2f} {at:>8} {saved:>10} {session.start_step:>10} {lost:>5}"
                  f"{'' if good else '  <-- FAIL'}")  # fmt: skip
            pending = None
        if done == interrupts:
            break
        delay = rng.uniform(0.2, 2.5)
        signum = (signal.SIGINT, signal.SIGTERM)[done % 2]  # both kinds, in turn
        time.sleep(delay)
        if session.proc.poll() is None:
            session.proc.send_signal(signum)
        code = session.wait()
        text = "".join(session.lines)
        match = STOPPED.search(text)
        if match is None and (run / "summary.json").exists():  # it ended first (exit 0, or the signal
            print(f"  the run finished before the signal ({delay:.2f} s, exit {code}); "  # hit its shutdown)
                  f"{done} interruptions made")  # fmt: skip
            break
        if match is None or code != 128 + signum:
            print(f"  unexpected end (exit {code}):\n{text}")
            return False
        at, saved = int(match.group(2)), int(match.group(4))
        if newest_checkpoint(run) != saved:
            print(f"  the checkpoint on disk ({newest_checkpoint(run)}) is not the one reported ({saved})")
            ok = False
        done += 1
        pending = (done, signal.Signals(signum).name, delay, at, saved)
        argv = ["--resume", "run"]
    code = session.wait()
    summary = json.loads((run / "summary.json").read_text()) if (run / "summary.json").exists() else {}
    steps = summary.get("steps")
    reached = steps is not None and steps >= timesteps and steps - timesteps < max(bound, 1)
    ok &= reached
    n_ckpt = len(list((run / "checkpoints").glob("*.zip")))
    verdict = "OK" if ok else "FAIL"
    print(f"  final: exit {code}, {steps} steps (target {timesteps}), {n_ckpt} checkpoints; {verdict}")
    return ok


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python benchmarks/soak_train.py", description=__doc__.splitlines()[0]
    )
    parser.add_argument("--algo", choices=("ppo", "sac"), nargs="+", default=["ppo", "sac"])
    parser.add_argument("--interrupts", type=int, default=4, help="interruptions per run (default 4)")
    parser.add_argument("--seed", type=int, default=0, help="seeds the signal times and the training")
    parser.add_argument(
        "--keep", type=Path, default=None, help="run in this folder (kept) instead of a temporary one"
    )
    args = parser.parse_args(argv)
    ok = True
    for algo in args.algo:
        if args.keep is not None:
            workdir = args.keep / algo
            workdir.mkdir(parents=True, exist_ok=False)
            ok &= soak(algo, args.interrupts, args.seed, workdir, TARGET[algo])
        else:
            with tempfile.TemporaryDirectory(prefix=f"soak-{algo}-") as tmp:
                ok &= soak(algo, args.interrupts, args.seed, Path(tmp), TARGET[algo])
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
