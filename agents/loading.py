"""Trained agents: the algorithms by name and the one loader of runs, shipped models and checkpoints.

A run or model folder holds ``model.zip``, ``config.json`` (its ``algo``, ``env_id`` and
``env_kwargs``), ``vecnormalize.pkl`` when training normalised observations or rewards, and
``summary.json``; a run's ``checkpoints/`` hold ``rl_model_<steps>_steps.zip`` with the
matching ``rl_model_vecnormalize_<steps>_steps.pkl``. The algorithm is the one its
``config.json`` names; a bare ``.zip`` without one needs ``algo``.

>>> agent = load_agent("agents/models/ppo_IOSUAV-v0")                      # doctest: +SKIP
>>> early = load_agent("runs/<run>", checkpoint=250_000)                   # doctest: +SKIP
>>> import gymnasium as gym                                                # doctest: +SKIP
>>> from ios_uav_env.rollout import run_episode                            # doctest: +SKIP
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

    An ``Agent`` is a policy for ``ios_uav_env.rollout.run_episode``: ``agent(obs)`` is
    ``agent.act(obs)``, the deterministic action.
    """

    model: Any  # an SB3 algorithm
    vecnormalize: Any = None  # VecNormalize with the training statistics, or None
    env_id: str = DEFAULT_ENV_ID  # the id it was trained on
    env_kwargs: dict[str, Any] = field(default_factory=dict)  # the env arguments it was trained with
    name: str = "agent"
    meta: dict[str, Any] = field(default_factory=dict)  # config.json and summary.json of its run

    def act(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
        if self.vecnormalize is not None:
            obs = self.vecnormalize.normalize_obs(obs)
        action, _ = self.model.predict(obs, deterministic=deterministic)
        return action

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return self.act(obs)


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
    """The VecNormalize statistics of ``path`` for inference (frozen, rewards not normalised)."""
    with path.open("rb") as fh:
        vecnormalize = pickle.load(fh)  # what VecNormalize.load does, without an env to attach
    vecnormalize.training, vecnormalize.norm_reward = False, False
    return vecnormalize


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
    ``algo``: checked against the run's ``config.json`` (``ValueError`` if it differs); required
    for a ``.zip`` without a ``config.json`` beside it. ``checkpoint``: the steps of a
    checkpoint of the run folder ``path`` (model and VecNormalize statistics of that step).
    ``env_id``: the id of a bare ``.zip`` (default ``ios_uav_env/IOSUAV-v0``); a run's own
    id comes from its ``config.json``. Raises ``FileNotFoundError`` for a missing model.
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
            meta[key] = json.loads(file.read_text())
    config = meta.get("config", {})
    found = config.get("algo")
    if found is None and algo is None:
        raise ValueError(
            f"{zip_path}: no config.json beside it names its algorithm; "
            f"pass the algorithm ({', '.join(ALGOS)})"
        )
    if found is not None and algo is not None and found != algo:
        raise ValueError(f"{zip_path} holds a {found.upper()} model, not {algo.upper()}")
    import torch

    torch.set_num_threads(1)
    model = ALGOS[found or algo].load(zip_path, device="cpu")
    return Agent(
        model,
        _read_vecnormalize(stats) if stats.exists() else None,
        config.get("env_id", env_id or DEFAULT_ENV_ID),
        dict(config.get("env_kwargs", {})),
        name or (zip_path.stem if checkpoint is not None or path.suffix == ".zip" else folder.name),
        meta,
    )
