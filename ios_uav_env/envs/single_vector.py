"""The v0 view batched: ``IOSUAVVectorEnv`` and ``RandomIOSUAVVectorEnv``, presets of ``UAVVectorEnv``.

``gym.make_vec(id, num_envs=B, vectorization_mode="vector_entry_point")`` returns a
``UAVVectorEnv`` (``ios_uav_env.envs.core.vector``) for every id; these classes make the same
batched env for code that names them: ``IOSUAVVectorEnv`` the fixed single-node ids' (the view
``"v0"``), ``RandomIOSUAVVectorEnv`` the randomised ones' (``draws=True``; ``ranges`` its first
argument after ``num_envs``). The rows are ``single_rows.SingleNodeRows``: the kernels of
``single_kernels``, the ones the single env runs on a batch of one, on B rows, so row i is the
single env reset with seed ``seed + i`` (tested). ``info`` is a dict of arrays (``INFO_KEYS``,
``position`` of shape (B, 2)) with Gymnasium's ``_key`` masks (all True: every row has every key).
"""

from __future__ import annotations

from typing import Any

from ios_uav_env.envs.batched import AUTORESET_MODES, check_threads
from ios_uav_env.envs.core.vector import UAVVectorEnv

__all__ = ["AUTORESET_MODES", "IOSUAVVectorEnv", "RandomIOSUAVVectorEnv", "check_threads"]


class IOSUAVVectorEnv(UAVVectorEnv):
    """``num_envs`` episodes of :class:`~ios_uav_env.envs.single.IOSUAVEnv`: ``UAVVectorEnv`` with
    the view ``"v0"``. Arguments: the single env's (``config``, ``EnvOptions`` and
    ``ScenarioConfig`` keywords) plus ``num_envs``, ``autoreset_mode`` and ``num_threads``."""

    def __init__(self, num_envs: int = 1, config: Any = None, **kwargs: Any):
        super().__init__(num_envs, config, view="v0", **kwargs)


class RandomIOSUAVVectorEnv(UAVVectorEnv):
    """``num_envs`` episodes of :class:`~ios_uav_env.envs.random_env.RandomIOSUAVEnv`: every row
    draws its own scenarios (row i as the single env seeded ``seed + i``); ``UAVVectorEnv`` with the
    view ``"v0"`` and ``draws=True``. Arguments: the single env's (``ranges``, ``focus``, ...) plus
    ``num_envs``."""

    def __init__(self, num_envs: int = 1, ranges: Any = None, **kwargs: Any):
        super().__init__(num_envs, view="v0", draws=True, ranges=ranges, **kwargs)
