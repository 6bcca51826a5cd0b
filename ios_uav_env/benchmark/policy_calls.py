"""How the benchmark calls a policy: its deterministic action function, its display name, and the
check of an episode seed (shared by :mod:`~ios_uav_env.benchmark.scoring` and the several-UAV
rollouts of :mod:`~ios_uav_env.benchmark.fleet_scoring`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["action_function", "check_seed", "policy_name"]


def _as_array(action: Any) -> np.ndarray:
    """An action as a numpy array (a tensor is detached and moved to the CPU first)."""
    if hasattr(action, "detach"):
        action = action.detach().cpu().numpy()
    return np.asarray(action)


def action_function(policy: Any) -> Callable[[np.ndarray], np.ndarray]:
    """The deterministic observation -> action function of ``policy`` (see the module doc)."""
    predict = getattr(policy, "predict", None)
    if callable(predict):
        return lambda obs: _as_array(predict(obs, deterministic=True)[0])
    if callable(policy):
        return lambda obs: _as_array(policy(obs))
    raise TypeError(
        f"a policy must be callable (obs -> action) or have predict(obs, deterministic=True); "
        f"got {type(policy).__name__}"
    )


def policy_name(policy: Any) -> str:
    """A display name: the policy's ``name`` attribute, else its function or class name."""
    name = getattr(policy, "name", None)
    if isinstance(name, str) and name:
        return name
    return getattr(policy, "__name__", None) or type(policy).__name__


def check_seed(seed: Any) -> None:
    """``ValueError`` unless ``seed`` is None or an integer >= 0 (a Gymnasium reset seed)."""
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0):
        raise ValueError(f"seed must be an integer >= 0 or None, got {seed!r}")
