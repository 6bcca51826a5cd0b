"""Hyperparameters in the rl-baselines3-zoo format, and the ``--env-kwargs`` parser.

``agents/hyperparams/{ppo,sac}.yml`` map an env id to the zoo's keys: ``n_timesteps``,
``n_envs``, ``policy``, ``normalize`` (``true`` or a string such as
``"{'norm_obs': False, 'norm_reward': True}"``), ``policy_kwargs`` (a Python string, e.g.
``"dict(net_arch=[64, 64])"``), ``learning_rate`` (a number or ``lin_<value>``, the zoo's
linear schedule), ``callback`` and ``env_wrapper`` (``module.Class`` or a list of
``{module.Class: {kwargs}}``, e.g. ``agents.wrappers.ShiftReward``), ``env_kwargs`` (the env's
keyword arguments the recipe is trained with, a mapping such as ``{peak_hint: true}``; a
command line's ``--env-kwargs`` overrides them key by key in ``train.py``, the whole mapping in
the zoo) and the algorithm's own keyword arguments. The same files train with the zoo:

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
_ZOO_KEYS = (
    "n_timesteps", "n_envs", "policy", "normalize", "env_wrapper", "frame_stack", "callback", "env_kwargs",
)  # fmt: skip


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
    env_kwargs: dict[str, Any] = field(default_factory=dict)  # the env's arguments of the recipe

    @property
    def repeat(self) -> int:
        """The slots each action is held (``agents.wrappers.ActionRepeat`` among the wrappers; else 1)."""
        from agents.wrappers import action_repeat

        return action_repeat(self.raw.get("env_wrapper"))

    @property
    def memory(self) -> int:
        """The observations the policy sees at once (``agents.wrappers.FrameStack``'s frames; else 1)."""
        from agents.wrappers import memory_frames

        return memory_frames(self.raw.get("env_wrapper"))


def hyperparams_path(algo: str) -> Path:
    """The shipped file of ``algo`` (``agents/hyperparams/<algo>.yml``)."""
    return HYPERPARAMS_DIR / f"{algo}.yml"


def load_hyperparams(algo: str, env_id: str, path: str | Path | None = None) -> Hyperparams:
    """Read and resolve the entry of ``env_id`` in the zoo-format file of ``algo``; ``ValueError``
    naming the file and the key if the file is not YAML, has no entry for ``env_id``, or an
    entry cannot be resolved (:func:`check_entry`)."""
    path = Path(path) if path is not None else hyperparams_path(algo)
    try:
        with open(path, encoding="utf-8") as fh:
            table = yaml.safe_load(fh) or {}
    except yaml.YAMLError as exc:
        raise ValueError(f"{path} is not valid YAML: {exc}") from None
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path} is not a text file: {exc}") from None
    if not isinstance(table, dict):
        raise ValueError(f"{path} must map env ids to hyperparameters, got a {type(table).__name__}")
    if env_id not in table:
        raise ValueError(f"{path} has no hyperparameters for env id {env_id!r} (has: {', '.join(table)})")
    entry = table[env_id]
    if not isinstance(entry, dict):
        raise ValueError(f"{path}: the entry of {env_id!r} must be a mapping of hyperparameters")
    try:
        return resolve(check_entry(algo, entry))
    except ValueError as exc:
        raise ValueError(f"{path}, {env_id}: {exc}") from None


#: Counts that must be positive integers, and those that may be zero.
POSITIVE_KEYS = (
    "n_timesteps", "n_envs", "n_steps", "batch_size", "n_epochs", "buffer_size", "gradient_steps",
)  # fmt: skip
NON_NEGATIVE_KEYS = ("learning_starts",)
#: Numbers in [0, 1] and numbers >= 0.
FRACTION_KEYS = ("gamma", "gae_lambda", "tau")
NUMBER_KEYS = ("max_grad_norm", "vf_coef", "clip_range_vf", "target_kl")


def check_entry(algo: str, entry: dict[str, Any]) -> dict[str, Any]:
    """``entry`` if every key is a zoo key or an argument of the algorithm and every count and
    number is in its range; ``ValueError`` naming the key and the allowed values otherwise."""
    import inspect
    import math

    from agents.loading import ALGOS

    cls = ALGOS[algo]
    allowed = set(inspect.signature(cls.__init__).parameters) - {"self", "env", "policy", "_init_setup_model"}
    unknown = [k for k in entry if k not in _ZOO_KEYS and k not in allowed]
    if unknown:
        raise ValueError(
            f"hyperparameter {unknown[0]!r} is neither a zoo key ({', '.join(_ZOO_KEYS)}) nor an "
            f"argument of {cls.__name__}"
        )

    def number(key: str, value: Any) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float) and not _is_number_text(value):
            raise ValueError(f"hyperparameter {key} must be a number, got {value!r}")
        value = float(value)
        if not math.isfinite(value):
            raise ValueError(f"hyperparameter {key} must be finite, got {value!r}")
        return value

    for key in (*POSITIVE_KEYS, *NON_NEGATIVE_KEYS):
        if key in entry:
            value = number(key, entry[key])
            low = 1 if key in POSITIVE_KEYS else 0
            if value != int(value) or value < low:
                what = "a positive integer" if low else "an integer >= 0"
                raise ValueError(f"hyperparameter {key} must be {what}, got {entry[key]!r}")
    for key in FRACTION_KEYS:
        if key in entry and not 0.0 <= number(key, entry[key]) <= 1.0:
            raise ValueError(f"hyperparameter {key} must be in [0, 1], got {entry[key]!r}")
    for key in NUMBER_KEYS:
        if key in entry and entry[key] is not None and number(key, entry[key]) < 0:
            raise ValueError(f"hyperparameter {key} must be >= 0, got {entry[key]!r}")
    for key in ("learning_rate", "clip_range"):
        if key in entry:
            value = entry[key]
            text = value[4:] if isinstance(value, str) and value.startswith("lin_") else value
            if number(key, text) <= 0:
                raise ValueError(
                    f"hyperparameter {key} must be > 0 (a number or lin_<number>), got {value!r}"
                )
    if "train_freq" in entry:
        freq = entry["train_freq"]
        count = freq[0] if isinstance(freq, list | tuple) and len(freq) == 2 else freq
        unit = freq[1] if isinstance(freq, list | tuple) and len(freq) == 2 else "step"
        bad_count = isinstance(count, bool) or not isinstance(count, int) or count < 1
        if bad_count or unit not in ("step", "episode"):
            raise ValueError(f"hyperparameter train_freq must be n or [n, 'step'|'episode'] with n >= 1, "
                             f"got {freq!r}")  # fmt: skip
    return entry


def _is_number_text(value: Any) -> bool:
    if not isinstance(value, str):
        return False
    try:
        float(value)
    except ValueError:
        return False
    return True


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


def _env_kwargs(spec: Any) -> dict[str, Any]:
    """The zoo's ``env_kwargs`` value: a mapping of the env's keyword arguments (none: {})."""
    if spec is None:
        return {}
    if not isinstance(spec, dict) or not all(isinstance(k, str) and k.isidentifier() for k in spec):
        raise ValueError(
            f"hyperparameter env_kwargs must map env argument names to values (e.g. {{peak_hint: true}}), "
            f"got {spec!r}"
        )
    return copy.deepcopy(spec)


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
        env_kwargs=_env_kwargs(entry.get("env_kwargs")),
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


def positive_int(text: str) -> int:
    """An argparse type: an integer >= 1 (the counts of the CLIs: jobs, scenarios, seeds)."""
    import argparse

    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text!r}")
    return value
