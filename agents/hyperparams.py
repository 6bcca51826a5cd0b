"""Hyperparameters in the rl-baselines3-zoo format, and the ``--env-kwargs`` parser.

``agents/hyperparams/{ppo,sac}.yml`` map an env id to the zoo's keys: ``n_timesteps``,
``n_envs``, ``policy``, ``normalize`` (``true`` or a string such as
``"{'norm_obs': False, 'norm_reward': True}"``), ``policy_kwargs`` (a Python string, e.g.
``"dict(net_arch=[64, 64])"``), ``learning_rate`` (a number or ``lin_<value>``, the zoo's
linear schedule), ``callback`` and ``env_wrapper`` (``module.Class`` or a list of
``{module.Class: {kwargs}}``, e.g. ``agents.wrappers.ShiftReward``) and the algorithm's own
keyword arguments. The same files train with the zoo:

    python -m rl_zoo3.train --algo ppo --env ios_uav_env/IOSUAV-v0 --gym-packages ios_uav_env \\
        --conf-file agents/hyperparams/ppo.yml
"""

from __future__ import annotations

import ast
import copy
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

HYPERPARAMS_DIR = Path(__file__).resolve().parent / "hyperparams"
#: zoo keys that are not keyword arguments of the algorithm
_ZOO_KEYS = ("n_timesteps", "n_envs", "policy", "normalize", "env_wrapper", "frame_stack", "callback")


@dataclass
class Hyperparams:
    """One resolved entry of a zoo-format file."""

    raw: dict[str, Any]  # the entry as written in the YAML file (for the resolved config)
    n_timesteps: int
    n_envs: int
    policy: str
    normalize: dict[str, Any] | None  # VecNormalize keyword arguments, None = no VecNormalize
    model_kwargs: dict[str, Any] = field(default_factory=dict)  # for PPO(...) / SAC(...)
    callbacks: list[Any] = field(default_factory=list)  # instances from the zoo's ``callback`` key
    env_wrappers: list[tuple[Any, dict[str, Any]]] = field(default_factory=list)  # (class, kwargs)


def hyperparams_path(algo: str) -> Path:
    """The shipped file of ``algo`` (``agents/hyperparams/<algo>.yml``)."""
    return HYPERPARAMS_DIR / f"{algo}.yml"


def load_hyperparams(algo: str, env_id: str, path: str | Path | None = None) -> Hyperparams:
    """Read and resolve the entry of ``env_id`` in the zoo-format file of ``algo``; ``ValueError``
    if the file has no entry for ``env_id`` or an entry cannot be resolved."""
    path = Path(path) if path is not None else hyperparams_path(algo)
    with open(path, encoding="utf-8") as fh:
        table = yaml.safe_load(fh) or {}
    if env_id not in table:
        raise ValueError(f"{path} has no hyperparameters for env id {env_id!r} (has: {', '.join(table)})")
    return resolve(table[env_id])


def _linear(initial: float) -> Any:
    def schedule(progress_remaining: float) -> float:
        return progress_remaining * initial

    return schedule


def _schedule(value: Any) -> Any:
    if isinstance(value, str) and value.startswith("lin_"):
        return _linear(float(value[4:]))
    return float(value) if isinstance(value, str) else value


def _python_value(text: str, key: str) -> Any:
    """Evaluate a zoo string value (``dict(net_arch=[64, 64])``) with torch's ``nn`` in scope."""
    from torch import nn

    try:
        return eval(text, {"__builtins__": {"dict": dict, "list": list, "tuple": tuple}, "nn": nn})  # noqa: S307
    except Exception as exc:
        raise ValueError(f"hyperparameter {key}: cannot evaluate {text!r}: {exc}") from exc


def _classes(spec: Any, key: str) -> list[tuple[Any, dict[str, Any], str]]:
    """A zoo value "module.Class", or a list of such names or of {"module.Class": {kwargs}}
    mappings: the (class, kwargs, name) triples."""
    import importlib

    if spec is None:
        return []
    out = []
    for item in spec if isinstance(spec, list) else [spec]:
        if isinstance(item, dict) and len(item) == 1:
            name, kwargs = next(iter(item.items()))
        else:
            name, kwargs = item, {}
        if not isinstance(name, str) or not (kwargs is None or isinstance(kwargs, dict)):
            raise ValueError(
                f"hyperparameter {key}: each entry must be 'module.Class' or {{'module.Class': {{kwargs}}}}, "
                f"got {item!r}"
            )
        module, _, cls = name.rpartition(".")
        try:
            out.append((getattr(importlib.import_module(module), cls), dict(kwargs or {}), name))
        except (ImportError, AttributeError, ValueError) as exc:
            raise ValueError(f"hyperparameter {key}: cannot import {name!r}: {exc}") from exc
    return out


def _wrappers(spec: Any) -> list[tuple[Any, dict[str, Any]]]:
    """The zoo's ``env_wrapper`` value (see :func:`_classes`): (class, kwargs) pairs whose
    keyword arguments fit the class (checked now, not when the envs are made)."""
    import inspect

    out = []
    for cls, kwargs, name in _classes(spec, "env_wrapper"):
        try:
            inspect.signature(cls).bind(None, **kwargs)  # None stands for the env
        except TypeError as exc:
            raise ValueError(f"hyperparameter env_wrapper: bad arguments for {name!r}: {exc}") from exc
        out.append((cls, kwargs))
    return out


def _callbacks(spec: Any) -> list[Any]:
    """The zoo's ``callback`` value (see :func:`_classes`); returns the instances."""
    out = []
    for cls, kwargs, name in _classes(spec, "callback"):
        try:
            out.append(cls(**kwargs))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"hyperparameter callback: cannot build {name!r}: {exc}") from exc
    return out


def resolve(entry: dict[str, Any]) -> Hyperparams:
    """Turn a zoo entry into algorithm keyword arguments, the way the zoo does."""
    raw = copy.deepcopy(entry)
    kwargs = {k: v for k, v in entry.items() if k not in _ZOO_KEYS}
    if "frame_stack" in entry:
        raise ValueError("zoo key 'frame_stack' is not supported by train.py")
    if isinstance(kwargs.get("policy_kwargs"), str):
        kwargs["policy_kwargs"] = _python_value(kwargs["policy_kwargs"], "policy_kwargs")
    for key in ("learning_rate", "clip_range"):
        if key in kwargs:
            kwargs[key] = _schedule(kwargs[key])
    if isinstance(kwargs.get("train_freq"), list):
        kwargs["train_freq"] = tuple(kwargs["train_freq"])
    normalize = entry.get("normalize", False)
    if isinstance(normalize, str):
        normalize = _python_value(normalize, "normalize")
    if normalize is True:
        normalize = {}
    elif normalize is False:
        normalize = None
    elif not isinstance(normalize, dict):
        raise ValueError(f"hyperparameter normalize must be a bool or a dict string, got {normalize!r}")
    return Hyperparams(
        raw=raw,
        callbacks=_callbacks(entry.get("callback")),
        env_wrappers=_wrappers(entry.get("env_wrapper")),
        n_timesteps=int(float(entry.get("n_timesteps", 100_000))),
        n_envs=int(entry.get("n_envs", 1)),
        policy=str(entry.get("policy", "MlpPolicy")),
        normalize=normalize,
        model_kwargs=kwargs,
    )


def parse_env_kwarg(item: str) -> tuple[str, Any]:
    """Parse one zoo-style ``key:value`` pair; the value is a Python literal or else a plain word.

    ``arrival_guard:False``, ``T:100``, ``channel:rician`` and ``channel:"'rician'"`` all work
    (a string may be quoted or not). Raises ``ValueError`` naming the malformed item.
    """
    key, sep, text = item.partition(":")
    key, text = key.strip(), text.strip()
    if not sep or not key.isidentifier() or not text:
        raise ValueError(f"expected key:value (e.g. arrival_guard:False), got {item!r}")
    try:
        return key, ast.literal_eval(text)
    except (ValueError, SyntaxError):
        if not text.replace("_", "").replace("-", "").isalnum():
            raise ValueError(f"cannot read the value of {item!r} (a Python literal or a word)") from None
        return key, text


def parse_env_kwargs(items: list[str] | None) -> dict[str, Any]:
    """Parse zoo-style ``key:value`` pairs (:func:`parse_env_kwarg`); a later key wins."""
    return dict(parse_env_kwarg(item) for item in items or [])
