r"""What a UAV can learn of moving nodes each slot (``docs/model.md``, "Reports and the filter").

Pure functions of the truth and a numpy ``Generator`` (the caller's, e.g. an env's RNG):

- :func:`position_reports`: every node's position with an independent Gaussian error per
  component, z_k[n] = w_k[n] + e_k[n], e_k[n] ~ N(0, s^2 I_2) (s = ``REPORT_SIGMA`` m by
  default): a GPS-like report;
- :func:`measured_rates`: the rate the served node measures in its slot, one faded sample
  log2(1 + eta |h|^2) of the Rician channel of eqs. (4)-(8) with the IOS phases aligned to
  that node's true channel, drawn by :func:`ios_uav_env.model.channel.faded_rates` (the
  draws of the env's ``channel="rician"``: the real, then the imaginary part of h_SS) on the
  single-node model of the node at its true position w_k[n].
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ios_uav_env.model.channel import as_positions, faded_rates
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.motion import check_paths, node_config_at

#: m, default standard deviation of each component of a position report's error.
REPORT_SIGMA = 10.0
#: A node is served in a slot (and measures its rate there) when its share exceeds this.
SERVED_SHARE = 1e-9

__all__ = ["REPORT_SIGMA", "SERVED_SHARE", "measured_rates", "position_reports"]


def _sigma(value: Any) -> float:
    if type(value) is float and 0.0 <= value < math.inf:  # (the common case, checked per slot)
        return value
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if not (number and math.isfinite(value) and value >= 0):
        raise ValueError(f"sigma must be a finite number >= 0 (m), got {value!r}")
    return float(value)


def position_reports(
    positions: np.ndarray, rng: np.random.Generator, sigma: float = REPORT_SIGMA
) -> np.ndarray:
    """Noisy reports of ``positions`` (any shape (..., 2), m): positions + sigma x standard
    normals drawn from ``rng`` in C order, same shape."""
    s = _sigma(sigma)
    w = np.asarray(positions, dtype=float)
    if w.ndim < 1 or w.shape[-1] != 2 or not np.isfinite(w).all():
        raise ValueError(f"positions must be a finite array of shape (..., 2) (m), got shape {w.shape}")
    return w + s * rng.standard_normal(w.shape)


def measured_rates(
    config: ScenarioConfig,
    trajectory: np.ndarray,
    paths: np.ndarray,
    served: np.ndarray,
    rng: np.random.Generator,
) -> np.ndarray:
    """(n,) bps/Hz: slot i's faded rate of node ``served[i]`` at its true position
    ``paths[i, served[i]]`` with the UAV at ``trajectory[i]`` (module docstring); the draws of
    slot i follow those of slot i - 1. ``paths`` is (n, K, 2), ``served`` n node indices."""
    q = as_positions(trajectory, "trajectory")
    w = check_paths(config, paths, len(q))
    k = np.asarray(served)
    if k.shape != (len(q),) or not np.issubdtype(k.dtype, np.integer) or np.any((k < 0) | (k >= config.K)):
        raise ValueError(f"served must be {len(q)} node indices in [0, {config.K - 1}], got {served!r}")
    out = np.empty(len(q))
    for i in range(len(q)):
        node = node_config_at(config, int(k[i]), w[i, k[i]])
        out[i] = faded_rates(node, q[i : i + 1], rng)[0]
    return out
