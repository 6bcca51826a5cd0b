"""B episodes of ``MISOControl-v0`` as one Gymnasium ``VectorEnv``: the id's batched form.

Row b is a :class:`~ios_uav_env.envs.miso_control.MISOControlEnv` of its own, stepped through
that env's public ``reset`` and ``step``: the model's per-slot functions (the slot channel, the
users' rates, the bound, the baselines and above all the AO of ``miso_slot.slot_optimum``) take
one slot at a time, so the rows are computed one after the other and the outputs stacked into
arrays. That makes row b the single env seeded ``seed + b`` bit for bit, across autoresets, by
construction (tested in ``tests/envs/test_miso_control.py``).

The API is the package's other batched envs' (``ios_uav_env.envs.batched``): ``reset(seed=s)``
seeds row b with ``s + b`` (or takes a list of B seeds); ``info`` is a dict of arrays (one row
per env: ``rates`` is (B, K)) with Gymnasium's ``_key`` masks; autoreset follows Gymnasium's
default ``NEXT_STEP`` mode (the step after an episode ends resets that row, reward 0), or with
``autoreset_mode="same_step"`` the row is reset in the step that ends it and ``info["final_obs"]``
/ ``info["final_info"]`` hold the episode's last observation and info.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector.utils import batch_space

from ios_uav_env.envs.batched import BatchedEnv, check_batch
from ios_uav_env.envs.miso_control import INFO_KEYS, MISOControlEnv
from ios_uav_env.envs.row_protocol import row_seeds


class MISOControlVectorEnv(gym.vector.VectorEnv):
    """``num_envs`` rows of ``MISOControlEnv(**kwargs)`` (see the module's docstring).

    Arguments: the single env's keywords plus ``num_envs`` and ``autoreset_mode`` ("next_step"
    or "same_step"). No rendering (``render_mode=None``)."""

    metadata = BatchedEnv.metadata
    info_keys = INFO_KEYS  # the keys of ``info`` (before the ``_key`` masks), as the other batched envs'

    def __init__(
        self, num_envs: int = 1, *, autoreset_mode: Any = "next_step", render_mode: None = None, **kwargs: Any
    ) -> None:
        check_batch(self, num_envs, autoreset_mode, render_mode)
        self.envs = [MISOControlEnv(**kwargs) for _ in range(self.num_envs)]
        template = self.envs[0]
        self.single_observation_space = template.observation_space
        self.single_action_space = template.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_names = template.observation_names
        self._autoreset = np.zeros(self.num_envs, dtype=np.bool_)
        self._started = False

    def reset(
        self, *, seed: int | Sequence[int] | None = None, options: Mapping[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        seeds = row_seeds(seed, self.num_envs)
        if options:
            raise ValueError(f"options must be None or empty (this env takes none), got {options!r}")
        rows = [env.reset(seed=s) for env, s in zip(self.envs, seeds, strict=True)]
        self._autoreset[:] = False
        self._started = True
        return np.stack([obs for obs, _ in rows]), self._stack([info for _, info in rows])

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if not self._started:
            raise RuntimeError("call reset() before step()")
        a = np.asarray(actions)
        if a.shape != self.action_space.shape:
            raise ValueError(
                f"actions must have shape {self.action_space.shape} (num_envs, A), got {a.shape}"
            )
        b = self.num_envs
        obs = np.empty((b, *self.single_observation_space.shape), dtype=np.float32)
        reward, terminated = np.zeros(b), np.zeros(b, dtype=np.bool_)
        infos: list[dict[str, Any]] = []
        final_obs, final_infos = [None] * b, [None] * b
        for i, env in enumerate(self.envs):
            if self._autoreset[i]:  # NEXT_STEP: the row's new episode starts instead of a step
                obs[i], info = env.reset()
            else:
                obs[i], reward[i], terminated[i], _, info = env.step(a[i])
                if self.same_step and terminated[i]:
                    final_obs[i], final_infos[i] = obs[i].copy(), info
                    obs[i], info = env.reset()
            infos.append(info)
        truncated = np.zeros(b, dtype=np.bool_)
        out = self._stack(infos)
        if self.same_step:
            self._autoreset[:] = False
            ended = terminated.copy()
            last = self._stack([f if f is not None else i for f, i in zip(final_infos, infos, strict=True)])
            stacked = np.stack([f if f is not None else o for f, o in zip(final_obs, obs, strict=True)])
            out.update(final_obs=stacked, _final_obs=ended, final_info=last, _final_info=ended.copy())
        else:
            self._autoreset = terminated.copy()
        return obs, reward, terminated, truncated, out

    def _stack(self, infos: list[dict[str, Any]]) -> dict[str, Any]:
        """The rows' ``info`` dicts as one dict of arrays (row b in row b), then the ``_key`` masks."""
        out: dict[str, Any] = {key: np.stack([np.asarray(info[key]) for info in infos]) for key in INFO_KEYS}
        out.update({f"_{key}": np.ones(self.num_envs, dtype=np.bool_) for key in INFO_KEYS})
        return out

    def close(self, **kwargs: Any) -> None:
        for env in self.envs:
            env.close()
