"""Regenerate the dated results log, ``results/log.md``, from named measurement commands.

    python benchmarks/log.py --list                 # the names, their commands, what they measure
    python benchmarks/log.py step_speed planners    # run those, replace their sections in the log

Each name of :data:`REGISTRY` is one command (a script of ``benchmarks/`` with its arguments), run
from the repository root with this Python. Its stdout is echoed and captured (stderr passes
through); if it exits 0, the log's section ``## <name>`` under "Latest runs" is replaced by (or,
the first time, appended as) a dated entry: the UTC date, the exact command, the machine and the
output in a code block. A failed command leaves the log as it was and makes this one exit 1.
Everything after the ``# History`` heading is never touched. The file is rewritten atomically
(``ios_uav_env.io.atomic_write_text``), once per command, so an interrupted run loses nothing.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import re
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ios_uav_env.io import atomic_write_text  # noqa: E402  (after the root is on the path)

LOG = ROOT / "results" / "log.md"
LATEST = "# Latest runs"
HISTORY = "# History"


class Measurement(NamedTuple):
    """A registered command: the arguments after ``python`` and what it measures."""

    args: tuple[str, ...]
    what: str

    @property
    def command(self) -> str:
        """The command as typed from the repository root."""
        return " ".join(["python", *self.args])


#: The measurements by name: the script of ``benchmarks/`` (and its arguments), what it measures.
REGISTRY: dict[str, Measurement] = {
    name: Measurement((f"benchmarks/{script}", *extra), what)
    for name, script, extra, what in [
        ("step_speed", "step_speed.py", (), "raw env.step of IOSUAV-v0 against CartPole-v1"),
        ("random_env", "random_env.py", ("--peak-hint", "--energy"), "resets and steps of the random ids"),
        ("vector_speed", "vector_speed.py", ("--steps",), "batched steps vs CartPole; the multi-node one"),
        ("vector_episodes", "vector_speed.py", (), "whole episodes of every id at B = 1024 vs CartPoleVec"),
        ("planners", "planners.py", (), "DP and the paper's schemes: rate, % of DP, seconds"),
        ("sca_bench", "sca_bench.py", (), "SCA against the DP optimum, tiles, solvers, DPP"),
        ("ppo_speed", "ppo_speed.py", (), "PPO (ppo_fast.yml), batched env: time to 99.5% of DP"),
        ("multinode", "multinode.py", (), "several nodes: tour, SCA, the DP's plan and bound"),
        ("star_slot", "star_slot.py", (), "STAR surfaces, one slot: each protocol and access, the gaps"),
        (
            "fleet",
            "fleet.py",
            ("--access", "orthogonal", "shared"),
            "several UAVs: the centralised plan's max-min against its bound",
        ),
        (
            "train_speed",
            "train_speed.py",
            ("throughput", "--n-envs", "1024"),
            "fast trainer (B = 1024) vs SB3: steps/s and the time split",
        ),
        (
            "fast_race",
            "train_speed.py",
            ("race", "--env", "ios_uav_env/IOSUAV-v0", "--seeds", "0", "1", "2", "--time-cap", "60"),
            "fast trainer, IOSUAV-v0: wall time to 99.5% of DP",
        ),
        (
            "fast_race_multi",
            "train_speed.py",
            ("race", "--seeds", "0", "1", "2"),
            "fast trainer, IOSUAV-MultiNode-v0: wall time to 97% of SCA",
        ),
        (
            "fast_race_energy",
            "train_speed.py",
            ("race", "--env", "ios_uav_env/IOSUAV-Energy-v0", "--seeds", "0", "1", "2"),
            "fast trainer, IOSUAV-Energy-v0: wall time to 99% of DP-EE",
        ),
        ("soak_train", "soak_train.py", (), "interrupted and resumed training: steps lost"),
        (
            "soak_faults",
            "soak_faults.py",
            (),
            "imitation, sweep and fast trainer, SIGKILL and full disk: work lost",
        ),
        ("replay_tolerance", "replay_tolerance.py", (), "shipped models' replays under float32 noise"),
        ("energy", "energy.py", ("--budgets", "0.8", "0.9"), "energy planners: EE, % of the bound"),
        ("miso_slot", "miso_slot.py", (), "multi-antenna slot: AO vs bound, MRT/ZF, TDMA; a power sweep"),
        (
            "miso_sweep",
            "miso_sweep.py",
            (),
            "fixed-UAV MISO, N_t = 4, K = 2 and 4: sum and max-min rate vs P, each scheme's gap to the bound",
        ),
        (
            "mobile",
            "mobile.py",
            ("--quick",),
            "moving nodes (M = 60): bound, clairvoyant tour, MPC, plan once",
        ),
        (
            "mobile_single",
            "mobile.py",
            ("--single", "--scenarios", "3", "--T", "100"),
            "one moving node (the mobile id): MPC, plan once, tracking on reports and exact",
        ),
    ]
}

TEMPLATE = f"""# Results log

Measurements, timings and tuning stories, dated; the code and the docs state the contracts.
Regenerate a section with `python benchmarks/log.py NAME` (`--list` for the names).

{LATEST}

{HISTORY}
"""


def machine() -> str:
    """The processor, the CPU count, the OS and the Python of this machine."""
    cpu = platform.processor() or platform.machine() or "unknown processor"
    system = f"{platform.system()} {platform.release()}"
    return f"{cpu}, {os.cpu_count()} CPUs, {system}, Python {platform.python_version()}"


def entry(name: str, command: str, output: str, date: datetime.date) -> str:
    """The section of one run: heading, date, command, machine and the output in a code block."""
    fence = "`" * max([3, *(len(run) + 1 for run in re.findall(r"`{3,}", output))])
    head = f"## {name}\n\n- date: {date.isoformat()} (UTC)\n- command: `{command}`\n- machine: {machine()}"
    return f"{head}\n\n{fence}text\n{output.rstrip()}\n{fence}\n"


def _headings(lines: list[str], start: int) -> list[int]:
    """Indices of the ``## `` lines from ``start`` on, outside code fences."""
    found: list[int] = []
    fence = ""
    for i in range(start, len(lines)):
        line = lines[i].rstrip("\n")
        ticks = re.match(r"`{3,}", line)
        if fence:
            if ticks and not line.strip("`") and len(line) >= len(fence):
                fence = ""
        elif ticks:
            fence = ticks.group(0)
        elif line.startswith("## "):
            found.append(i)
    return found


def replace_section(text: str, name: str, section: str) -> str:
    """``text`` with the ``## name`` section of its latest runs replaced by ``section`` (appended
    after the latest runs when there is none); the history is kept as it is."""
    cut = text.find(f"\n{HISTORY}\n")
    head, tail = (text, "") if cut < 0 else (text[: cut + 1], text[cut + 1 :])
    lines = head.splitlines(keepends=True)
    if f"{LATEST}\n" not in lines:
        lines += ["\n"] if lines and not lines[-1].endswith("\n") else []
        lines += ["\n", f"{LATEST}\n"]
    starts = _headings(lines, lines.index(f"{LATEST}\n"))
    block = [section.rstrip("\n") + "\n", "\n"]
    for k, i in enumerate(starts):
        if lines[i].rstrip("\n") == f"## {name}":
            end = starts[k + 1] if k + 1 < len(starts) else len(lines)
            lines[i:end] = block
            break
    else:
        while lines and not lines[-1].strip():
            lines.pop()
        lines += ["\n", *block]
    return "".join(lines) + tail


def run(measurement: Measurement) -> tuple[int, str]:
    """Run the command from the repository root; its stdout echoed line by line and returned."""
    proc = subprocess.Popen(
        [sys.executable, *measurement.args], cwd=ROOT, stdout=subprocess.PIPE, text=True, bufsize=1
    )
    captured: list[str] = []
    for line in proc.stdout or ():
        sys.stdout.write(line)
        captured.append(line)
    return proc.wait(), "".join(captured)


def record(name: str, log: Path = LOG, date: datetime.date | None = None) -> bool:
    """Run ``name`` and, if it succeeds, write its dated section into ``log``; whether it succeeded."""
    measurement = REGISTRY[name]
    code, output = run(measurement)
    if code != 0:
        print(f"{name}: `{measurement.command}` exited with {code}; {log} not changed", file=sys.stderr)
        return False
    day = date or datetime.datetime.now(datetime.timezone.utc).date()
    text = log.read_text(encoding="utf-8") if log.exists() else TEMPLATE
    atomic_write_text(log, replace_section(text, name, entry(name, measurement.command, output, day)))
    return True


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", metavar="NAME", help="measurements to run (see --list)")
    parser.add_argument("--list", action="store_true", help="list the registered names and exit")
    parser.add_argument("--log", type=Path, default=LOG, help="the log file (default results/log.md)")
    args = parser.parse_args(argv)
    if args.list:
        for name, measurement in REGISTRY.items():
            print(f"{name:13s} {measurement.command:40s} {measurement.what}")
        return 0
    unknown = [name for name in args.names if name not in REGISTRY]
    if unknown:
        parser.error(f"unknown name(s) {', '.join(unknown)}; allowed: {', '.join(REGISTRY)}")
    if not args.names:
        parser.error(f"name at least one measurement (allowed: {', '.join(REGISTRY)}) or use --list")
    failed = [name for name in args.names if not record(name, args.log)]
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
