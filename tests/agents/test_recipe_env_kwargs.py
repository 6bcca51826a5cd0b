"""A recipe carries its env arguments (the zoo's ``env_kwargs`` key): ``train.py`` alone trains
the documented recipe, ``--env-kwargs`` overrides it key by key, the run records the resolved
arguments. Tiny budgets (the fast trainer's test recipe)."""

from __future__ import annotations

import json
import re

import pytest
import yaml

import train
from agents.hyperparams import HYPERPARAMS_DIR, load_hyperparams
from ios_uav_env import ENERGY_ID, ENERGY_RANDOM_ID
from tests.agents.test_fast import ENV, MULTI, entry

pytestmark = pytest.mark.usefixtures("one_torch_thread")

#: What the documented commands passed with --env-kwargs before the recipes carried them.
DOCUMENTED = {
    ("fast_ppo.yml", MULTI): {"softmin_beta": 20, "peak_hint": True},
    ("fast_ppo.yml", ENERGY_ID): {"energy_reference": 17155.06},
    ("fast_ppo.yml", ENERGY_RANDOM_ID): {"energy_reference": "loiter", "peak_hint": True},
    ("ppo_fast.yml", MULTI): {"softmin_beta": 20, "peak_hint": True},
    ("ppo.yml", "ios_uav_env/IOSUAV-Random-v0"): {
        "peak_hint": True, "focus": {"ground_x": [-150, 150], "ground_y": [-60, 60]}, "focus_prob": 0.5,
    },
}  # fmt: skip


def test_the_documented_commands_alone_train_the_documented_recipes():
    # before: `train.py --algo ppo --trainer fast --env ios_uav_env/IOSUAV-MultiNode-v0` trained
    # on the env's defaults (no soft-min reward, no peak hint): the recipe needed --env-kwargs
    _, settings = train.parse_args(["--algo", "ppo", "--trainer", "fast", "--env", MULTI])
    assert settings.env_kwargs == {"softmin_beta": 20, "peak_hint": True}
    _, settings = train.parse_args(["--algo", "ppo", "--trainer", "fast", "--env", MULTI, "--env-kwargs",
                                    "peak_hint:False", "T:60"])  # fmt: skip
    assert settings.env_kwargs == {"softmin_beta": 20, "peak_hint": False, "T": 60}  # key by key
    for (name, env_id), kwargs in DOCUMENTED.items():
        assert load_hyperparams("ppo", env_id, HYPERPARAMS_DIR / name).env_kwargs == kwargs, (name, env_id)
    # the ids that alias another's entry do not take its env arguments
    for env_id in (ENERGY_RANDOM_ID, "ios_uav_env/IOSUAV-Mobile-v0"):
        assert load_hyperparams("ppo", env_id).env_kwargs == {}


def test_every_shipped_recipes_env_kwargs_make_its_env():
    import importlib.util

    from agents.fast.fleet import FLEET_KEY, FleetSpec
    from agents.training import check_env_kwargs

    fleets = 0
    for path in sorted(HYPERPARAMS_DIR.glob("*.yml")):
        algo = "sac" if path.stem == "sac" else "ppo"
        for env_id in yaml.safe_load(path.read_text()):
            kwargs = load_hyperparams(algo, env_id, path).env_kwargs
            if env_id == FLEET_KEY:  # the fleets' recipe: the arguments of ios_uav_env.parallel_env
                fleets += 1
                if importlib.util.find_spec("pettingzoo") is not None:
                    FleetSpec(kwargs).parallel_env().reset(seed=0)
                continue
            check_env_kwargs(env_id, kwargs)
    assert fleets == 1  # agents/hyperparams/fast_ippo_fleet.yml


def test_a_run_records_the_resolved_env_kwargs_and_resumes_with_them(tmp_path, monkeypatch):
    # before: the zoo's env_kwargs key was refused ("neither a zoo key nor an argument of PPO")
    from agents.loading import load_agent

    hp = tmp_path / "fast.yml"
    hp.write_text(yaml.safe_dump({ENV: entry(env_kwargs={"T": 40, "arrival_guard": True})}))
    run = tmp_path / "run"
    argv = ["--algo", "ppo", "--trainer", "fast", "--hyperparams", str(hp), "--out", str(run),
            "--timesteps", "256", "--env-kwargs", "arrival_guard:False", "--eval-freq", "0",
            "--no-progress"]  # fmt: skip
    assert train.main(argv) == 0
    config = json.loads((run / "config.json").read_text())
    resolved = {"T": 40, "arrival_guard": False}
    assert config["env_kwargs"] == resolved and config["args"]["env_kwargs"] == resolved
    assert config["hyperparams"]["env_kwargs"] == {"T": 40, "arrival_guard": True}  # the recipe as written
    assert load_agent(run).env_kwargs == resolved
    hp.write_text(yaml.safe_dump({ENV: entry(env_kwargs={"T": 60, "channel": "rician"})}))  # changed since
    import agents.fast.run as fast_run

    made, make = [], fast_run.FastPPO

    def recorded(*args, **kwargs):
        made.append(kwargs["env_kwargs"])
        return make(*args, **kwargs)

    monkeypatch.setattr(fast_run, "FastPPO", recorded)
    assert train.main(["--resume", str(run), "--timesteps", "512", "--no-progress"]) == 0
    assert made == [resolved]  # the run's own, not the changed recipe's


@pytest.mark.parametrize(
    ("env_kwargs", "argument", "message"),
    [
        ([1, 2], "--hyperparams", "env_kwargs must map env argument names to values"),
        ({"T": -5}, "--env-kwargs", r"the recipe's env_kwargs \{'T': -5\}"),
    ],
)
def test_bad_recipe_env_kwargs_name_the_key_before_the_run_folder_exists(tmp_path, capsys, env_kwargs,
                                                                          argument, message):  # fmt: skip
    hp = tmp_path / "fast.yml"
    hp.write_text(yaml.safe_dump({ENV: entry(env_kwargs=env_kwargs)}))
    with pytest.raises(SystemExit) as exc:
        train.parse_args(["--algo", "ppo", "--trainer", "fast", "--hyperparams", str(hp),
                          "--out", str(tmp_path / "run")])  # fmt: skip
    err = capsys.readouterr().err
    assert exc.value.code == 2 and f"argument {argument}" in err
    assert re.search(message, err) and not (tmp_path / "run").exists()
