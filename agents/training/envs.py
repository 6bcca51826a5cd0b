"""The training envs of a run: ``n_envs`` envs (SB3's DummyVecEnv or the batched env) with their
monitor files in ``monitor/``, the hyperparameters' ``env_wrapper`` list and, when they normalise,
VecNormalize (new, or loaded from a checkpoint's statistics).

The monitor files are append-only logs (SB3's ``Monitor``, a line per episode): a resumed run
appends to them, after cutting the unfinished last line a killed process or a full disk may
have left (``ios_uav_env.io.cut_torn_tail``), so its first episode is not glued onto it."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

from agents.hyperparams import Hyperparams
from agents.training.settings import TrainSettings
from agents.wrappers import apply_wrappers
from ios_uav_env.io import cut_torn_tail


def make_venv(
    settings: TrainSettings, hp: Hyperparams, run_dir: Path, resume_from: str | None, resumed: bool = False
) -> Any:
    """The training VecEnv of ``settings``; ``resume_from`` is a checkpoint's VecNormalize file (its
    statistics are loaded) or None; ``resumed``: the run goes on, so the monitor files are
    appended to (their torn last lines cut), else they are started anew."""
    if resumed:
        for path in sorted((run_dir / "monitor").glob("*.monitor.csv")):
            cut_torn_tail(path)
    if settings.vec_env == "batched":
        venv = _batched_venv(settings, hp, run_dir, resumed)
    else:
        venv = _dummy_venv(settings, hp, run_dir, resumed)
    return _normalized(venv, hp, resume_from)


def _normalized(venv: Any, hp: Hyperparams, resume_from: str | None) -> Any:
    """``venv`` under VecNormalize if the hyperparameters normalise (its statistics from ``resume_from``)."""
    from stable_baselines3.common.vec_env import VecNormalize

    if hp.normalize is None:
        return venv
    if resume_from is not None:
        return VecNormalize.load(resume_from, venv)
    return VecNormalize(venv, gamma=hp.model_kwargs.get("gamma", 0.99), **hp.normalize)


def _dummy_venv(settings: TrainSettings, hp: Hyperparams, run_dir: Path, resumed: bool) -> Any:
    """SB3's ``make_vec_env`` of wrapped single envs (env i seeded ``seed + i``), each under a
    ``Monitor`` writing ``monitor/<i>.monitor.csv`` (appended to on resume)."""
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv

    wrap = functools.partial(apply_wrappers, wrappers=hp.env_wrappers) if hp.env_wrappers else None
    return make_vec_env(
        settings.env_id,
        wrapper_class=wrap,
        n_envs=settings.n_envs,
        seed=settings.seed,
        env_kwargs=settings.env_kwargs,
        monitor_dir=str(run_dir / "monitor"),
        monitor_kwargs={"override_existing": not resumed},
        vec_env_cls=DummyVecEnv,
    )


def _batched_venv(settings: TrainSettings, hp: Hyperparams, run_dir: Path, resumed: bool) -> Any:
    """``BatchedVecEnv`` (row i seeded ``seed + i``, as ``make_vec_env`` seeds env i; rows staggered
    over the episode, see its ``stagger``) under a ``VecMonitor`` writing
    ``monitor/batched.monitor.csv`` (appended to on resume), then the hyperparameters'
    ``env_wrapper`` list in its VecEnv form (``agents.vec_env.wrap_batched``)."""
    from stable_baselines3.common.monitor import ResultsWriter
    from stable_baselines3.common.vec_env import VecMonitor

    from agents.vec_env import BatchedVecEnv, wrap_batched
    from agents.wrappers import ActionRepeat

    batched = BatchedVecEnv(
        settings.env_id, settings.n_envs, settings.env_kwargs, seed=settings.seed, stagger=True
    )
    # the action repeat steps the batched env's rows itself (its advance), under the monitor
    inner = [w for w in hp.env_wrappers if issubclass(w[0], ActionRepeat)]
    monitor = VecMonitor(wrap_batched(batched, inner))
    monitor.results_writer = ResultsWriter(
        str(run_dir / "monitor" / "batched"),
        header={"t_start": monitor.t_start, "env_id": settings.env_id},
        override_existing=not resumed,
    )
    return wrap_batched(monitor, [w for w in hp.env_wrappers if w not in inner])
