"""benchmarks/vector_speed.py: whole episodes of every id against CartPoleVectorEnv.

The episode table runs in-process on 2 ids with tiny B and budgets: its JSON has the table's
columns, each row's ratio is its rate over the CartPoleVectorEnv rate measured beside it in the
same run (a CartPole slowed here shows up in the ratio), and the bar follows the id's class. Every
registered id is classified from its registration; a new id is classified too, or named as one
that cannot be; an id without a batched form is reported, not timed. The step-level tables still
run, and the results log's commands for this script parse.
"""

from __future__ import annotations

import importlib.util
import json
import sys
import time
from pathlib import Path

import gymnasium as gym
import pytest
from gymnasium.envs.classic_control.cartpole import CartPoleVectorEnv
from gymnasium.envs.registration import EnvSpec

ROOT = Path(__file__).resolve().parents[2]
FIXED_ID, RANDOM_ID = "ios_uav_env/IOSUAV-v0", "ios_uav_env/IOSUAV-Random-v0"
SLEEP = 0.002  # s per step of the slowed CartPole


def _load(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def vs():
    module = _load("benchmarks_vector_speed", ROOT / "benchmarks" / "vector_speed.py")
    yield module
    sys.modules.pop("benchmarks_vector_speed", None)


class SlowCartPole(CartPoleVectorEnv):
    """CartPoleVectorEnv with a sleep in each step: its rate is at most B / SLEEP."""

    def step(self, action):
        time.sleep(SLEEP)
        return super().step(action)


def test_the_table_has_its_columns_and_each_ratio_is_to_the_same_runs_cartpole(
    vs, monkeypatch, tmp_path, capsys
):
    monkeypatch.setattr(vs, "CartPoleVectorEnv", SlowCartPole)
    out = tmp_path / "table.json"
    argv = ["--ids", FIXED_ID, RANDOM_ID, "--num-envs", "4", "--episodes", "1", "--seconds", "20"]
    assert vs.main([*argv, "--min-seconds", "0", "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    table = json.loads(out.read_text())
    assert table["columns"] == list(vs.COLUMNS) and table["num_envs"] == 4
    rows = {row["id"]: row for row in table["rows"]}
    assert list(rows) == [FIXED_ID, RANDOM_ID]
    assert rows[FIXED_ID]["kind"] == "fixed" and rows[FIXED_ID]["bar"] == vs.FIXED_BAR
    assert rows[RANDOM_ID]["kind"] == "random" and rows[RANDOM_ID]["bar"] == vs.RANDOM_BAR
    for env_id, row in rows.items():
        assert set(row) == set(vs.COLUMNS), env_id
        assert row["form"] == "vector_entry_point" and not row["partial"], row
        assert row["episodes_ended"] >= row["episodes_target"] == 4
        assert row["steps_per_s"] == pytest.approx(row["steps"] / row["seconds"])
        assert 0 < row["reset_seconds"] < row["seconds"]
        # the CartPole figure is the one measured beside this id in this run: the slowed one
        cartpole = row["cartpole_steps"] / row["cartpole_seconds"]
        assert row["cartpole_steps_per_s"] == pytest.approx(cartpole) and 0 < cartpole < 4 / SLEEP
        assert row["x_cartpole"] == pytest.approx(row["steps_per_s"] / cartpole)
        assert row["meets_bar"] == (row["x_cartpole"] >= row["bar"])
        assert env_id in printed
    pooled = sum(r["cartpole_steps"] for r in rows.values()) / sum(
        r["cartpole_seconds"] for r in rows.values()
    )
    assert table["cartpole_steps_per_s"] == pytest.approx(pooled)
    assert "x CartPole" in printed and "meets" in printed


def test_every_registered_id_is_classified(vs):
    ids = vs.registered_ids()
    assert FIXED_ID in ids and "ios_uav_env/IOSUAV-MultiNode-Mobile-v0" in ids
    kinds = {env_id: vs.classify(env_id) for env_id in ids}
    unclassified = {env_id: c.why for env_id, c in kinds.items() if c.kind is None}
    assert not unclassified, unclassified
    assert kinds[FIXED_ID].kind == "fixed" and kinds["ios_uav_env/IOSUAV-MultiNode-v0"].kind == "fixed"
    assert kinds["ios_uav_env/IOSUAV-MultiNode-Random-v0"].why == "reset draws a scenario"
    assert "nodes move" in kinds["ios_uav_env/IOSUAV-Mobile-v0"].why


def test_a_new_id_is_classified_or_named_and_one_without_a_batched_form_is_reported(
    vs, monkeypatch, tmp_path
):
    new = {
        "ios_uav_env/TestFixed-v0": EnvSpec(
            "ios_uav_env/TestFixed-v0",
            "ios_uav_env.envs.single:IOSUAVEnv",
            kwargs={"surface": "ris", "T": 50},
        ),
        "ios_uav_env/TestDraws-v0": EnvSpec(
            "ios_uav_env/TestDraws-v0", "ios_uav_env.envs.random_env:RandomIOSUAVEnv"
        ),
        "ios_uav_env/TestOther-v0": EnvSpec(
            "ios_uav_env/TestOther-v0", "gymnasium.envs.classic_control.cartpole:CartPoleEnv"
        ),
    }
    for env_id, spec in new.items():
        monkeypatch.setitem(gym.registry, env_id, spec)
    assert set(new) <= set(vs.registered_ids())  # a new id is in the default run
    assert vs.classify("ios_uav_env/TestFixed-v0").kind == "fixed"
    assert vs.classify("ios_uav_env/TestDraws-v0").kind == "random"
    other = vs.classify("ios_uav_env/TestOther-v0")
    assert other.kind is None and other.bar is None and "ScenarioConfig" in other.why

    out = tmp_path / "table.json"
    assert vs.main(["--ids", *new, "--num-envs", "2", "--json", str(out)]) == 0
    rows = {row["id"]: row for row in json.loads(out.read_text())["rows"]}
    for row in rows.values():
        assert row["form"] is None and row["steps_per_s"] is None and "no batched form" in row["note"]
    assert rows["ios_uav_env/TestOther-v0"]["note"].startswith("cannot classify")

    argv = ["--ids", "ios_uav_env/TestFixed-v0", "--num-envs", "2", "--episodes", "1", "--seconds", "20"]
    assert vs.main([*argv, "--min-seconds", "0", "--sync", "--json", str(out)]) == 0
    (row,) = json.loads(out.read_text())["rows"]
    assert row["form"] == "sync" and row["steps_per_s"] > 0 and row["episodes_ended"] >= 2


def test_the_step_tables_still_run_and_the_logs_commands_parse(vs, capsys):
    argv = ["--steps", "--sizes", "8", "--env-steps", "80", "--repeats", "1", "--multinode-id", ""]
    assert vs.main(argv) == 0
    assert "CartPoleVectorEnv" in capsys.readouterr().out
    log = _load("benchmarks_log_for_vector_speed", ROOT / "benchmarks" / "log.py")
    try:
        commands = [m.args for m in log.REGISTRY.values() if m.args[0] == "benchmarks/vector_speed.py"]
    finally:
        sys.modules.pop("benchmarks_log_for_vector_speed", None)
    assert ("benchmarks/vector_speed.py",) in commands and len(commands) == 2
    for args in commands:
        vs.build_parser().parse_args(list(args[1:]))
