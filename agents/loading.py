"""Trained agents: the algorithms by name and the one loader of runs, shipped models and checkpoints.

A run or model folder holds ``model.zip``, ``config.json`` (its ``algo``, ``env_id`` and
``env_kwargs``), ``vecnormalize.pkl`` when training normalised observations or rewards, and
``summary.json``; a run's ``checkpoints/`` hold ``rl_model_<steps>_steps.zip`` with the
matching ``rl_model_vecnormalize_<steps>_steps.pkl``. The algorithm is the one its
``config.json`` names; a bare ``.zip`` without one needs ``algo``.

>>> agent = load_agent("agents/models/ppo_IOSUAV-v0")                      # doctest: +SKIP
>>> early = load_agent("runs/<run>", checkpoint=250_000)                   # doctest: +SKIP
>>> import gymnasium as gym                                                # doctest: +SKIP
>>> from ios_uav_env.envs.rollout import run_episode                            # doctest: +SKIP
>>> run_episode(gym.make(agent.env_id, **agent.env_kwargs), agent.act)     # doctest: +SKIP
"""

from __future__ import annotations

import json
import pickle
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
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
