"""A run's settings (:class:`TrainSettings`, the fields of ``train.py``'s arguments) and their checks.

Each check returns its value or raises ``ValueError`` with the reason and the allowed values;
:meth:`TrainSettings.validate` and ``train.py``'s argument parser both use them.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym

import ios_uav_env
from agents.hyperparams import Hyperparams, load_hyperparams
from agents.loading import ALGOS
from agents.wrappers import apply_wrappers

DEFAULT_ENV_ID = "ios_uav_env/IOSUAV-v0"

#: ``TrainSettings.vec_env``: SB3's DummyVecEnv of single envs, or the natively batched env
#: (``agents.vec_env.BatchedVecEnv``: the same episodes, stepped as one array computation).
VEC_ENVS = ("dummy", "batched")

#: ``TrainSettings.trainer``: Stable-Baselines3's own loop (the library path, the default) or the
#: fast PPO on the batched env's arrays (``agents.fast``; PPO only, always on the batched env).
TRAINERS = ("sb3", "fast")

#: The recipe file of the fast trainer (``agents.fast``) when none is given.
FAST_HYPERPARAMS = Path(__file__).resolve().parents[1] / "hyperparams" / "fast_ppo.yml"


def check_trainer(trainer: str) -> str:
    if trainer not in TRAINERS:
        raise ValueError(f"unknown trainer {trainer!r}; choose from {', '.join(TRAINERS)}")
    return trainer


def check_threads(threads: Any) -> int | None:
    """``threads`` (torch threads of the fast trainer) checked: None (the default, 1) or an integer >= 1."""
    if threads is None:
        return None
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise ValueError(f"must be None (the default, 1) or an integer >= 1, got {threads!r}")
    return threads


def check_algo(algo: str) -> str:
    if algo not in ALGOS:
        raise ValueError(f"unknown algorithm {algo!r}; choose from {', '.join(ALGOS)}")
    return algo


def check_env_id(env_id: str) -> str:
    if env_id not in gym.registry:
        ours = ", ".join(sorted(ios_uav_env.ENV_IDS))
        raise ValueError(f"unknown env id {env_id!r}; registered ids of this package: {ours}")
    return env_id


def check_positive(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
        raise ValueError(f"must be a positive integer, got {value!r}")
    return value


def check_vec_env(vec_env: str) -> str:
    if vec_env not in VEC_ENVS:
        raise ValueError(f"unknown vec env {vec_env!r}; choose from {', '.join(VEC_ENVS)}")
    return vec_env


def check_env_kwargs(env_id: str, env_kwargs: dict[str, Any]) -> dict[str, Any]:
    """``env_kwargs`` if ``gym.make(env_id, **env_kwargs)`` accepts them and the env resets."""
    try:
        env = gym.make(env_id, **env_kwargs)
        try:
            env.reset(seed=0)
        finally:
            env.close()
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{env_kwargs!r} rejected by {env_id}: {exc}") from exc
    return env_kwargs


def check_hyperparams(
    algo: str,
    env_id: str,
    path: str | Path | None = None,
    env_kwargs: dict[str, Any] | None = None,
    n_envs: int | None = None,
    vec_env: str = "dummy",
    trainer: str = "sb3",
) -> Hyperparams:
    """The resolved hyperparameters of ``env_id`` if the algorithm can be built with them on the
    env (``ValueError`` naming the file and the key otherwise, :func:`agents.hyperparams.check_entry`);
    for ``trainer="fast"`` also read as its recipe (``agents.fast.FastRecipe``), default file
    :data:`FAST_HYPERPARAMS`.

    The trial build has at most two envs and a small replay buffer: what it warns about (e.g.
    SB3's mini-batch size against ``n_steps * n_envs``) is its own size, not the run's, so its
    warnings are dropped; the run's own build warns about the run's settings."""
    import warnings

    from stable_baselines3.common.vec_env import DummyVecEnv

    if trainer == "fast":
        if algo != "ppo":
            raise ValueError(f"the fast trainer trains PPO only, got algo {algo!r}")
        path = path or FAST_HYPERPARAMS
    hp = load_hyperparams(algo, env_id, path)
    where = path or f"agents/hyperparams/{algo}.yml"
    if trainer == "fast":
        from agents.fast.recipe import FastRecipe

        try:
            FastRecipe.from_hyperparams(hp, n_envs, env_id, env_kwargs)  # a CloneStart expert on the env
        except ValueError as exc:
            raise ValueError(f"{where}, {env_id}: {exc}") from None
        vec_env = "batched"
    if vec_env == "batched" and hp.env_wrappers:
        _check_batchable(hp, where, env_id)
    n = n_envs or hp.n_envs

    def make() -> gym.Env:
        env = gym.make(env_id, **(env_kwargs or {}))
        return apply_wrappers(env, hp.env_wrappers) if hp.env_wrappers else env

    venv = DummyVecEnv([make] * min(n, 2))
    try:
        with warnings.catch_warnings(record=True):  # the trial build's size, not the run's
            warnings.simplefilter("always")
            ALGOS[algo](hp.policy, venv, device="cpu", **{**hp.model_kwargs, **_small_buffer(hp)})
    except (TypeError, ValueError, AssertionError, KeyError) as exc:
        raise ValueError(f"{where}, {env_id}: {algo.upper()} refuses these hyperparameters: {exc}") from None
    finally:
        venv.close()
    return hp


def _check_batchable(hp: Hyperparams, where: str | Path, env_id: str) -> None:
    """``ValueError`` naming the first ``env_wrapper`` of ``hp`` that has no VecEnv form."""
    from agents.vec_env import VEC_FORMS

    for cls, _ in hp.env_wrappers:
        name = f"{cls.__module__}.{cls.__qualname__}"
        if name not in VEC_FORMS:
            raise ValueError(
                f"{where}, {env_id}: env_wrapper {name!r} cannot wrap the batched env; "
                f"wrappers with a VecEnv form: {', '.join(VEC_FORMS)}"
            )


def _small_buffer(hp: Hyperparams) -> dict[str, Any]:
    """A trial build needs no full replay buffer."""
    return {"buffer_size": 10} if "buffer_size" in hp.model_kwargs else {}


@dataclass
class TrainSettings:
    """Everything a run needs; the fields are ``train.py``'s arguments."""

    algo: str  # "ppo" or "sac"
    env_id: str = DEFAULT_ENV_ID  # a registered id
    timesteps: int | None = None  # total env steps; None = the hyperparameter file's n_timesteps
    seed: int = 0  # seeds torch, numpy, the model and the envs (env i gets seed + i)
    n_envs: int | None = None  # parallel envs; None = the file's n_envs
    vec_env: str = "dummy"  # "dummy" (SB3's DummyVecEnv) or "batched" (agents.vec_env.BatchedVecEnv)
    env_kwargs: dict[str, Any] = field(default_factory=dict)  # env arguments (over the recipe's env_kwargs)
    out: str | None = None  # run folder; None = runs/<env>__<algo>__<seed>__<time>
    hyperparams_file: str | None = None  # None = agents/hyperparams/<algo>.yml
    checkpoint_freq: int = 25_000  # env steps between checkpoints
    eval_freq: int = 10_000  # env steps between deterministic evaluations (0: none)
    progress_bar: bool = True
    trainer: str = "sb3"  # "sb3" (SB3's loop) or "fast" (agents.fast: PPO on the batched env's arrays)
    threads: int | None = None  # torch threads of the fast trainer; None = 1
    init_from: str | None = None  # fast trainer: a model (folder or PPO .zip) whose weights it starts from

    def resolve_env_kwargs(self) -> dict[str, Any]:
        """Fill ``env_kwargs`` in with the recipe's (the ``env_kwargs`` of the hyperparameter entry):
        a key given here wins, key by key. Returns them. A recipe that does not load leaves them
        as they are (the hyperparameter check names its problem)."""
        try:
            hp = load_hyperparams(self.algo, self.env_id, self.hyperparams_path())
        except (ValueError, OSError, KeyError):
            return self.env_kwargs
        self.env_kwargs = {**hp.env_kwargs, **self.env_kwargs}
        return self.env_kwargs

    def hyperparams_path(self) -> Path:
        """The recipe file the run reads: ``hyperparams_file``, else the trainer's default
        (``agents/hyperparams/<algo>.yml``, or :data:`FAST_HYPERPARAMS` for the fast trainer)."""
        if self.hyperparams_file is not None:
            return Path(self.hyperparams_file)
        return (
            FAST_HYPERPARAMS
            if self.trainer == "fast"
            else Path(__file__).resolve().parents[1] / (f"hyperparams/{self.algo}.yml")
        )

    def validate(self) -> None:
        """Raise ``ValueError`` naming the first bad field."""
        for name, check, value in self._checks():
            try:
                check(value)
            except ValueError as exc:
                raise ValueError(f"{name}: {exc}") from exc

    def _checks(self) -> list[tuple[str, Any, Any]]:
        """``(field, check, value)`` in the order :meth:`validate` runs them."""
        checks: list[tuple[str, Any, Any]] = [
            ("algo", check_algo, self.algo),
            ("env_id", check_env_id, self.env_id),
            ("vec_env", check_vec_env, self.vec_env),
            ("trainer", check_trainer, self.trainer),
            ("threads", check_threads, self.threads),
        ]
        for name in ("timesteps", "n_envs", "checkpoint_freq"):
            if getattr(self, name) is not None:  # None: the hyperparameter file's value
                checks.append((name, check_positive, getattr(self, name)))
        checks.append(("env_kwargs", functools.partial(check_env_kwargs, self.env_id), self.env_kwargs))
        hyperparams = functools.partial(
            check_hyperparams,
            self.algo,
            self.env_id,
            env_kwargs=self.env_kwargs,
            n_envs=self.n_envs,
            vec_env=self.vec_env,
            trainer=self.trainer,
        )
        checks.append(("hyperparams_file", hyperparams, self.hyperparams_file))
        if self.init_from is not None:
            checks.append(("init_from", self.check_init_from, self.init_from))
        return checks

    def check_init_from(self, path: str) -> None:
        """``ValueError`` unless the fast trainer can start this run from the model at ``path``
        (:mod:`agents.fast.init_from`: the same observation and action sizes, network and
        observation normalisation as the recipe builds, and no ``CloneStart`` in the recipe)."""
        if self.trainer != "fast":
            raise ValueError("only the fast trainer takes it (add --trainer fast)")
        from agents.fast.init_from import check_init_from

        check_init_from(path, self.env_id, self.env_kwargs, self.hyperparams_path(), self.n_envs)
