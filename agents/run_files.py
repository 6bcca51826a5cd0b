"""What a trained run's folder holds, read and checked: the algorithms by name, the checkpoints'
files, ``config.json`` and the VecNormalize statistics.

A run or model folder holds ``model.zip``, ``config.json`` (its ``algo``, ``env_id`` and
``env_kwargs``), ``vecnormalize.pkl`` when training normalised observations or rewards, and
``summary.json``; a run's ``checkpoints/`` hold ``rl_model_<steps>_steps.zip`` with the
matching ``rl_model_vecnormalize_<steps>_steps.pkl`` (:func:`checkpoints`,
:func:`checkpoint_file`). :func:`check_config` and :func:`check_statistics` refuse a malformed
``config.json`` or another model's statistics, naming the file; :func:`zip_algorithm` reads the
algorithm of a bare ``.zip``; :func:`observations_normalised` says whether a run normalised its
observations. ``agents.loading.load_agent`` is the one loader that reads them; every name here
is importable from :mod:`agents.loading` too.
"""

from __future__ import annotations

import json
import pickle
import re
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

import ios_uav_env  # noqa: F401  (registers the ids the agents' env_id names)

DEFAULT_ENV_ID = "ios_uav_env/IOSUAV-v0"
CHECKPOINT_PREFIX = "rl_model"


class _Algorithms(Mapping[str, type]):
    """``{"ppo": PPO, "sac": SAC}``, importing Stable-Baselines3 only when a class is looked up."""

    _NAMES = {"ppo": "PPO", "sac": "SAC"}

    def __getitem__(self, algo: str) -> type:
        if algo not in self._NAMES:
            raise KeyError(algo)
        import stable_baselines3

        return getattr(stable_baselines3, self._NAMES[algo])

    def __contains__(self, algo: object) -> bool:
        return algo in self._NAMES

    def __iter__(self) -> Iterator[str]:
        return iter(self._NAMES)

    def __len__(self) -> int:
        return len(self._NAMES)


#: The algorithms by name: ``ALGOS["ppo"]`` is ``stable_baselines3.PPO``.
ALGOS: Mapping[str, type] = _Algorithms()


def checkpoints(run_dir: str | Path) -> list[tuple[int, Path]]:
    """``(steps, zip)`` of every checkpoint in ``run_dir/checkpoints``, by steps (may be empty)."""
    found = []
    for path in (Path(run_dir) / "checkpoints").glob(f"{CHECKPOINT_PREFIX}_*_steps.zip"):
        match = re.fullmatch(rf"{CHECKPOINT_PREFIX}_(\d+)_steps\.zip", path.name)
        if match:
            found.append((int(match.group(1)), path))
    return sorted(found)


def checkpoint_file(run_dir: str | Path, steps: int, kind: str = "") -> Path:
    """The checkpoint file of ``steps``: the model (``kind=""``, a .zip) or its ``"vecnormalize"``
    / ``"replay_buffer"`` pickle."""
    folder = Path(run_dir) / "checkpoints"
    if not kind:
        return folder / f"{CHECKPOINT_PREFIX}_{steps}_steps.zip"
    return folder / f"{CHECKPOINT_PREFIX}_{kind}_{steps}_steps.pkl"


def _read_vecnormalize(path: Path) -> Any:
    """The VecNormalize statistics of ``path`` for inference (frozen, rewards not normalised);
    ``ValueError`` naming the file if it cannot be read."""
    try:
        with path.open("rb") as fh:
            vecnormalize = pickle.load(fh)  # what VecNormalize.load does, without an env to attach
    except Exception as exc:  # truncated or foreign pickles fail in many ways
        raise ValueError(
            f"{path}: cannot read the VecNormalize statistics: {type(exc).__name__}: {exc}"
        ) from None
    if not hasattr(vecnormalize, "normalize_obs"):
        raise ValueError(f"{path} holds a {type(vecnormalize).__name__}, not VecNormalize statistics")
    vecnormalize.training, vecnormalize.norm_reward = False, False
    return vecnormalize


def read_json(path: Path) -> dict[str, Any]:
    """The JSON object in ``path`` (``ValueError`` naming the file if unreadable or not an object)."""
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path} cannot be read: {exc}") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path} must hold a JSON object, got a {type(data).__name__}")
    return data


#: This package's own SB3 policy classes (SB3 records a policy under its class's module) and the
#: algorithm that trains them.
PACKAGE_POLICIES = {"agents.node_set": "ppo"}


def zip_algorithm(zip_path: Path) -> str | None:
    """The algorithm an SB3 ``.zip`` was saved by (``"ppo"``, ``"sac"``; None if another), from
    its policy class (SB3's, or one of :data:`PACKAGE_POLICIES`); ``ValueError`` naming the file
    if it is not an SB3 model file."""
    import zipfile

    try:
        with zipfile.ZipFile(zip_path) as archive:
            data = json.loads(archive.read("data"))
        module = str(data["policy_class"]["__module__"])
    except (OSError, zipfile.BadZipFile, KeyError, TypeError, ValueError) as exc:
        raise ValueError(
            f"{zip_path} is not a readable SB3 model file: {type(exc).__name__}: {exc}"
        ) from None
    for algo in ALGOS:
        if module.startswith(f"stable_baselines3.{algo}."):
            return algo
    return PACKAGE_POLICIES.get(module)


def check_config(config: Mapping[str, Any], path: Path) -> None:
    """``ValueError`` naming ``path`` (a run's ``config.json``) and the field if a field the loader
    reads is malformed: ``algo`` (one of :data:`ALGOS`), ``env_id`` (a registered id),
    ``env_kwargs`` (an object of arguments the env accepts), ``hyperparams`` (an object), its
    ``normalize`` (a bool, a zoo string or an object) and its ``env_wrapper`` (a valid repeat)."""
    import gymnasium as gym

    from agents.wrappers import action_repeat, memory_frames

    def bad(name: str, must: str) -> ValueError:
        value = config
        for key in name.split("."):
            value = value[key]
        return ValueError(f"{path}: {name}: must be {must}, got {value!r}")

    if "algo" in config and not (isinstance(config["algo"], str) and config["algo"] in ALGOS):
        raise bad("algo", f"one of {', '.join(ALGOS)}")
    if "env_id" in config and not (isinstance(config["env_id"], str) and config["env_id"] in gym.registry):
        raise bad("env_id", "a registered env id")
    kwargs = config.get("env_kwargs", {})
    if not isinstance(kwargs, dict):
        raise bad("env_kwargs", "an object of env arguments")
    hyperparams = config.get("hyperparams", {})
    if not isinstance(hyperparams, dict):
        raise bad("hyperparams", "an object (the zoo-format entry)")
    normalize = hyperparams.get("normalize")
    if normalize is not None and not isinstance(normalize, (bool, str, dict)):
        raise bad("hyperparams.normalize", "true, false, a zoo string or an object of VecNormalize arguments")
    try:
        action_repeat(hyperparams.get("env_wrapper"))
        memory_frames(hyperparams.get("env_wrapper"))
    except (ValueError, TypeError, AttributeError, StopIteration) as exc:
        raise ValueError(f"{path}: hyperparams.env_wrapper: {exc}") from None
    env_id = config.get("env_id", DEFAULT_ENV_ID)
    try:
        gym.make(env_id, **kwargs).close()
    except Exception as exc:  # the env's own checks raise TypeError, ValueError and more
        raise ValueError(f"{path}: env_kwargs: {kwargs!r} rejected by {env_id}: {exc}") from None


def check_statistics(vecnormalize: Any, model: Any, stats: Path, zip_path: Path) -> None:
    """``ValueError`` naming ``stats`` and both shapes if its observation statistics are not of
    the observations ``model`` (the one of ``zip_path``) takes: another model's file."""
    found = vars(vecnormalize)  # not getattr: a VecEnvWrapper without its venv recurses on a missing one
    rms, space = found.get("obs_rms"), found.get("observation_space")  # no obs_rms: norm_obs was off
    shape = getattr(rms, "mean", None) if rms is not None else None
    shape = np.shape(shape) if shape is not None else getattr(space, "shape", None)
    expected = getattr(getattr(model, "observation_space", None), "shape", None)
    if shape is None or expected is None:
        return
    if tuple(shape) != tuple(expected):
        raise ValueError(
            f"{stats}: VecNormalize statistics of observations of shape {tuple(shape)}, but "
            f"{zip_path} takes observations of shape {tuple(expected)} (statistics of another model?)"
        )


#: ``config.json``'s ``trained_by`` of runs that always normalise observations, recorded or not.
ALWAYS_NORMALISED = ("agents.imitation",)


def observations_normalised(config: Mapping[str, Any]) -> bool:
    """Whether the run of ``config`` (a run's ``config.json``) normalised its observations, as its
    ``hyperparams.normalize`` says (``true``, or a dict / dict string with ``norm_obs`` true or unset);
    without that field, true for a run whose ``trained_by`` is one of :data:`ALWAYS_NORMALISED`."""
    import ast

    hyperparams = config.get("hyperparams", {})
    if "normalize" not in hyperparams and config.get("trained_by") in ALWAYS_NORMALISED:
        return True
    normalize = hyperparams.get("normalize", False)
    if isinstance(normalize, str):
        text = normalize.strip()
        if text.lower() in ("true", "false"):
            return text.lower() == "true"
        try:
            tree = ast.parse(text, mode="eval").body
            if isinstance(tree, ast.Call) and getattr(tree.func, "id", "") == "dict":
                normalize = {k.arg: ast.literal_eval(k.value) for k in tree.keywords}
            else:
                normalize = ast.literal_eval(text)
        except (ValueError, SyntaxError):
            return True  # unreadable: assume it did (refusing is safer than acting on raw observations)
    if isinstance(normalize, dict):
        return bool(normalize.get("norm_obs", True))
    return bool(normalize)
