"""Each node's rate kernel without a config per node (ios_uav_env/model/node_kernels.py), and the
multi-node draw that makes one config (``scenarios.sample_multinode``)."""

from __future__ import annotations

import numpy as np

from ios_uav_env.model.channel import rate_kernel
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.node_kernels import kernel_config, node_kernels
from ios_uav_env.model.scenarios import (
    MULTINODE_RANGES,
    ScenarioRanges,
    _off_plane,
    sample_multinode,
    sample_scenario,
)


def _per_node(config: ScenarioConfig) -> tuple[np.ndarray, np.ndarray]:
    kernels = [rate_kernel(config.node_config(k)) for k in range(config.K)]
    return np.stack([k.nodes for k in kernels]), np.stack([k.params for k in kernels])


def test_node_kernels_are_each_nodes_rate_kernel_bit_for_bit():
    rng = np.random.default_rng(0)
    configs = [sample_multinode(rng, nodes=(1, 5)) for _ in range(40)]
    configs += [c.replace(surface="none") for c in configs[:4]]
    configs += [
        c.replace(alpha=2.4, uav_altitude=140.0, quadrature_nodes=5) for c in configs[:6]
    ]  # other geometries
    for config in configs:
        nodes, params = node_kernels(config)
        expected_nodes, expected_params = _per_node(config)
        assert np.array_equal(nodes, expected_nodes) and np.array_equal(params, expected_params)


def test_one_kernel_config_serves_every_draw_of_a_geometry_and_no_other():
    rng = np.random.default_rng(1)
    a, b = (sample_multinode(rng, ScenarioRanges(T=(100.0, 200.0), surfaces=("ios",), ios_rows=(30, 30)))
            for _ in range(2))  # fmt: skip
    assert a.nodes != b.nodes and kernel_config(a) is kernel_config(b)
    other = b.replace(epsilon=0.3)
    assert kernel_config(other) is not kernel_config(b)
    assert np.array_equal(node_kernels(other)[0], _per_node(other)[0])
    single = sample_scenario(rng)
    assert kernel_config(single) is single


def test_the_multinode_draw_is_the_scenario_draw_with_its_nodes():
    for nodes in ((2, 4), (1, 1), (3, 8)):
        ours, theirs = np.random.default_rng(5), np.random.default_rng(5)
        for _ in range(30):
            config = sample_multinode(ours, MULTINODE_RANGES, nodes)
            # the draw as two configs: K and the nodes, then sample_scenario's draws, whose G is replaced
            k = int(theirs.integers(nodes[0], nodes[1], endpoint=True))
            r = MULTINODE_RANGES
            points = [
                (float(theirs.uniform(*r.ground_x)), float(theirs.uniform(*r.ground_y))) for _ in range(k)
            ]
            drawn = sample_scenario(theirs, r)
            expected = drawn.replace(ground_nodes=tuple(_off_plane(p, r.base, drawn.surface) for p in points))
            assert config == expected and config.K == k


def test_the_scenario_draw_is_the_stream_of_scalar_draws():
    """``sample_scenario`` (one config made from ``_draw``'s changes) draws as documented: one
    scalar draw each, in order, and the generator's state after them (the scenarios of every seed)."""
    ranges = ScenarioRanges(T=(40.0, 80.0), start_x=(-450.0, -350.0), end_y=(5.0, 5.0))
    for seed in range(40):
        ours, theirs = np.random.default_rng(seed), np.random.default_rng(seed)
        config = sample_scenario(ours, ranges)
        ground = (float(theirs.uniform(*ranges.ground_x)), float(theirs.uniform(*ranges.ground_y)))
        slots = int(theirs.integers(*ranges.slot_range, endpoint=True))
        rows = int(theirs.integers(*ranges.ios_rows, endpoint=True))
        surface = ranges.surfaces[int(theirs.integers(len(ranges.surfaces)))]
        ends = [
            float(theirs.uniform(*p)) for p in (ranges.start_x, ranges.start_y, ranges.end_x, ranges.end_y)
        ]
        expected = ranges.base.replace(
            ground_node=ground, T=slots * ranges.base.dt, ios_shape=ranges.shape(rows), surface=surface,
            q0=tuple(ends[:2]), qF=tuple(ends[2:]),
        )  # fmt: skip
        assert config == expected and ours.uniform() == theirs.uniform()
