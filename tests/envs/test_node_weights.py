"""The batched multi-node env's moving rows compute each slot's node kernels in the row
(ios_uav_env/envs/node_weights.py): bit for bit the kernels ``channel.path_kernels`` builds on the
true paths (the old path: the track's kernels, gathered per step), rows of different surfaces side
by side; the lazily built track equals ``start_nodes_track``'s; a row the compiled weights do not
take keeps its track's kernels, and the batch still equals its single envs."""

from __future__ import annotations

import numpy as np
import pytest

from ios_uav_env.envs import node_weights
from ios_uav_env.envs.knowledge import start_nodes_track
from ios_uav_env.envs.multi_vector import MultiNodeVectorEnv
from ios_uav_env.envs.node_weights import NodeWeights, start_bare_track
from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model.channel import path_kernels
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.node_kernels import kernel_width
from ios_uav_env.model.scenarios import ScenarioRanges
from tests.envs.batch_rows import CASES, same
from tests.envs.test_nodes_kernels import check_rows

needs_numba = pytest.mark.skipif(not HAVE_NUMBA, reason="the compiled weights need numba")
WALK = {"kind": "gauss_markov"}


def batch(rows: int = 8, seed: int = 3) -> MultiNodeVectorEnv:
    """A reset batch of moving rows whose drawn surfaces differ (several projections side by side)."""
    ranges = ScenarioRanges(T=(40.0, 60.0), ios_rows=(12, 40), base=ScenarioConfig(motion=WALK))
    vec = MultiNodeVectorEnv(rows, random_nodes=(2, 4), ranges=ranges, knowledge="reports")
    vec.reset(seed=seed)
    return vec


@needs_numba
def test_each_slots_kernels_are_path_kernels_bit_for_bit():
    vec = batch()
    rows = vec.rows
    weights, kernels = rows._weights, rows.kernel_rows
    b = vec.num_envs
    assert (weights.slots > 0).all()
    assert len(set(weights.which.tolist())) > 1  # (rows of different projections, interleaved)
    configs = [env.config for env in vec.envs]
    for config in configs:
        assert weights.width(config) == kernel_width(config)
    # the reference: each node's path_kernels on its true path (the old track's kernels)
    refs = [
        [path_kernels(c.node_config(k), vec.envs[i].track.paths[:, k]) for k in range(c.K)]
        for i, c in enumerate(configs)
    ]
    state = kernels.state.copy()
    nodes, params = kernels.nodes.copy(), kernels.params.copy()
    every = np.arange(b, dtype=np.int64)
    for slot in range(max(c.N for c in configs)):
        if slot == 0:
            weights.put(every, state, -1, nodes, params)
        else:
            state[:, 2] = slot - 1
            weights.put(every, state, 1, nodes, params)
        for i, c in enumerate(configs):
            if slot >= c.N:
                continue
            q = kernel_width(c)
            for k in range(c.K):
                ref_nodes, ref_params = refs[i][k]
                assert same(nodes[i, k, :, :q], ref_nodes[slot]), (slot, i, k)
                assert same(params[i, k], ref_params[slot]), (slot, i, k)
                assert (nodes[i, k, 2, q:] == 0.0).all()  # (padding: zero weight)


@needs_numba
def test_a_row_at_its_episodes_end_is_left_as_it_is():
    vec = batch(rows=3)
    rows = vec.rows
    weights, kernels = rows._weights, rows.kernel_rows
    state = kernels.state.copy()
    state[:, 2] = weights.slots - 1  # (every row at its last slot: no slot to fly to)
    nodes, params = kernels.nodes.copy(), kernels.params.copy()
    weights.put(np.arange(3, dtype=np.int64), state, 1, nodes, params)
    assert same(nodes, kernels.nodes) and same(params, kernels.params)


def test_the_bare_track_is_start_nodes_tracks():
    config = ScenarioConfig(motion=WALK, ground_nodes=((40.0, 30.0), (-50.0, 60.0), (90.0, -20.0)), T=40.0)
    before, after = np.random.default_rng(5), np.random.default_rng(5)
    full = start_nodes_track(config, before, 3.0, 70)
    bare = start_bare_track(config, after, 3.0, 70)
    assert before.bit_generator.state == after.bit_generator.state  # (the same draws)
    for name in ("paths", "lo", "hi", "reports", "measured", "tally"):
        assert same(getattr(bare, name), getattr(full, name)), name
    assert bare.held == ()  # (nothing built before a read)
    assert same(bare.nodes, full.nodes) and same(bare.params, full.params)
    assert len(bare.held) == config.K
    with pytest.raises(AttributeError):
        bare.nodes = full.nodes


@needs_numba
@pytest.mark.parametrize("kwargs", [CASES[0], CASES[2], CASES[1]])
def test_rows_the_compiled_weights_do_not_take_keep_their_tracks(kwargs, monkeypatch):
    load = NodeWeights.load
    refused: list[int] = []

    def every_other(self, i, config, paths, nodes):  # (odd rows: as if their surface were not interpolated)
        if i % 2:
            self.slots[i] = 0
            refused.append(i)
            return False
        return load(self, i, config, paths, nodes)

    monkeypatch.setattr(node_weights.NodeWeights, "load", every_other)
    assert check_rows(kwargs, rows=4) > 0
    assert refused


@needs_numba
def test_the_batch_equals_its_single_envs_with_the_compiled_weights():
    # (the rows of test_nodes_kernels' check: surfaces of 48, 64 and 40 nodes, all compiled)
    assert check_rows({"knowledge": "reports"}, rows=5, seed=4) > 0


@needs_numba
def test_the_blocks_on_numbas_threads_give_the_serial_kernels():
    vec = batch(rows=24, seed=6)
    rows = vec.rows
    weights, kernels = rows._weights, rows.kernel_rows
    every = np.arange(vec.num_envs, dtype=np.int64)
    for slot in range(1, 30, 7):
        state = kernels.state.copy()
        state[:, 2] = slot
        serial = kernels.nodes.copy(), kernels.params.copy()
        threaded = kernels.nodes.copy(), kernels.params.copy()
        weights.put(every, state, 1, *serial)
        weights.put(every, state, 1, *threaded, num_threads=2)
        assert same(serial[0], threaded[0]) and same(serial[1], threaded[1])
        assert not same(serial[0], kernels.nodes)  # (the slot's kernels were put)
