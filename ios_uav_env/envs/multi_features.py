"""The multi-node env's names and maps, apart from the env: its default nodes, the names of its
observation's features (the scenario's, then each node block's; defined with the kernels' layout
in ``multi_table``), the inverse of its share map (:func:`share_scores`) and the potential of its
rate term (:func:`rate_potential`). Re-exported by ``ios_uav_env.envs.multi``, where callers
import them.
"""

from __future__ import annotations

import numpy as np

from ios_uav_env.envs.multi_kernels import soft_minimum
from ios_uav_env.envs.multi_table import BASE_FEATURES, NODE_FEATURES, NODE_PEAK_FEATURES
from ios_uav_env.model.scenarios import DEFAULT_NODES

__all__ = [
    "BASE_FEATURES", "DEFAULT_NODES", "NODE_FEATURES", "NODE_PEAK_FEATURES", "rate_potential", "share_scores",
]  # fmt: skip


def rate_potential(rates: np.ndarray, beta: float = 0.0) -> float:
    """The potential of the rate term: min_k R_k for ``beta`` = 0, else the soft minimum
    -(1/beta) log((1/K) sum_k exp(-beta R_k)), which lies in [min_k R_k, min_k R_k + log(K) /
    beta] and equals the minimum when every R_k is the same."""
    values = np.asarray(rates, dtype=np.float64)
    return soft_minimum(values, values.size, 1.0, float(beta))


def share_scores(shares: np.ndarray, sharpness: float = 5.0) -> np.ndarray:
    """Node scores in [-1, 1] whose softmax (x ``sharpness``, the env's share map) gives
    ``shares`` (K,) or (K, B): 1 for the largest share, 1 + log(alpha_k / alpha_max) /
    sharpness for the others, so exact for ratios alpha_k / alpha_max >= exp(-2 sharpness);
    smaller ones (a 0 share too) become -1. The inverse of the action's share entries."""
    alpha = np.asarray(shares, dtype=np.float64)
    bad = alpha.ndim not in (1, 2) or not np.all(np.isfinite(alpha)) or np.any(alpha < 0)
    if bad or np.any(alpha.max(axis=0) <= 0):
        raise ValueError(f"shares must be finite, >= 0 and not all 0 ((K,) or (K, B)), got {alpha!r}")
    ratio = np.maximum(alpha / alpha.max(axis=0), np.exp(-2.0 * sharpness))
    return np.clip(1.0 + np.log(ratio) / sharpness, -1.0, 1.0)
