"""Soak test of the fast trainer's crashes and full disks: ``train.py --trainer fast`` (a tiny
recipe) is killed by SIGKILL at random moments, or runs out of disk space part-way through a write
(a file-size limit, RLIMIT_FSIZE, of a random size: a write beyond it fails with EFBIG), several
times, and resumed (``--resume``) after each fault; then it finishes undisturbed.

    python benchmarks/soak_fast.py                     # 4 faults, seed 0
    python benchmarks/soak_fast.py --faults 6 --seed 3
    python benchmarks/soak_faults.py --target fast     # the same, as a target of soak_faults.py

For every fault it prints the newest whole checkpoint (its steps and the updates its trainer
state counts), the whole lines of ``progress.csv`` up to that checkpoint, the lines lost (updates
the checkpoint counts that have no line), the torn files (a result file that does not read
back, or a log whose last line is unfinished or a line that is not one JSON record), the
temporary files of atomic writes left (litter, never read), how a disk-full session ended (one
clear line, or after a traceback) and the step the next session resumed from (the steps lost
beyond the work in progress: a checkpoint newer than that step). At the end ``progress.csv`` must
hold exactly one whole line per update the final checkpoint counts, in order.

A benchmark, not a test (every session starts a Python with torch). Exit status 0 if no line and
no checkpointed step was lost, no file was left torn and the run ended complete; 1 otherwise.
"""

from __future__ import annotations

import argparse
import json
import pickle
import random
import re
import sys
import tempfile
import time
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from soak_session import (  # noqa: E402
    Session,
    add_fault_arguments,
    check_fault_arguments,
    describe_fault,
    error_line,
    fault_plan,
    run_session,
    torn_files,
)

#: The tiny recipe: 32 rows x 8 slots = 256 env steps per update.
RECIPE = """
ios_uav_env/IOSUAV-v0:
  n_envs: 32
  policy: 'MlpPolicy'
  normalize: "{'norm_obs': True, 'norm_reward': True}"
  n_steps: 8
  batch_size: 128
  n_epochs: 2
  policy_kwargs: "dict(net_arch=dict(pi=[16], vf=[16]), log_std_init=-1.0)"
"""
STEPS = 262144  # 1024 updates
CHECKPOINT = 16384  # a checkpoint every 64 updates
STARTED = re.compile(r"training (\S+) \(fast PPO\): step (\d+) of (\d+)")


@dataclass
class State:
    """What the run folder holds after a session."""

    steps: int  # the newest whole checkpoint's steps (0: none)
    updates: int  # the updates its trainer state counts
    lines: int  # progress.csv's whole JSON lines
    logged: int  # of them, the lines of updates at or before the checkpoint
    torn: list[str]  # torn files (a log's unfinished or unreadable lines included)
    litter: int

    @property
    def lost(self) -> int:
        """Updates the checkpoint counts that have no line."""
        return max(0, self.updates - self.logged)

    @classmethod
    def read(cls, run: Path) -> State:
        steps = updates = 0
        folder = run / "checkpoints"
        for zip_path in folder.glob("rl_model_*_steps.zip") if folder.is_dir() else []:
            match = re.fullmatch(r"rl_model_(\d+)_steps\.zip", zip_path.name)
            try:
                with zipfile.ZipFile(zip_path) as archive:
                    whole = archive.testzip() is None
                with (folder / f"rl_model_trainer_{match.group(1)}_steps.pkl").open("rb") as fh:
                    counted = int(pickle.load(fh)["updates"])
            except (OSError, zipfile.BadZipFile, pickle.UnpicklingError, EOFError, KeyError, AttributeError):
                continue
            if whole and int(match.group(1)) > steps:
                steps, updates = int(match.group(1)), counted
        torn, litter = torn_files(run) if run.is_dir() else ([], 0)
        lines, logged = 0, 0
        log = run / "progress.csv"
        if log.exists():
            text = log.read_text(errors="replace")
            if text and not text.endswith("\n"):
                torn.append("progress.csv (an unfinished last line)")
            bad = 0
            for line in text.split("\n")[:-1]:
                try:
                    record_steps = int(json.loads(line)["steps"])
                except (ValueError, KeyError, TypeError):
                    bad += 1
                    continue
                lines += 1
                logged += record_steps <= steps
            if bad:
                torn.append(f"progress.csv ({bad} lines that are not one JSON record)")
        return cls(steps, updates, lines, logged, torn, litter)


def argv_of(run: Path, hp: Path) -> list[str]:
    """A new run, or ``--resume`` once the folder is a run folder (its config.json written)."""
    train = str(ROOT / "train.py")
    if (run / "config.json").exists():
        return [train, "--resume", str(run), "--no-progress"]
    return [train, "--algo", "ppo", "--trainer", "fast", "--hyperparams", str(hp), "--out", str(run),
            "--timesteps", str(STEPS), "--env-kwargs", "T:40", "--checkpoint-freq", str(CHECKPOINT),
            "--eval-freq", "0", "--no-progress", "--threads", "1"]  # fmt: skip


def resumed_at(session: Session) -> int | None:
    found = [int(m.group(2)) for line in session.lines if (m := STARTED.search(line))]
    return found[0] if found else None


def soak_fast(workdir: Path, faults: int, rng: random.Random, timeout: float, deadline: float) -> bool:
    run, hp = workdir / "fast" / "run", workdir / "fast" / "fast.yml"
    hp.parent.mkdir(parents=True, exist_ok=True)
    hp.write_text(RECIPE)
    print(f"soak: train.py --trainer fast, {STEPS} steps ({STEPS // 256} updates), a checkpoint every "
          f"{CHECKPOINT} steps, {faults} faults, run {run}")  # fmt: skip
    print(f"  {'#':>2} {'fault':24} {'ended':20} {'checkpoint':>10} {'updates':>7} {'lines':>5} {'lost':>4} "
          f"{'torn':>4} {'litter':>6}  next session resumed at")  # fmt: skip
    rows, ok = [], True
    for k, (kind, value) in enumerate(fault_plan(faults, rng, "fast")):
        if time.monotonic() > deadline:
            print(f"  out of time after {k} faults")
            break
        session, ended = run_session(argv_of(run, hp), kind, value, timeout)
        session.save(workdir / "logs" / f"fast-{k + 1}.log")
        if rows:
            rows[-1]["next"] = resumed_at(session)
        state = State.read(run)
        error = None if ended in ("killed", "exit 0") else error_line(session)
        rows.append({"fault": describe_fault(kind, value), "ended": ended, "state": state, "next": None,
                     "error": error})  # fmt: skip
        if (run / "summary.json").exists() and "exit 0" in ended:
            print(f"  the run finished before fault {k + 1} came: no more faults")
            break
    final = Session(argv_of(run, hp))
    code = final.wait(timeout)
    if code is None:
        final.end_group()
    final.save(workdir / "logs" / "fast-final.log")
    if rows:
        rows[-1]["next"] = resumed_at(final)
    lost_steps = 0
    for n, row in enumerate(rows, 1):
        s: State = row["state"]
        nxt = row["next"]
        late = 0 if nxt is None else max(0, s.steps - nxt)  # a whole checkpoint the next session skipped
        lost_steps += late
        ok &= not s.torn and s.lost == 0 and late == 0
        print(f"  {n:>2} {row['fault']:24} {row['ended']:20} {s.steps:>10} {s.updates:>7} {s.logged:>5} "
              f"{s.lost:>4} {len(s.torn):>4} {s.litter:>6}  {'-' if nxt is None else nxt}"
              f"{f' ({late} checkpointed steps lost)' if late else ''}")  # fmt: skip
        for name in s.torn:
            print(f"       torn: {name}")
        if row["error"]:
            print(f"       {row['error']}")
    end = State.read(run)
    complete = code == 0 and end.steps >= STEPS and (run / "summary.json").exists()
    exact = end.lines == end.updates == end.logged
    ok &= complete and exact and not end.torn
    if code != 0:
        print(f"  the final session failed:\n{final.tail()}")
    print(f"  final: exit {code}, checkpoint {end.steps} steps of {end.updates} updates, progress.csv "
          f"{end.lines} whole lines ({'one per update' if exact else 'NOT one per update'}), "
          f"{len(end.torn)} torn, {end.litter} litter")  # fmt: skip
    lines_lost = sum(row["state"].lost for row in rows)
    print(f"  lost: {lines_lost} log lines, {lost_steps} checkpointed steps; torn files at faults: "
          f"{sum(len(row['state'].torn) for row in rows)}; {'OK' if ok else 'FAIL'}")  # fmt: skip
    return ok


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python benchmarks/soak_fast.py", description=__doc__.splitlines()[0]
    )
    add_fault_arguments(parser, max_seconds=900.0)
    args = parser.parse_args(argv)
    deadline = check_fault_arguments(parser, args)
    with tempfile.TemporaryDirectory(prefix="soak-fast-") as tmp:
        workdir = args.keep or Path(tmp)
        workdir.mkdir(parents=True, exist_ok=True)
        ok = soak_fast(workdir, args.faults, random.Random(args.seed), args.session_timeout, deadline)
    print("soak: " + ("OK" if ok else "FAIL"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
