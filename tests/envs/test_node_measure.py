"""The batched multi-node env's measured rates on numba's threads (ios_uav_env/envs/node_measure.py)
equal the serial kernel's bit for bit: every served node's record and told rate of each row
asked, rows of both kinds (kernels computed in the row, or the track's), nothing else written.
(The serial kernel and the threaded default equal the single envs: test_node_weights, test_multi*.)"""

from __future__ import annotations

import numpy as np
import pytest

from ios_uav_env.envs import node_weights
from ios_uav_env.envs.knowledge_kernels import row_list
from ios_uav_env.envs.multi_vector import MultiNodeVectorEnv
from ios_uav_env.envs.node_measure import measure_node_rates, measure_rows
from ios_uav_env.envs.node_weights import NodeWeights
from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.scenarios import ScenarioRanges
from tests.envs.batch_rows import same
from tests.envs.test_nodes_kernels import WIDTHS

needs_numba = pytest.mark.skipif(not HAVE_NUMBA, reason="the compiled weights need numba")


def measure(
    vec: MultiNodeVectorEnv, rows: np.ndarray, num_threads: int
) -> tuple[list[np.ndarray], np.ndarray]:
    """The measured rates of ``rows`` in the batch's current slots, into copies of its records and
    a told array of -1 (serial kernel, or ``measure_rows`` on ``num_threads`` threads)."""
    r = vec.rows
    w = r._weights
    measured = row_list(np.zeros((1, 1)), vec.num_envs)
    for i, record in enumerate(r._track_measured):
        measured[i] = record.copy()
    told = np.full_like(r._told, -1.0)
    args = (rows, r._rows.state, r._rows.shares, r._k, w.widths, w.slots, measured, r._track_nodes,
            r._track_params, r._rows.nodes, r._rows.params, r._slot_normals, r._knowledge == 1,
            r._rate_high, told)  # fmt: skip
    if num_threads == 1:
        measure_node_rates(*args)
    else:
        measure_rows(num_threads, *args)
    return list(measured), told


@needs_numba
@pytest.mark.parametrize("knowledge", ["reports", "rates"])
def test_the_rows_on_numbas_threads_give_the_serial_kernels(knowledge, monkeypatch):
    load = NodeWeights.load

    def every_third(self, i, config, paths, nodes):  # (as if their surface were not interpolated)
        if i % 3 == 1:
            self.slots[i] = 0
            return False
        return load(self, i, config, paths, nodes)

    monkeypatch.setattr(node_weights.NodeWeights, "load", every_third)
    walk = {"kind": "gauss_markov"}
    ranges = ScenarioRanges(T=(40.0, 60.0), ios_rows=(20, 30), base=ScenarioConfig(motion=walk))
    vec = MultiNodeVectorEnv(12, random_nodes=(2, 4), ranges=ranges, knowledge=knowledge, num_threads=1)
    grounds = ((40.0, 30.0), (-50.0, 60.0), (90.0, -20.0), (10.0, -70.0))
    configs = [
        ranges.base.replace(T=40.0, ground_nodes=grounds[: 2 + i % 3], **WIDTHS[i % len(WIDTHS)])
        for i in range(vec.num_envs)
    ]  # (pinned scenarios of three surface widths: the rows load them through NodeWeights.load)
    vec.reset(seed=5, options={"configs": configs})
    weights = vec.rows._weights
    assert (weights.slots > 0).any() and (weights.slots == 0).any()  # (rows of both kinds)
    draw = np.random.default_rng(5)
    rows = np.array([7, 0, 10, 3, 4, 9, 1, 6], dtype=np.int64)  # (some rows, out of order)
    others = np.setdiff1d(np.arange(vec.num_envs), rows)
    rates = 0
    for _ in range(25):
        vec.step(draw.uniform(-1.0, 1.0, vec.action_space.shape))
        serial, told = measure(vec, rows, 1)
        threaded, told_threaded = measure(vec, rows, 2)
        assert same(told, told_threaded)
        assert all(same(a, b) for a, b in zip(serial, threaded, strict=True))
        assert (told[others] == -1.0).all()  # (rows not asked: nothing written)
        # (the serial kernel measures again what the batch's step measured)
        assert all(same(serial[i], vec.rows._track_measured[i]) for i in rows.tolist())
        rates += int(np.isfinite(told[rows]).sum() - (told[rows] == -1.0).sum())
    assert rates > 100
