"""Trained agents: the algorithms by name and the one loader of runs, shipped models and checkpoints.

A run or model folder holds ``model.zip``, ``config.json`` (its ``algo``, ``env_id`` and
``env_kwargs``), ``vecnormalize.pkl`` when training normalised observations or rewards, and
``summary.json``; a run's ``checkpoints/`` hold ``rl_model_<steps>_steps.zip`` with the
matching ``rl_model_vecnormalize_<steps>_steps.pkl``. The algorithm is the one its
``config.json`` names; a bare ``.zip`` without one needs ``algo``. The algorithms by name and the
reading and checks of those files are :mod:`agents.run_files`' (importable from here too).

>>> agent = load_agent("agents/models/ppo_IOSUAV-v0")                      # doctest: +SKIP
>>> early = load_agent("runs/<run>", checkpoint=250_000)                   # doctest: +SKIP
>>> import gymnasium as gym                                                # doctest: +SKIP
>>> from ios_uav_env.envs.rollout import run_episode                            # doctest: +SKIP
>>> run_episode(gym.make(agent.env_id, **agent.env_kwargs), agent.act)     # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

import ios_uav_env  # noqa: F401  (registers the ids the agents' env_id names)
from agents.run_files import (  # noqa: F401 (a run folder's files, re-exported)
    ALGOS,
    ALWAYS_NORMALISED,
    CHECKPOINT_PREFIX,
    DEFAULT_ENV_ID,
    PACKAGE_POLICIES,
    _read_vecnormalize,
    check_config,
    check_statistics,
    checkpoint_file,
    checkpoints,
    observations_normalised,
    read_json,
    zip_algorithm,
)


@dataclass
class Agent:
    """A trained policy: ``model.predict`` on observations normalised as in training (if they were).

    An ``Agent`` is a policy for ``ios_uav_env.envs.rollout.run_episode``: ``agent(obs)`` is
    ``agent.act(obs)``, the deterministic action.
    """

    model: Any  # an SB3 algorithm
    vecnormalize: Any = None  # VecNormalize with the training statistics, or None
    env_id: str = DEFAULT_ENV_ID  # the id it was trained on
    env_kwargs: dict[str, Any] = field(default_factory=dict)  # the env arguments it was trained with
    name: str = "agent"
    meta: dict[str, Any] = field(default_factory=dict)  # config.json and summary.json of its run
    repeat: int = 1  # slots each action is held (agents.wrappers.ActionRepeat in its training)
    memory: int = 1  # observations the model sees at once (agents.wrappers.FrameStack in its training)
    batched = True  # act takes a (B, obs_dim) batch too (ios_uav_env.envs.rollout.batch_policy)
    _history: Any = field(default=None, init=False, repr=False)  # agents.tricks.History, made at first use

    @property
    def observation_space(self) -> Any:
        """The observations the agent takes: the model's (what it was trained on), or with a memory
        (:attr:`memory` frames) the env's own, one frame of the model's."""
        return self.model.observation_space if self.memory == 1 else frame_space(self.model, self.memory)

    def act(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
        """The model's action on ``obs``; with a memory, ``obs`` is the env's own observation and the
        agent keeps the last :attr:`memory` of them (``agents.tricks.History``: a new episode is
        told by the ``time_left`` feature), so one agent flies one episode (or one batch) at a time."""
        if self.memory > 1:
            if self._history is None:
                self._history = history(self.memory, self.env_id, self.env_kwargs)
            obs = self._history(obs)
        if self.vecnormalize is not None:
            obs = self.vecnormalize.normalize_obs(obs)
        action, _ = self.model.predict(obs, deterministic=deterministic)
        return action

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return self.act(obs)

    def check_env(
        self,
        env: Any = None,
        *,
        env_id: str | None = None,
        env_kwargs: Mapping[str, Any] | None = None,
        source: Any = None,
    ) -> None:
        """``ValueError`` naming both sizes if ``env`` (default: ``env_id`` made with ``env_kwargs``,
        default the agent's own) gives observations of another size than the model takes."""
        expected = getattr(getattr(self.model, "observation_space", None), "shape", None)
        if expected is None:
            return
        if env is None:
            import gymnasium as gym

            import ios_uav_env  # noqa: F401  (registers the ids)

            env_id = env_id or self.env_id
            env_kwargs = dict(self.env_kwargs if env_kwargs is None else env_kwargs)
            made = gym.make(env_id, **env_kwargs)
            shape = made.observation_space.shape
            made.close()
            where = f"{env_id} with {env_kwargs}"
        else:
            shape = env.observation_space.shape
            where = f"the env {getattr(getattr(env, 'spec', None), 'id', type(env).__name__)}"
        if self.memory > 1:  # the model takes the env's observations stacked
            shape = (shape[0] * self.memory,)
        if tuple(shape) != tuple(expected):
            raise ValueError(
                f"{source or self.name}: the model takes observations of shape {tuple(expected)}, "
                f"{where} gives {tuple(shape)}"
            )


def frame_space(model: Any, frames: int) -> Any:
    """The space of one frame of the stacked observations ``model`` takes (``frames`` of them)."""
    import gymnasium as gym

    space = model.observation_space
    d = space.shape[0] // frames
    return gym.spaces.Box(space.low[-d:], space.high[-d:], dtype=space.dtype)


def history(frames: int, env_id: str, env_kwargs: Mapping[str, Any]) -> Any:
    """A memory of ``frames`` observations for a policy flown on ``env_id`` with ``env_kwargs``
    (``agents.tricks.History``, its clock the env's ``time_left`` feature); ``ValueError`` if the
    env's observation has no such feature."""
    import gymnasium as gym

    from agents.tricks import History

    env = gym.make(env_id, **dict(env_kwargs))
    names = tuple(getattr(env.unwrapped, "observation_names", ()))
    env.close()
    if "time_left" not in names:
        raise ValueError(f"{env_id}: a memory needs the time_left feature in the observation, got {names}")
    return History(frames, names.index("time_left"))


def load_agent(
    path: str | Path,
    algo: str | None = None,
    *,
    checkpoint: int | None = None,
    env_id: str | None = None,
    name: str | None = None,
) -> Agent:
    """The agent of a run or model folder, of one of a run's checkpoints, or of a bare ``.zip``.

    ``path``: a folder with ``model.zip`` (and ``config.json``), or a ``.zip`` file.
    ``algo``: checked against the run's ``config.json`` and the zip's own policy class
    (``ValueError`` if it differs); required for a ``.zip`` without a ``config.json`` beside
    it. ``checkpoint``: the steps of a checkpoint of the run folder ``path`` (model and
    VecNormalize statistics of that step). ``env_id``: the id of a bare ``.zip`` (default
    ``ios_uav_env/IOSUAV-v0``); a run's own id comes from its ``config.json``.

    Raises ``FileNotFoundError`` for a missing model, or for missing VecNormalize statistics
    of a run whose config says it normalised observations; ``ValueError`` for a file that
    cannot be read (it names the file), a malformed ``config.json`` field (it names the file
    and the field, :func:`check_config`), VecNormalize statistics of observations of another
    size than the model's (it names the file and both, :func:`check_statistics`), or an env
    whose observation size is not the model's (it names both).
    """
    path = Path(path)
    if algo is not None and algo not in ALGOS:
        raise ValueError(f"unknown algorithm {algo!r}; choose from {', '.join(ALGOS)}")
    if checkpoint is not None:
        folder, zip_path = path, checkpoint_file(path, checkpoint)
        stats = checkpoint_file(path, checkpoint, "vecnormalize")
    elif path.suffix == ".zip":
        folder, zip_path, stats = path.parent, path, path.parent / "vecnormalize.pkl"
    else:
        folder, zip_path, stats = path, path / "model.zip", path / "vecnormalize.pkl"
    if not zip_path.exists():
        raise FileNotFoundError(f"no model at {zip_path}")
    meta: dict[str, Any] = {}
    for key in ("config", "summary"):
        file = folder / f"{key}.json"
        if file.exists():
            meta[key] = read_json(file)
    config = meta.get("config", {})
    if "config" in meta:
        check_config(config, folder / "config.json")
    found = config.get("algo")
    if found is None and algo is None:
        raise ValueError(
            f"{zip_path}: no config.json beside it names its algorithm; "
            f"pass the algorithm ({', '.join(ALGOS)})"
        )
    if found is not None and algo is not None and found != algo:
        raise ValueError(f"{zip_path} holds a {found.upper()} model, not {algo.upper()}")
    algo = found or algo
    saved_by = zip_algorithm(zip_path)
    if saved_by is not None and saved_by != algo:
        raise ValueError(f"{zip_path} holds a {saved_by.upper()} model, not {algo.upper()}")
    vecnormalize = None
    if stats.exists():
        vecnormalize = _read_vecnormalize(stats)
    elif observations_normalised(config):
        hyperparams = config.get("hyperparams", {})
        record = (
            f"normalize {hyperparams['normalize']!r}"
            if "normalize" in hyperparams
            else f"trained_by {config.get('trained_by')!r}"
        )
        raise FileNotFoundError(
            f"{zip_path}: its run normalised observations ({folder / 'config.json'}: {record}) "
            f"but the statistics {stats} are missing"
        )
    import torch

    from agents.wrappers import action_repeat, memory_frames

    torch.set_num_threads(1)
    try:
        model = ALGOS[algo].load(zip_path, device="cpu")
    except Exception as exc:  # a damaged zip fails in many ways (zipfile, torch, SB3 asserts)
        raise ValueError(
            f"{zip_path}: cannot load the {algo.upper()} model: {type(exc).__name__}: {exc}"
        ) from None
    if vecnormalize is not None:
        check_statistics(vecnormalize, model, stats, zip_path)
    agent = Agent(
        model,
        vecnormalize,
        config.get("env_id", env_id or DEFAULT_ENV_ID),
        dict(config.get("env_kwargs", {})),
        name or (zip_path.stem if checkpoint is not None or path.suffix == ".zip" else folder.name),
        meta,
        action_repeat(config.get("hyperparams", {}).get("env_wrapper")),
        memory_frames(config.get("hyperparams", {}).get("env_wrapper")),
    )
    agent.check_env(source=zip_path)
    return agent


def load_numpy_agent(path: str | Path, algo: str | None = None, *, checkpoint: int | None = None) -> Any:
    """:func:`load_agent`'s deterministic policy exported to numpy (``agents.numpy_policy``): the
    same actions to float rounding at a fraction of SB3's per-call overhead, for timing a policy's
    plan (``python -m ios_uav_env.benchmark evaluate --policy
    "agents.loading:load_numpy_agent('<run>')"``). It carries the agent's ``env_id``,
    ``env_kwargs`` and ``name``, so the benchmark makes the env the agent was trained on, and
    ``batched`` False, so it plays in the single env (it still takes a batch of observations)."""
    from agents.numpy_policy import NumpyPolicy

    agent = load_agent(path, algo, checkpoint=checkpoint)
    policy = NumpyPolicy.from_sb3(agent.model, agent.vecnormalize, agent.repeat)
    if agent.memory > 1:  # flown on the env's own observations, its memory beside it
        policy.history = history(agent.memory, agent.env_id, agent.env_kwargs)
        policy.observation_space = agent.observation_space
    policy.env_id, policy.env_kwargs, policy.name = agent.env_id, dict(agent.env_kwargs), agent.name
    # scored one episode at a time in the single env (a batch of one costs more per slot)
    policy.batched = False
    return policy
