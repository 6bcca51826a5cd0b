"""Fault injection for ``agents.loading.load_agent``: another model's VecNormalize statistics and
malformed ``config.json`` fields, each refused at load time with one error naming the file and
the field (or both shapes). Each case fails on the code before the fix (see each comment)."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")

from agents.evaluate import MODELS_DIR  # noqa: E402
from agents.loading import load_agent  # noqa: E402

SMALL = MODELS_DIR / "ppo_IOSUAV-v0"  # 11 observations
OTHER = MODELS_DIR / "ppo_IOSUAV-Random-v0"  # 20 observations, normalised


@pytest.fixture
def model_copy(tmp_path) -> Path:
    folder = tmp_path / "model"
    shutil.copytree(SMALL, folder)
    return folder


def test_another_models_statistics_are_refused_naming_the_file_and_both_shapes(model_copy):
    # before: it loaded, and the first action failed with a broadcast error naming no file
    stats = model_copy / "vecnormalize.pkl"
    shutil.copy(OTHER / "vecnormalize.pkl", stats)
    message = (f"{stats}: VecNormalize statistics of observations of shape (20,), but "
               f"{model_copy / 'model.zip'} takes observations of shape (11,)")  # fmt: skip
    with pytest.raises(ValueError, match=re.escape(message)):
        load_agent(model_copy)
    bare = model_copy / "model.zip"  # a bare zip reads the statistics beside it: the same check
    with pytest.raises(ValueError, match=re.escape(f"{stats}: VecNormalize statistics")):
        load_agent(bare, "ppo")


def test_statistics_without_observation_statistics_of_another_env_are_refused(tmp_path):
    # before: the generalist loaded with the small model's file (norm_obs off) and acted on raw observations
    folder = tmp_path / "generalist"
    shutil.copytree(OTHER, folder)
    shutil.copy(SMALL / "vecnormalize.pkl", folder / "vecnormalize.pkl")
    with pytest.raises(ValueError, match=re.escape("observations of shape (11,), but")):
        load_agent(folder)


@pytest.mark.parametrize(
    "field, value",
    [
        ("algo", 3),  # before: AttributeError ('int' has no upper)
        ("algo", "dqn"),  # before: "cannot load the DQN model: KeyError", naming the zip
        ("algo", None),  # before: "no config.json beside it names its algorithm", with one beside it
        ("algo", ["ppo"]),  # before: AttributeError ('list' has no upper)
        ("env_id", 5),  # before: gymnasium's TypeError
        ("env_id", "nowhere/Missing-v0"),  # before: gymnasium's NamespaceNotFound
        ("env_kwargs", "T:40"),  # before: a ValueError of dict() naming no file
        ("env_kwargs", [1, 2]),  # before: TypeError
        ("env_kwargs", {"bogus": 1}),  # before: the env's TypeError, naming no file
        ("env_kwargs", {"T": -5}),  # before: "T must be a finite number > 0", naming no file
        ("hyperparams", "ppo"),  # before: AttributeError ('str' has no get)
        ("hyperparams.normalize", 5),  # before: loaded, read as "normalised"
        ("hyperparams.normalize", [True]),  # before: loaded
        ("hyperparams.env_wrapper", [{"agents.wrappers.ActionRepeat": {"repeat": "4"}}]),  # before: no file
    ],
)
def test_a_malformed_config_field_is_named_with_its_file(model_copy, field, value):
    path = model_copy / "config.json"
    config = json.loads(path.read_text())
    *parents, key = field.split(".")
    target = config
    for name in parents:
        target = target[name]
    target[key] = value
    path.write_text(json.dumps(config))
    with pytest.raises(ValueError, match=f"^{re.escape(f'{path}: {field}: ')}"):
        load_agent(model_copy)


def test_the_shipped_imitation_model_without_its_statistics_is_refused(tmp_path):
    # before: its config.json records no normalisation: it loaded without them and scored 2% of SCA
    folder = tmp_path / "dagger"
    shutil.copytree(MODELS_DIR / "dagger_IOSUAV-MultiNode-Random-v0", folder)
    (folder / "vecnormalize.pkl").unlink()
    stats = folder / "vecnormalize.pkl"
    with pytest.raises(FileNotFoundError, match=re.escape(f"but the statistics {stats} are missing")):
        load_agent(folder)


def test_the_shipped_models_pass_the_checks():
    # the checks refuse nothing the shipped folders hold (older ones record no normalisation)
    for folder in sorted(p for p in MODELS_DIR.iterdir() if (p / "model.zip").exists()):
        agent = load_agent(folder)
        assert agent.name == folder.name
