"""Soak test of crashes and full disks: ``python -m agents.imitation``, ``python -m agents.sweep`` and
``train.py --trainer fast`` (tiny settings; the last in ``benchmarks/soak_fast.py``) are killed by
SIGKILL at random moments, or run out of disk space part-way through
a write (a file-size limit, RLIMIT_FSIZE, of a random size: a write beyond it fails with EFBIG),
several times each, and run again after each fault; this prints, for every fault, what the run's
folder held when the session ended (finished rounds or trials, the newest checkpoints), the files
left torn, where the next session went on and what was lost beyond the work in progress, then
finishes the run undisturbed and checks that it is complete and that every file in it is whole.

    python benchmarks/soak_faults.py                         # the three commands, 4 faults each, seed 0
    python benchmarks/soak_faults.py --target sweep --faults 6 --seed 3

What counts as lost: for imitation, a round (or a tour plan) finished at a fault that a later
session computes again (its files replaced); for the sweep, a trial whose record existed at a
fault that is trained again, and the steps between the newest whole checkpoint a fault left and
the step the next session resumed that trial from. The work in progress (the round being
fitted, the plan being solved, the steps since a trial's last checkpoint) is what a fault may
cost. Torn: a result file (JSON, YAML, npz, zip, pickle) that does not read back; the
temporary files of an atomic write cut short are counted apart (litter, never read). The
Monitor's CSV logs and TensorBoard's event files are append-only logs and are not checked.
After a SIGKILL of the sweep, its worker processes must end by themselves (each checkpoints
its training and exits once its parent is gone): the script waits for them, reports any left
and then ends them (they are its own descendants, in the session it started).

A benchmark, not a test (every session starts a Python with torch; a few minutes in all, each
session and the whole run bounded by ``--session-timeout`` and ``--max-seconds``). Exit status
0 if nothing was lost beyond the work in progress, no file was left torn, no worker outlived
its sweep and every run ended complete; 1 otherwise.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pickle
import random
import re
import resource
import signal
import subprocess
import sys
import tempfile
import threading
import time
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: ``agents.imitation``: 2 scenarios, 10 short rounds (the settings of tests/agents/test_imitation.py).
IMITATION_ARGS = ["--scenarios", "2", "--rounds", "10", "--epochs", "40", "--net-arch", "32", "32",
                  "--batch-size", "64", "--learning-rate", "3e-3", "--jobs", "1",
                  "--no-progress"]  # fmt: skip
#: ``agents.sweep``: 3 seeds of a tiny PPO on 2 worker processes, a checkpoint every 2048 steps.
SWEEP_STEPS = 16384
SWEEP_TRIALS = 3
SWEEP_ARGS = ["--seeds", "0", "1", "2", "--jobs", "2", "--timesteps", str(SWEEP_STEPS),
              "--env-kwargs", "T:40", "--eval-freq", "0", "--checkpoint-freq", "2048", "--no-progress",
              "--set", "n_envs=2", "--set", "n_steps=32", "--set", "batch_size=64",
              "--set", "n_epochs=1"]  # fmt: skip
#: When a SIGKILL comes (s after the session starts; startup, the imports included, takes a few).
KILL_AFTER = {"imitation": (2.0, 14.0), "sweep": (4.0, 16.0), "fast": (4.0, 16.0)}
#: The file-size limit of a disk-full session, log-uniform between these (bytes): from below the
#: smallest result file to below the largest (checkpoints, datasets), so some write always fails.
LIMIT_RANGE = {"imitation": (600, 100_000), "sweep": (600, 140_000), "fast": (600, 100_000)}
#: How long the workers of a killed sweep may take to checkpoint and exit (agents.sweep's grace, 30 s,
#: and a margin).
ORPHAN_WAIT_S = 45.0
STARTED = re.compile(r"training (\S+): step (\d+) of (\d+)")
ROUND = re.compile(r"^round (\d+): ")
CHECKED = (".json", ".yml", ".npz", ".zip", ".pkl")


class Session:
    """One command in a session (process group) of its own; its output lines read as they come."""

    def __init__(self, argv: list[str], limit: int | None = None) -> None:
        # no bytecode cache writes: under a file-size limit CPython renames a short .pyc into the
        # source tree's __pycache__ (it does not check the write's count), which breaks every import
        # of that module afterwards, in any process
        env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "OMP_NUM_THREADS": "1",
               "HOME": os.environ.get("HOME", "/tmp"), "PYTHONDONTWRITEBYTECODE": "1"}  # fmt: skip
        self.started_at = time.monotonic()
        self.proc = subprocess.Popen(
            [sys.executable, *argv], cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
            text=True, start_new_session=True,
        )  # fmt: skip
        if limit is not None:  # before the command writes anything (its imports take seconds)
            resource.prlimit(self.proc.pid, resource.RLIMIT_FSIZE, (limit, limit))
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    def wait(self, timeout: float) -> int | None:
        """The exit status, or None if it still runs after ``timeout`` s."""
        try:
            code = self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            return None
        self._reader.join(1)  # workers left running may hold the pipe: their lines come later
        return code

    def group(self) -> list[int]:
        """The live processes of this session's group (the command and the workers it started)."""
        pids = []
        for stat in Path("/proc").glob("[0-9]*/stat"):
            try:
                fields = stat.read_text().rsplit(")", 1)[1].split()
            except (OSError, IndexError):
                continue
            if int(fields[2]) == self.proc.pid and fields[0] != "Z":
                pids.append(int(stat.parent.name))
        return pids

    def end_group(self) -> None:
        """SIGKILL to whatever is left of this session's group."""
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        self.wait(30)

    def save(self, path: Path) -> None:
        """Its output so far into ``path`` (the soak's own log of the session)."""
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("\n".join(self.lines) + "\n")

    def tail(self, n: int = 15) -> str:
        return "\n".join("    | " + line for line in self.lines[-n:])


def torn_files(folder: Path) -> tuple[list[str], int]:
    """The result files of ``folder`` that do not read back, and the count of temporary files of
    atomic writes left behind."""
    import numpy as np
    import yaml

    torn, litter = [], 0
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        if path.name.startswith(".") and path.name.endswith(".tmp"):
            litter += 1
            continue
        if path.suffix not in CHECKED:
            continue
        try:
            if path.suffix == ".json":
                json.loads(path.read_text())
            elif path.suffix == ".yml":
                yaml.safe_load(path.read_text())
            elif path.suffix == ".npz":
                with np.load(path) as data:
                    [data[k] for k in data.files]
            elif path.suffix == ".zip":
                with zipfile.ZipFile(path) as archive:
                    if archive.testzip() is not None:
                        raise ValueError("a member fails its CRC")
            else:
                with path.open("rb") as fh:
                    pickle.load(fh)
        except Exception as exc:  # a torn file fails in many ways
            torn.append(f"{path.relative_to(folder)} ({type(exc).__name__})")
    return torn, litter


def identity(path: Path) -> tuple[int, int] | None:
    """What changes when a file is written again (atomic writes make a new inode)."""
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_ino, st.st_mtime_ns


def fault_plan(kind_count: int, rng: random.Random, target: str) -> list[tuple[str, float]]:
    """``kind_count`` faults, SIGKILL and disk full in turn: (kind, delay in s or limit in bytes)."""
    lo, hi = LIMIT_RANGE[target]
    out = []
    for k in range(kind_count):
        if k % 2 == 0:
            out.append(("SIGKILL", rng.uniform(*KILL_AFTER[target])))
        else:
            out.append(("disk full", float(int(math.exp(rng.uniform(math.log(lo), math.log(hi)))))))
    return out


def describe_fault(kind: str, value: float) -> str:
    return f"SIGKILL after {value:.1f} s" if kind == "SIGKILL" else f"disk full at {value / 1000:.1f} kB"


def run_session(argv: list[str], kind: str, value: float, timeout: float) -> tuple[Session, str]:
    """One fault session: killed after ``value`` s, or run under a file-size limit of ``value`` bytes.
    Returns the session and how it ended."""
    if kind == "SIGKILL":
        session = Session(argv)
        code = session.wait(value)
        if code is None:
            session.proc.kill()
            session.wait(30)
            return session, "killed"
        return session, f"ended first (exit {code})"
    session = Session(argv, limit=int(value))
    code = session.wait(timeout)
    if code is None:
        session.end_group()
        return session, "timed out (killed)"
    return session, f"exit {code}"


def error_line(session: Session) -> str | None:
    """The last line of a failed session that names an error, shortened, and whether a traceback
    came with it."""
    found = [line for line in session.lines if "rror" in line]
    if not found:
        return None
    traceback = any(line.startswith("Traceback") for line in session.lines)
    return f"{'after a traceback' if traceback else 'one line'}: {found[-1][:140]}"


def spans(numbers: Sequence[int]) -> str:
    """``[0, 1, 2, 5]`` -> ``0-2, 5``; empty -> ``none``."""
    out: list[str] = []
    for n in sorted(numbers):
        if out and int(out[-1].split("-")[-1]) == n - 1:
            out[-1] = f"{out[-1].split('-')[0]}-{n}"
        else:
            out.append(str(n))
    return ", ".join(out) or "none"


# --- agents.imitation -----------------------------------------------------------------------
def finished_rounds(out: Path) -> list[int]:
    """The rounds a new session reads back: in summary.json, with their model and data on disk."""
    try:
        rounds = [e["round"] for e in json.loads((out / "summary.json").read_text())["rounds"]]
    except (OSError, ValueError, KeyError, TypeError):
        return []
    return [r for r in rounds if (out / "rounds" / str(r) / "model.zip").exists()
            and (out / "data" / f"round_{r}.npz").exists()]  # fmt: skip


def round_files(out: Path, r: int) -> list[Path]:
    return [out / "data" / f"round_{r}.npz", *(out / "rounds" / str(r) / name
            for name in ("model.zip", "vecnormalize.pkl", "config.json"))]  # fmt: skip


def soak_imitation(workdir: Path, faults: int, rng: random.Random, timeout: float, deadline: float) -> bool:
    out = workdir / "imitation"
    argv = ["-m", "agents.imitation", "--out", str(out), *IMITATION_ARGS]
    rounds = int(IMITATION_ARGS[IMITATION_ARGS.index("--rounds") + 1])
    print(f"soak: python -m agents.imitation, {rounds} rounds of 2 scenarios, {faults} faults, run {out}")
    print(f"  {'#':>2} {'fault':24} {'ended':22} {'finished then':16} {'plans':>5} {'torn':>4} "
          f"{'litter':>6}  next session computed")  # fmt: skip
    rows, snapshots, ok = [], [], True
    for k, (kind, value) in enumerate(fault_plan(faults, rng, "imitation")):
        if time.monotonic() > deadline:
            print(f"  out of time after {k} faults")
            break
        session, ended = run_session(argv, kind, value, timeout)
        session.save(workdir / "logs" / f"imitation-{k + 1}.log")
        computed = [int(m.group(1)) for line in session.lines if (m := ROUND.match(line))]
        if rows:
            rows[-1]["next"] = computed
        finished = finished_rounds(out)
        torn, litter = torn_files(out)
        ok &= not torn
        plans = sorted((out / "plans").glob("*.json")) if (out / "plans").is_dir() else []
        snapshot = {f"round {r}": [identity(p) for p in round_files(out, r)] for r in finished}
        snapshot |= {f"plan {p.stem}": [identity(p)] for p in plans}
        snapshots.append(snapshot)
        rows.append({"fault": describe_fault(kind, value), "ended": ended, "finished": finished,
                     "plans": len(plans), "torn": torn, "litter": litter, "next": None,
                     "error": None if ended in ("killed", "exit 0") else error_line(session)})  # fmt: skip
        if len(finished) == rounds and "exit 0" in ended:
            print(f"  the run finished before fault {k + 1} came: no more faults")
            break
    final = Session(argv)
    code = final.wait(timeout)
    if code is None:
        final.end_group()
    final.save(workdir / "logs" / "imitation-final.log")
    computed = [int(m.group(1)) for line in final.lines if (m := ROUND.match(line))]
    if rows:
        rows[-1]["next"] = computed
    for n, row in enumerate(rows, 1):
        print(f"  {n:>2} {row['fault']:24} {row['ended']:22} {'rounds ' + spans(row['finished']):16} "
              f"{row['plans']:>5} {len(row['torn']):>4} {row['litter']:>6}  "
              f"{'rounds ' + spans(row['next']) if row['next'] is not None else '-'}")  # fmt: skip
        for name in row["torn"]:
            print(f"       torn: {name}")
        if row["error"]:
            print(f"       {row['error']}")
    lost = []  # what a fault left finished and a later session computed again
    for n, snapshot in enumerate(snapshots, 1):
        for item, ids in snapshot.items():
            r = int(item.split()[1]) if item.startswith("round") else None
            now = [identity(p) for p in round_files(out, r)] if r is not None else \
                [identity(out / "plans" / f"{item.split()[1]}.json")]  # fmt: skip
            if now != ids:
                lost.append(f"{item} (finished at fault {n})")
    lost = list(dict.fromkeys(lost))
    finished = finished_rounds(out)
    torn, litter = torn_files(out)
    complete = code == 0 and finished == list(range(rounds)) and (out / "model.zip").exists()
    ok &= complete and not lost and not torn
    print(f"  final: exit {code}, rounds {spans(finished)} finished, {len(torn)} torn, {litter} litter")
    print(f"  lost beyond the work in progress: {', '.join(lost) if lost else 'nothing'}; "
          f"{'OK' if ok else 'FAIL'}")  # fmt: skip
    return ok


# --- agents.sweep ---------------------------------------------------------------------------
@dataclass
class SweepState:
    """What a sweep's folder holds: the finished trials' records and each run's newest whole checkpoint."""

    records: dict[str, tuple[int, int] | None] = field(default_factory=dict)  # trial -> file identity
    newest: dict[str, int] = field(default_factory=dict)  # run folder name -> steps (if any)

    @classmethod
    def read(cls, out: Path) -> SweepState:
        state = cls()
        for path in sorted((out / "results").glob("*.json")) if (out / "results").is_dir() else []:
            try:
                state.records[json.loads(path.read_text())["trial"]] = identity(path)
            except (OSError, ValueError, KeyError):
                continue
        for run in sorted((out / "runs").iterdir()) if (out / "runs").is_dir() else []:
            whole = []
            for zip_path in (run / "checkpoints").glob("rl_model_*_steps.zip"):
                match = re.fullmatch(r"rl_model_(\d+)_steps\.zip", zip_path.name)
                try:
                    with zipfile.ZipFile(zip_path) as archive:
                        good = archive.testzip() is None
                except (OSError, zipfile.BadZipFile):
                    good = False
                if match and good:
                    whole.append(int(match.group(1)))
            if whole:
                state.newest[run.name] = max(whole)
        return state


def short(run: str) -> str:
    """A trial's run folder name by its seed (``...__seed1__...`` -> ``seed1``)."""
    match = re.search(r"seed\d+", run)
    return match.group(0) if match else run


def resumed_steps(lines: list[str]) -> dict[str, int]:
    """Run folder name -> the step a session's training of it started from."""
    return {Path(m.group(1)).name: int(m.group(2)) for line in lines if (m := STARTED.search(line))}


def soak_sweep(workdir: Path, faults: int, rng: random.Random, timeout: float, deadline: float) -> bool:
    out = workdir / "sweep"
    argv = ["-m", "agents.sweep", "--out", str(out), *SWEEP_ARGS]
    print(f"soak: python -m agents.sweep, {SWEEP_TRIALS} trials of {SWEEP_STEPS} steps on 2 workers, "
          f"a checkpoint every 2048 steps, {faults} faults, run {out}")  # fmt: skip
    print(f"  {'#':>2} {'fault':24} {'ended':22} {'workers left':>12} {'trials done':>11} {'torn':>4} "
          f"{'litter':>6}")  # fmt: skip
    ok, rows = True, []
    pending: dict[str, tuple[int, int]] = {}  # run -> (fault number, newest whole checkpoint then)
    lost: list[str] = []
    states: list[SweepState] = []

    def note_resumed(lines: list[str]) -> str:
        started = resumed_steps(lines)
        for run, step in started.items():
            if run in pending:
                n, kept = pending.pop(run)
                if step < kept:
                    lost.append(f"{run}: {kept - step} steps (fault {n} kept a checkpoint at {kept}, "
                                f"resumed at {step})")  # fmt: skip
        return ", ".join(f"{short(run)} {step}" for run, step in sorted(started.items())) or "-"

    for k, (kind, value) in enumerate(fault_plan(faults, rng, "sweep")):
        if time.monotonic() > deadline:
            print(f"  out of time after {k} faults")
            break
        session, ended = run_session(argv, kind, value, timeout)
        if rows:
            rows[-1]["next"] = note_resumed(session.lines)
        left, start = session.group(), time.monotonic()
        while left and time.monotonic() - start < ORPHAN_WAIT_S:
            time.sleep(0.5)
            left = session.group()
        waited = time.monotonic() - start
        orphans = f"{len(left)} ({waited:.0f} s)" if left else ("0" if waited < 1 else f"0 ({waited:.0f} s)")
        if left:
            ok = False
            session.end_group()
        session.save(workdir / "logs" / f"sweep-{k + 1}.log")  # the workers' last lines included
        state = SweepState.read(out)
        states.append(state)
        for run, steps in state.newest.items():  # a run folder is named by its trial
            if run not in state.records:
                pending[run] = (k + 1, steps)
        torn, litter = torn_files(out)
        ok &= not torn
        error = None if ended in ("killed", "exit 0") else error_line(session)
        rows.append({"fault": describe_fault(kind, value), "ended": ended, "orphans": orphans,
                     "records": len(state.records), "newest": state.newest, "torn": torn, "litter": litter,
                     "next": "-", "error": error})  # fmt: skip
        if len(state.records) == SWEEP_TRIALS and "exit 0" in ended:
            print(f"  the sweep finished before fault {k + 1} came: no more faults")
            break
    final = Session(argv)
    code = final.wait(timeout)
    if code is None:
        final.end_group()
    final.save(workdir / "logs" / "sweep-final.log")
    if rows:
        rows[-1]["next"] = note_resumed(final.lines)
    for n, row in enumerate(rows, 1):
        newest = ", ".join(f"{short(r)} {v}" for r, v in sorted(row["newest"].items())) or "none"
        print(f"  {n:>2} {row['fault']:24} {row['ended']:22} {row['orphans']:>12} {row['records']:>11} "
              f"{len(row['torn']):>4} {row['litter']:>6}")  # fmt: skip
        print(f"       newest whole checkpoints: {newest}; the next session resumed: {row['next']}")
        for name in row["torn"]:
            print(f"       torn: {name}")
        if row["error"]:
            print(f"       {row['error']}")
    now = SweepState.read(out)
    for n, state in enumerate(states, 1):
        for trial, ident in state.records.items():
            if now.records.get(trial) != ident:
                lost.append(f"{trial}: its finished record of fault {n} was computed again")
    lost = list(dict.fromkeys(lost))
    torn, litter = torn_files(out)
    complete = code == 0 and len(now.records) == SWEEP_TRIALS and (out / "sweep.csv").exists()
    ok &= complete and not lost and not torn
    if code != 0:
        print(f"  the final session failed:\n{final.tail()}")
    print(
        f"  final: exit {code}, {len(now.records)} of {SWEEP_TRIALS} trials finished, {len(torn)} torn, "
        f"{litter} litter"
    )
    print(f"  lost beyond the work in progress: {'; '.join(lost) if lost else 'nothing'}; "
          f"{'OK' if ok else 'FAIL'}")  # fmt: skip
    return ok


def _soak_fast(workdir: Path, faults: int, rng: random.Random, timeout: float, deadline: float) -> bool:
    from soak_fast import soak_fast  # benchmarks/soak_fast.py (beside this file)

    return soak_fast(workdir, faults, rng, timeout, deadline)


SOAKS = {"imitation": soak_imitation, "sweep": soak_sweep, "fast": _soak_fast}


def add_fault_arguments(parser: argparse.ArgumentParser, max_seconds: float) -> None:
    """The options every soak takes: --faults, --seed, --session-timeout, --max-seconds, --keep."""
    parser.add_argument("--faults", type=int, default=4, help="faults per command, 1 to 20 (default 4)")
    parser.add_argument("--seed", type=int, default=0, help="seeds the fault times and sizes (default 0)")
    parser.add_argument("--session-timeout", type=float, default=300.0,
                        help="seconds one session may run, 10 to 3600 (default 300)")  # fmt: skip
    parser.add_argument(
        "--max-seconds", type=float, default=max_seconds,
        help=f"no new fault after this many seconds, 60 to 7200 (default {max_seconds:g})",
    )  # fmt: skip
    parser.add_argument(
        "--keep", type=Path, default=None, help="run in this new folder (kept), not a temporary one"
    )


def check_fault_arguments(parser: argparse.ArgumentParser, args: argparse.Namespace) -> float:
    """``args`` of :func:`add_fault_arguments` checked (a parser error naming the option); returns the
    monotonic deadline after which no new fault starts."""
    if not 1 <= args.faults <= 20:
        parser.error(f"argument --faults: must be 1 to 20, got {args.faults}")
    if not 10 <= args.session_timeout <= 3600:
        parser.error(f"argument --session-timeout: must be 10 to 3600 s, got {args.session_timeout}")
    if not 60 <= args.max_seconds <= 7200:
        parser.error(f"argument --max-seconds: must be 60 to 7200 s, got {args.max_seconds}")
    if args.keep is not None and args.keep.exists():
        parser.error(f"argument --keep: {args.keep} exists; give a new folder")
    return time.monotonic() + args.max_seconds


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python benchmarks/soak_faults.py", description=__doc__.splitlines()[0]
    )
    parser.add_argument("--target", choices=list(SOAKS), nargs="+", default=list(SOAKS))
    add_fault_arguments(parser, max_seconds=1200.0)
    args = parser.parse_args(argv)
    deadline = check_fault_arguments(parser, args)
    rng = random.Random(args.seed)
    ok = True
    with tempfile.TemporaryDirectory(prefix="soak-faults-") as tmp:
        workdir = args.keep or Path(tmp)
        workdir.mkdir(parents=True, exist_ok=True)
        for target in args.target:
            ok &= SOAKS[target](workdir, args.faults, rng, args.session_timeout, deadline)
    print("soak: " + ("OK" if ok else "FAIL"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
