"""docs/leaderboard.md: every row of a suite's table reproduces from the command in its row.

Each command (``python -m ios_uav_env.benchmark ...``) runs in this process. The scores it prints
(single-node: mean, 10th percentile and minimum % of DP, mean % of SCA; multi-node: mean, 10th
percentile and minimum % of SCA, mean % of the bound, the best schedule's mean % of SCA) must equal
the row's to two decimals, and its feasible count must equal the row's. Plan times depend on the
machine and are not compared.

A policy row of ``star-v1`` whose rollout the suite stores (:data:`STAR_STORED`; an episode costs
the env's per-slot optimum, seconds under ES-NOMA) is reproduced from that stored rollout instead:
the command run on the first scenarios must give the stored values there, and ``show --reference``
of them must print the row's numbers. Any other row of it runs in full.
Rows that load an SB3 agent need the ``rl`` extra (skipped without it, a failure under CI).
"""

from __future__ import annotations

import importlib.util
import os
import re
import shlex
from pathlib import Path

import pytest

from ios_uav_env.benchmark.cli import main

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "leaderboard.md"
PREFIX = ["python", "-m", "ios_uav_env.benchmark"]
SUMMARY = re.compile(
    r"% of DP mean (?P<mean>-?[\d.]+) \| p10 (?P<p10>-?[\d.]+) \| min (?P<min>-?[\d.]+); "
    r"% of SCA mean (?P<sca>-?[\d.]+) \| p10 -?[\d.]+ \| min -?[\d.]+; feasible (?P<feasible>\d+/\d+)"
)
COLUMNS = {"mean % of DP": "mean", "p10": "p10", "min": "min", "mean % of SCA": "sca", "feasible": "feasible"}
MULTI_SUMMARY = re.compile(
    r"% of SCA mean (?P<mean>-?[\d.]+) \| p10 (?P<p10>-?[\d.]+) \| min (?P<min>-?[\d.]+); "
    r"% of bound mean (?P<bound>-?[\d.]+) \| p10 -?[\d.]+ \| min -?[\d.]+; "
    r"best schedule % of SCA mean (?P<best>-?[\d.]+); feasible (?P<feasible>\d+/\d+)"
)
MULTI_COLUMNS = {"mean % of SCA": "mean", "p10": "p10", "min": "min", "mean % of bound": "bound",
                 "best schedule % of SCA": "best", "feasible": "feasible"}  # fmt: skip
ENERGY_SUMMARY = re.compile(
    r"% of DP mean (?P<mean>-?[\d.]+) \| p10 (?P<p10>-?[\d.]+) \| min (?P<min>-?[\d.]+); "
    r"% of bound mean (?P<bound>-?[\d.]+) \| p10 -?[\d.]+ \| min -?[\d.]+; feasible (?P<feasible>\d+/\d+)"
)
ENERGY_COLUMNS = {"mean % of DP": "mean", "p10": "p10", "min": "min", "mean % of bound": "bound",
                  "feasible": "feasible"}  # fmt: skip
MOBILE_SUMMARY = re.compile(
    r"% of bound mean (?P<mean>-?[\d.]+) \| p10 (?P<p10>-?[\d.]+) \| min (?P<min>-?[\d.]+); "
    r"% of MPC\(k=1\) mean (?P<mpc>-?[\d.]+) \| p10 -?[\d.]+ \| min -?[\d.]+; feasible (?P<feasible>\d+/\d+)"
)
MOBILE_COLUMNS = {"mean % of bound": "mean", "p10": "p10", "min": "min", "mean % of MPC(k=1)": "mpc",
                  "feasible": "feasible"}  # fmt: skip
FLEET_SUMMARY = re.compile(
    r"% of planner mean (?P<mean>-?[\d.]+) \| p10 (?P<p10>-?[\d.]+) \| min (?P<min>-?[\d.]+); "
    r"% of bound mean (?P<bound>-?[\d.]+) \| p10 -?[\d.]+ \| min -?[\d.]+; feasible (?P<feasible>\d+/\d+)"
)
FLEET_COLUMNS = {"mean % of planner": "mean", "p10": "p10", "min": "min", "mean % of bound": "bound",
                 "feasible": "feasible"}  # fmt: skip
STAR_SUMMARY = re.compile(
    r"% of optimum mean (?P<mean>-?[\d.]+) \| p10 (?P<p10>-?[\d.]+) \| min (?P<min>-?[\d.]+); "
    r"% of bound mean (?P<bound>-?[\d.]+) \| p10 -?[\d.]+ \| min -?[\d.]+; feasible (?P<feasible>\d+/\d+)"
)
STAR_COLUMNS = {"mean % of optimum": "mean", "p10": "p10", "min": "min", "mean % of bound": "bound",
                "feasible": "feasible"}  # fmt: skip
MISO_SUMMARY = re.compile(
    r"% of optimum mean (?P<mean>-?[\d.]+) \| p10 (?P<p10>-?[\d.]+) \| min (?P<min>-?[\d.]+); % of bound "
    r"mean (?P<bound>-?[\d.]+) \| p10 (?P<bp10>-?[\d.]+) \| min (?P<bmin>-?[\d.]+); "
    r"feasible (?P<feasible>\d+/\d+)"
)
MISO_COLUMNS = {"mean % of optimum": "mean", "p10": "p10", "min": "min", "mean % of bound": "bound",
                "bound p10": "bp10", "bound min": "bmin", "feasible": "feasible"}  # fmt: skip
#: The policies of star-v1's rows whose rollouts the suite stores, by the reference that holds them.
STAR_STORED = {"ios_uav_env.benchmark.star_policies:ChannelPhases": "phases"}
#: The first scenarios a star-v1 policy row is run on (M = 16, continuous: TDMA, ES-NOMA, MS-NOMA).
STAR_FIRST = 3


def task_changes_of(argv: list[str]) -> dict:
    """The env arguments of a row's command that change its suite's task
    (``ios_uav_env.benchmark.overrides``): such a row runs only with ``--allow-task-change``."""
    from ios_uav_env.benchmark import load_suite
    from ios_uav_env.benchmark.cli import parse_env_kwargs
    from ios_uav_env.benchmark.overrides import task_changes

    suite = argv[argv.index("--suite") + 1] if "--suite" in argv else "single-node-v1"
    if "--env-kwargs" not in argv:
        return {}
    start = argv.index("--env-kwargs") + 1
    end = next((i for i in range(start, len(argv)) if argv[i].startswith("--")), len(argv))
    return task_changes(load_suite(suite), parse_env_kwargs(argv[start:end]))


def _rows(suite: str = "single-node-v1") -> list[dict[str, str]]:
    """The rows of the table in the section ``## <suite>``, by header name."""
    section = PAGE.read_text(encoding="utf-8").split(f"\n## {suite}\n", 1)[1].split("\n## ", 1)[0]
    lines = [line for line in section.splitlines() if line.startswith("|")]
    header = [cell.strip() for cell in lines[0].strip("|").split("|")]
    rows = []
    for line in lines[2:]:
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        rows.append(dict(zip(header, cells, strict=True)))
    return rows


ROWS = _rows()
MULTI_ROWS = _rows("multi-node-v1")
ENERGY_ROWS = _rows("energy-v1")
MOBILE_ROWS = _rows("mobile-v1")
FLEET_ROWS = _rows("multi-uav-v1")
STAR_ROWS = _rows("star-v1")
MISO_ROWS = _rows("miso-v1")
STAR_POLICY_ROWS = [row for row in STAR_ROWS if " evaluate " in row["command"]
                    and any(f"--policy {policy}" in row["command"] for policy in STAR_STORED)]  # fmt: skip
#: Every row to run: (summary pattern, columns, row) of every suite's table.
ALL_ROWS = (
    [(SUMMARY, COLUMNS, row) for row in ROWS]
    + [(MULTI_SUMMARY, MULTI_COLUMNS, row) for row in MULTI_ROWS]
    + [(ENERGY_SUMMARY, ENERGY_COLUMNS, row) for row in ENERGY_ROWS]
    + [(MOBILE_SUMMARY, MOBILE_COLUMNS, row) for row in MOBILE_ROWS]
    + [(FLEET_SUMMARY, FLEET_COLUMNS, row) for row in FLEET_ROWS]
    + [(STAR_SUMMARY, STAR_COLUMNS, row) for row in STAR_ROWS if row not in STAR_POLICY_ROWS]
    + [(MISO_SUMMARY, MISO_COLUMNS, row) for row in MISO_ROWS]
)
KINDS = {
    id(COLUMNS): "single",
    id(MULTI_COLUMNS): "multi",
    id(ENERGY_COLUMNS): "energy",
    id(MOBILE_COLUMNS): "mobile",
    id(FLEET_COLUMNS): "fleet",
    id(STAR_COLUMNS): "star",
    id(MISO_COLUMNS): "miso",
}


def test_the_table_has_the_shipped_policies_and_the_references():
    policies = " ".join(row["policy"] for row in ROWS)
    for name in ("SCA", "DP optimum", "rate peak", "fly to G", "ppo_IOSUAV-Random-v0", "sac_IOSUAV-v0",
                 "ppo_IOSUAV-v0`", "ppo_IOSUAV-v0_noguard"):  # fmt: skip
        assert name in policies, name
    means = [float(row["mean % of DP"]) for row in ROWS]
    assert means == sorted(means, reverse=True), "rows must be in order of mean % of DP"


def test_the_multi_node_table_has_the_references_and_the_baselines():
    policies = " ".join(row["policy"] for row in MULTI_ROWS)
    for name in ("upper bound", "SCA", "tour heuristic", "fly straight"):
        assert name in policies, name
    means = [float(row["mean % of SCA"]) for row in MULTI_ROWS]
    assert means == sorted(means, reverse=True), "rows must be in order of mean % of SCA"
    assert all("--suite multi-node-v1" in row["command"] for row in MULTI_ROWS)


def test_the_energy_and_mobile_tables_are_sorted_and_on_their_suites():
    for rows, column, suite in (
        (ENERGY_ROWS, "mean % of DP", "energy-v1"),
        (MOBILE_ROWS, "mean % of bound", "mobile-v1"),
    ):
        means = [float(row[column]) for row in rows]
        assert means == sorted(means, reverse=True), f"{suite}: rows must be in order of {column}"
        assert rows and all(f"--suite {suite}" in row["command"] for row in rows)
    assert any("evaluate" in row["command"] for row in MOBILE_ROWS)  # a policy, not only references


def test_the_several_uav_table_has_the_references_and_a_policy_and_is_sorted():
    policies = " ".join(row["policy"] for row in FLEET_ROWS)
    for name in ("upper bound", "centralised planner", "straight", "least-served"):
        assert name in policies, name
    means = [float(row["mean % of planner"]) for row in FLEET_ROWS]
    assert means == sorted(means, reverse=True), "rows must be in order of mean % of the planner"
    assert all("--suite multi-uav-v1" in row["command"] for row in FLEET_ROWS)
    assert any("evaluate" in row["command"] for row in FLEET_ROWS)


def test_the_star_table_has_the_references_and_a_policy_and_is_sorted():
    policies = " ".join(row["policy"] for row in STAR_ROWS)
    names = ("per-slot optimum", "certified bound", "rounded", "aligned", "ChannelPhases", "random")
    for name in (*names, "StarLearner"):  # the references, the heuristic and the learner
        assert name in policies, name
    means = [float(row["mean % of optimum"]) for row in STAR_ROWS]
    assert means == sorted(means, reverse=True), "rows must be in order of mean % of the optimum"
    assert all("--suite star-v1" in row["command"] for row in STAR_ROWS) and STAR_POLICY_ROWS


def test_the_miso_table_has_the_references_and_a_policy_and_is_sorted():
    policies = " ".join(row["policy"] for row in MISO_ROWS)
    names = ("per-slot AO optimum", "certified bound", "MRT", "ZF", "random phases", "DirectMRT")
    for name in (*names, "MisoLearner"):  # the references, the heuristic and the learner
        assert name in policies, name
    means = [float(row["mean % of optimum"]) for row in MISO_ROWS]
    assert means == sorted(means, reverse=True), "rows must be in order of mean % of the optimum"
    assert all("--suite miso-v1" in row["command"] for row in MISO_ROWS)
    assert any(" evaluate " in row["command"] for row in MISO_ROWS)


@pytest.mark.parametrize("row", STAR_POLICY_ROWS, ids=[row["#"] for row in STAR_POLICY_ROWS])
def test_a_star_policy_row_reproduces_from_its_stored_rollout(row, capsys, tmp_path):
    import json

    from ios_uav_env.benchmark import load_suite
    from tests.tolerances import RATE_REL

    words = shlex.split(row["command"].strip("`"))
    assert words[:3] == PREFIX and words[3] == "evaluate", row["command"]
    argv = words[3:]
    reference = STAR_STORED[argv[argv.index("--policy") + 1]]
    assert main([*argv, "--n", str(STAR_FIRST), "--out", str(tmp_path)]) == 0
    capsys.readouterr()
    rates = [r["rate"] for r in json.loads((tmp_path / "results.json").read_text())["scenarios"]]
    stored = [s.value(reference) for s in load_suite("star-v1").subset(STAR_FIRST)]
    assert rates == pytest.approx(stored, rel=RATE_REL), f"{row['command']}: not the stored {reference} rows"
    assert main(["show", "--suite", "star-v1", "--reference", reference]) == 0
    match = STAR_SUMMARY.search(capsys.readouterr().out)
    table = {key: row[column] for column, key in STAR_COLUMNS.items()}
    assert match and match.groupdict() == table, f"{row['command']}: the table says {table}"


@pytest.mark.parametrize(
    "pattern, columns, row", ALL_ROWS, ids=[f"{KINDS[id(c)]}-{r['#']}" for _, c, r in ALL_ROWS]
)
def test_a_row_reproduces_from_its_command(pattern, columns, row, capsys):
    command = row["command"].strip("`")
    words = shlex.split(command)
    assert words[:3] == PREFIX, command
    if "agents.loading" in command and importlib.util.find_spec("stable_baselines3") is None:
        message = "the row loads an SB3 agent: pip install -e '.[rl]'"
        pytest.fail(message) if os.environ.get("CI") else pytest.skip(message)
    argv = words[3:]
    changes = task_changes_of(argv)
    if changes:  # another task than the suite's: the row says so; refused without the opt-in, then named
        assert "--allow-task-change" in argv, (
            f"{command}: a row of another task must pass --allow-task-change"
        )
        with pytest.raises(SystemExit):
            main([w for w in argv if w != "--allow-task-change"])
        refusal = capsys.readouterr().err
        assert "--allow-task-change" in refusal and all(f"{k}=" in refusal for k in changes), refusal
    assert main(argv) == 0
    out = capsys.readouterr().out
    match = pattern.search(out)
    assert match, command
    assert ("[not " in out) == bool(changes), out
    printed = match.groupdict()
    table = {key: row[column] for column, key in columns.items()}
    assert printed == table, f"{command}: the table says {table}, the command prints {printed}"


def test_the_energy_generalist_beats_the_loiter_heuristic():
    """The baseline every energy learner must beat: the shipped generalist's row (whose numbers
    test_a_row_reproduces_from_its_command reruns) is above the loiter heuristic's on the mean,
    the 10th percentile and the worst scenario."""
    rows = {row["policy"]: row for row in ENERGY_ROWS}
    generalist = next(row for name, row in rows.items() if "ppo_IOSUAV-Energy-Random-v0" in name)
    loiter = rows["loiter at the minimum-power speed (heuristic)"]
    assert "--reference loiter" in loiter["command"]
    for column in ("mean % of DP", "p10", "min"):
        assert float(generalist[column]) > float(loiter[column]), column
