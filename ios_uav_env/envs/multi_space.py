"""The multi-node env's observation space: its bounds over the env's family, or over one scenario.

:func:`multinode_bounds` is ``MultiNodeEnv``'s space (and the check of a pinned scenario against
it): lengths are the largest values at q0 plus the reach (N_max - 1) D, the node features cover
where a node can be told to be (its motion rectangle and the report clip, for moving or roughly
known nodes), rates are ``ground_free_rate_bound`` (plus ``FADE_MARGIN`` for measured rates, and
for the served rates of channel "rician"), the energy features (objective
``"energy_efficiency"``) those of ``multi_energy.energy_bounds``, and every bound must be a
finite float32 (``observation.float32_bounds``).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from ios_uav_env.envs.knowledge import FADE_MARGIN, nodes_extent
from ios_uav_env.envs.knowledge import node_extent as family_extent
from ios_uav_env.envs.multi_energy import energy_bounds, fixed_reference
from ios_uav_env.envs.observation import (
    M_SCALE,
    T_SCALE,
    float32_bounds,
    ground_free_rate_bound,
    length_bounds,
    overflow_hint,
    pad,
)
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.scenarios import ScenarioRanges


def rate_high(r: ScenarioRanges, knowledge: str, faded: bool = False) -> float:
    """bps/Hz: the rate features' bound over ``r``, plus ``FADE_MARGIN`` for measured rates
    (``knowledge`` other than ``"exact"``) or faded ones (``faded``: the served rates of channel
    "rician", clipped there in the observation)."""
    rate = max(ground_free_rate_bound(c) for c in r.configs_per_surface())
    return rate + (FADE_MARGIN if knowledge != "exact" or faded else 0.0)


def multinode_bounds(env: Any, config: ScenarioConfig | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) float32 over the family of ``env`` (a ``MultiNodeEnv``: its ranges or its one
    config, with its options, ``max_nodes`` and ``observation_names``), or over ``config``;
    ``ValueError`` if a bound overflows float32, naming the field."""
    single = config if config is not None else None if env.random_nodes else env._base
    r = env.ranges if single is None else ScenarioRanges.from_config(single.node_config(0))
    base, scale = r.base, env.options.length_scale
    reach = r.max_moves * base.D
    nodes = [] if single is None else list(single.nodes)
    gx = (min([r.ground_x[0], *(p[0] for p in nodes)]), max([r.ground_x[1], *(p[0] for p in nodes)]))
    gy = (min([r.ground_y[0], *(p[1] for p in nodes)]), max([r.ground_y[1], *(p[1] for p in nodes)]))
    if env.mobile:  # where a node can be told to be (the motion rectangles and the report clip)
        sigma = env.options.report_sigma if env.options.knowledge == "reports" else 0.0
        if single is None:
            gx, gy = family_extent(dataclasses.replace(r, base=env.ranges.base), sigma)
        else:
            gx, gy = nodes_extent(single, sigma)
    points = [(r.end_x, r.end_y), ((base.ios_center[0],) * 2, (base.ios_center[1],) * 2), (gx, gy)]
    lengths = [pad(v / scale) for v in length_bounds((r.start_x, r.start_y), points, reach)]
    own, final, ios, node = lengths[0:2], lengths[2:4], lengths[4:6], lengths[6:8]
    rate = pad(rate_high(r, env.options.knowledge))
    served = pad(rate_high(r, env.options.knowledge, env.options.channel == "rician"))
    elements = max(1.0, r.ios_columns * r.ios_rows[1] / M_SCALE) * (1 + 1e-6)
    horizon = max(1.0, r.slot_range[1] * base.dt / T_SCALE) * (1 + 1e-6)
    high = [*own, *final, *ios, 1.0, 1.0, elements, 1.0, 1.0, horizon]
    low = [-h for h in high[:6]] + [0.0, -1.0, 0.0, 0.0, 0.0, 0.0]
    hint = pad(2.0 * reach / scale)  # P_k and q are both within (N_max - 1) D of q0
    for _ in range(env.max_nodes):
        high += [1.0, *node, 1.0, served, rate] + ([hint, hint, rate] if env.options.peak_hint else [])
        low += [0.0, -node[0], -node[1], -1.0, 0.0, 0.0] + (
            [-hint, -hint, 0.0] if env.options.peak_hint else []
        )

    if env.energy_objective:  # after the node blocks (multi_energy.energy_bounds)
        more_low, more_high = energy_bounds(base, rate_high(r, "exact"), fixed_reference(env.options))
        low, high = low + more_low, high + more_high

    def why(name: str, value: float) -> str:
        return overflow_hint(name, value, scale, base, fixed_reference(env.options))

    names = env.observation_names
    return float32_bounds(low, names, why), float32_bounds(high, names, why)
