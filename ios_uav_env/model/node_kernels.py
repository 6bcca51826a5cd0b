"""The rate kernels of a scenario's K ground nodes, without a config per node.

Node k's rate r_k is the single-node model of ``config.node_config(k)`` (G = w_k), whose
kernel is ``channel.rate_kernel(config.node_config(k))``. Only the surface weights and G's
coordinates and side depend on G (``channel.path_kernels``), so :func:`node_kernels` takes
every node's kernel from one single-node config of the same kernel geometry
(:func:`kernel_config`): the first node's config of the first scenario seen with those fields,
reused by every scenario that differs from it only in the fields a draw changes
(:data:`DRAWN_FIELDS`: the nodes, T, q0, qF; none enters a rate). A randomised multi-node env
then makes no config per node at each reset. The arrays equal the per-node kernels bit for bit
(tested).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ios_uav_env.model.channel import path_kernels, rate_kernel
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.rate_kernels import DRAWN_FIELDS

__all__ = ["CACHE_SIZE", "DRAWN_FIELDS", "kernel_config", "kernel_width", "node_kernels"]
_KEY_FIELDS: tuple[str, ...] = tuple(
    f.name for f in dataclasses.fields(ScenarioConfig) if f.name not in DRAWN_FIELDS
)
#: Kernel geometries held at most (a family draws a handful: surfaces x IOS rows).
CACHE_SIZE = 256
_CONFIGS: dict[tuple, ScenarioConfig] = {}


def kernel_config(config: ScenarioConfig) -> ScenarioConfig:
    """A single-node config whose rate kernel with G moved to w_k is node k's of ``config``:
    ``config`` itself for one node, else the first node's config of the first scenario seen
    with ``config``'s fields outside :data:`DRAWN_FIELDS` (held in a cache of
    :data:`CACHE_SIZE`)."""
    if config.K == 1:
        return config
    key = tuple(getattr(config, name) for name in _KEY_FIELDS)
    held = _CONFIGS.get(key)
    if held is None:
        if len(_CONFIGS) >= CACHE_SIZE:
            _CONFIGS.clear()
        held = _CONFIGS[key] = config.node_config(0)
    return held


def kernel_width(config: ScenarioConfig) -> int:
    """Q, the surface nodes of each node's rate kernel of ``config`` (the width of
    :func:`node_kernels`' and of its nodes' ``path_kernels``), without projecting the surface."""
    return int(rate_kernel(kernel_config(config)).nodes.shape[1])


def node_kernels(config: ScenarioConfig) -> tuple[np.ndarray, np.ndarray]:
    """(``nodes`` (K, 3, Q), ``params`` (K, P)): row k the ``RateKernel.nodes`` and ``.params`` of
    ``rate_kernel(config.node_config(k))``, bit for bit (``channel.path_kernels`` of
    :func:`kernel_config` at the K nodes; one node: its own kernel)."""
    if config.K == 1:
        kernel = rate_kernel(config)
        return kernel.nodes[None], kernel.params[None]
    return path_kernels(kernel_config(config), np.asarray(config.nodes, dtype=np.float64))
