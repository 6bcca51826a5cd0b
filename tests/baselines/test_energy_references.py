"""The energy suite's reference pipeline: the held-out draws of the random energy id, the cache
keys, the per-scenario solve (cached and resumed), the content's checks and the freeze command,
which never overwrites a suite."""

from __future__ import annotations

import dataclasses
import hashlib
import json

import gymnasium as gym
import numpy as np
import pytest

import baselines.dp_energy
import ios_uav_env  # noqa: F401  (registers the ids)
from baselines.references import check_energy_record, energy_configs, energy_content, task_key
from baselines.references.__main__ import QUICK
from baselines.references.__main__ import main as references_main
from baselines.references.draws import ENERGY_RANGES, ENERGY_SPAWN_KEY, ENTROPY, energy_rng, suite_configs
from baselines.references.solve import tasks_of
from ios_uav_env.benchmark.suite import content_hash
from ios_uav_env.envs.registration import ENERGY_RANDOM_ID


def test_the_draws_are_the_random_energy_ids_and_held_out():
    env = gym.make(ENERGY_RANDOM_ID)
    assert env.unwrapped.ranges == ENERGY_RANGES and ENERGY_RANGES.surfaces == ("ios", "ris")
    configs = energy_configs(12)
    assert configs == energy_configs(12) and configs[:3] == energy_configs(3)
    assert {c.objective for c in configs} == {"energy_efficiency"} and {c.K for c in configs} == {1}
    assert {c.surface for c in configs} == {"ios", "ris"}
    assert all(60 <= c.T <= 200 for c in configs)
    # a spawned key: no reset seed's stream, nor the other suites' draws
    assert (
        ENERGY_SPAWN_KEY != (17,)
        and energy_rng().bit_generator.state != np.random.default_rng(ENTROPY).bit_generator.state
    )
    state = energy_rng().bit_generator.state["state"]["state"]
    assert all(np.random.default_rng(s).bit_generator.state["state"]["state"] != state for s in range(2000))
    firsts = {c.ground_node for c in configs}
    for seed in range(100):  # the first scenario of a training reset is never a suite scenario
        env.reset(seed=seed)
        assert env.unwrapped.config.ground_node not in firsts
    env.close()
    assert not firsts & {c.ground_node for c in suite_configs(60)}
    with pytest.raises(ValueError, match="objective must be 'energy_efficiency'"):
        energy_configs(
            2, ranges=dataclasses.replace(ENERGY_RANGES, base=ENERGY_RANGES.base.replace(objective="rate"))
        )
    with pytest.raises(ValueError, match="n must be an integer >= 1"):
        energy_configs(0)


def test_energy_tasks_have_new_keys_and_the_old_keys_are_unchanged():
    rate = ENERGY_RANGES.base.replace(objective="rate")
    energy = ENERGY_RANGES.base
    (rate_task,), (energy_task,) = tasks_of([rate]), tasks_of([energy])
    # the rate scenario's key: the published formula, whatever the energy settings
    assert task_key(rate_task) == task_key(rate_task, energy_bound_resolution=1.0)
    blob = json.dumps([rate.to_dict(), 2.5, "sca:defaults"], sort_keys=True)
    assert task_key(rate_task) == hashlib.sha1(blob.encode()).hexdigest()[:16]
    key = task_key(energy_task)
    assert key.startswith("energy_") and key != task_key(rate_task)
    assert (
        len(
            {
                key,
                task_key(energy_task, dp_resolution=5.0),
                task_key(energy_task, energy_bound_resolution=10.0),
            }
        )
        == 3
    )


def test_the_freeze_command_solves_once_checks_and_never_overwrites(tmp_path, monkeypatch, capsys):
    cache, out = tmp_path / "cache", tmp_path / "suite"
    argv = ["energy", "--quick", "--n", "1", "--cache", str(cache), "--dir", str(out)]
    assert references_main(argv) == 0
    printed = capsys.readouterr().out
    path = out / "energy-quick-v1.json"
    data = json.loads(path.read_text())
    assert data["kind"] == "energy" and data["source"]["ranges"]["T"] == list(QUICK["T"])
    assert f"sha256 {content_hash(data)}" in printed
    (record_file,) = cache.glob("energy_*.json")
    record = json.loads(record_file.read_text())
    assert record["dp"]["resolution"] == QUICK["dp_resolution"]
    assert record["bound"]["resolution"] == QUICK["bound_resolution"]
    assert check_energy_record(record) == []
    # resumed from the cache: no planner runs again, the same file and hash
    monkeypatch.setattr(baselines.dp_energy, "solve_ee", lambda *a, **k: pytest.fail("solved again"))
    before = path.read_text()
    assert references_main(argv) == 0 and path.read_text() == before
    # a registered name or an existing file with other content is never overwritten
    with pytest.raises(SystemExit, match="registered suite"):
        references_main([*argv, "--name", "single-node-v1"])
    path.write_text(before.replace('"version": 1', '"version": 2'))
    with pytest.raises(SystemExit, match="exists with different content"):
        references_main(argv)
    # the content refuses a bound below a plan and a zero EE
    low = {**record, "bound": {**record["bound"], "upper_bound": record["sca"]["energy_efficiency"] * 0.9}}
    assert any("> bound" in note for note in check_energy_record(low))
    with pytest.raises(ValueError, match="bound .* is below"):
        energy_content([low], "x", 1)
    failed = {**record, "loiter": {**record["loiter"], "energy_efficiency": 0.0}}
    with pytest.raises(ValueError, match=r"> 0 bits/J, got loiter 0.0"):
        energy_content([failed], "x", 1)


@pytest.mark.parametrize("kind", ["energy", "mobile", "multi-node"])
def test_a_suite_name_that_would_not_load_is_refused_before_any_solve(kind, tmp_path, monkeypatch):
    """A suite frozen under a non-canonical name (or a registered one's look-alike) could not be
    loaded: the command refuses it before it draws or solves anything."""
    import baselines.references.__main__ as cli

    def no_solve(*args, **kwargs):
        raise AssertionError("solved before the name was checked")

    for name in ("_energy", "_mobile", "solve_all"):
        if hasattr(cli, name):
            monkeypatch.setattr(cli, name, no_solve)
    for bad in ("Energy-V1", " mobile-v1", "my suite"):
        with pytest.raises(SystemExit, match="--name: name must be lowercase"):
            references_main([kind, "--name", bad, "--dir", str(tmp_path)])
    assert not list(tmp_path.iterdir())
