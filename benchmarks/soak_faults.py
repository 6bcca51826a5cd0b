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
import random
import re
import sys
import tempfile
import time
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass, field
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
    identity,
    run_session,
    spans,
    torn_files,
)

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
#: How long the workers of a killed sweep may take to checkpoint and exit (agents.sweep's grace, 30 s,
#: and a margin).
ORPHAN_WAIT_S = 45.0
STARTED = re.compile(r"training (\S+): step (\d+) of (\d+)")
ROUND = re.compile(r"^round (\d+): ")


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
