"""The batched multi-node env's compiled moving-node calls (ios_uav_env/envs/nodes_kernels.py)
equal the single env's per-row path (``MobileNodes.prepare_slot`` / ``observe_slot``,
``knowledge.observe_nodes``) bit for bit: observations, reports and the filtered estimates (the
measured rates and the served tally, taken from the step's node rates, to rounding), across
episode ends, rows of 2 to 4 nodes and of different surface widths; compiled and plain Python."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from ios_uav_env.envs.multi import MultiNodeEnv
from ios_uav_env.envs.multi_vector import MultiNodeVectorEnv
from ios_uav_env.envs.nodes_kernels import draws
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.scenarios import ScenarioRanges
from tests.envs.batch_rows import CASES, cut_episodes, same, step_batch_and_singles
from tests.processes import run_without_numba

#: Scenarios of different surface widths (an exact 60-element sum, the 64 compressed nodes)
#: pinned at the first reset: the narrower rows' kernels are padded in the batch's arrays.
WIDTHS = [{"ios_shape": (10, 6)}, {"ios_shape": (100, 20)}, {"ios_shape": (12, 5)}]
#: The records taken from the step's node rates, which the batch's parallel kernel and the single
#: env's serial one round differently in the last bits: compared to ``BATCH_MEASURED_REL``.
ROUNDED = ("measured", "tally")


def check_rows(
    kwargs: dict[str, Any], rows: int = 3, steps: int = 90, seed: int = 11, cut: bool = False
) -> int:
    """Step a batch and its rows' single envs with the same actions (the singles reset as the
    batch's NEXT_STEP autoreset does; the first reset pins scenarios of different widths) and
    assert every observation and track record equal bit for bit; the number of episode ends."""
    walk = {"kind": "gauss_markov"}
    ranges = ScenarioRanges(T=(40.0, 60.0), ios_rows=(20, 30), base=ScenarioConfig(motion=walk))
    kwargs = {"random_nodes": (2, 4), "ranges": ranges, **kwargs}
    vec = MultiNodeVectorEnv(rows, **kwargs)
    singles = [MultiNodeEnv(**kwargs) for _ in range(rows)]
    draw = np.random.default_rng(seed)
    configs = [
        ranges.base.replace(T=40.0, ground_nodes=((40.0, 30.0), (-50.0, 60.0), (90.0, -20.0))[: 2 + i % 2],
                            **WIDTHS[i % len(WIDTHS)])
        for i in range(rows)
    ]  # fmt: skip
    obs, _ = vec.reset(seed=seed, options={"configs": configs})
    for i, env in enumerate(singles):
        assert same(env.reset(seed=seed + i, options={"config": configs[i]})[0], obs[i])
    actions = (draw.uniform(-1.2, 1.2, vec.action_space.shape) for _ in range(steps))
    records, filtered = ("paths", "reports", "measured", "tally"), bool(kwargs.get("filter_estimate"))
    if cut:  # (episodes cut short by a restart and a reset without a seed)
        cut_episodes(vec, singles, actions, records, filtered, ROUNDED)
        return 0
    return step_batch_and_singles(vec, singles, actions, records, filtered, ROUNDED)


@pytest.mark.parametrize("kwargs", CASES)
def test_compiled_nodes_equal_the_per_row_path(kwargs):
    assert check_rows(kwargs) > 0  # (the episodes end: the autoreset's observations are compared too)


def test_a_row_whose_arrays_grow_mid_episode_keeps_its_tracks_kernels():
    """When another row's wider scenario grows the batch's arrays mid-episode, a row still flying
    on its narrower track swaps in and measures on its own kernels: the single env's observations
    and records bit for bit (a 48-node row still flying when a drawn 64-node scenario is loaded
    beside it)."""
    ranges = ScenarioRanges(
        T=(40.0, 60.0), ios_rows=(20, 30), base=ScenarioConfig(motion={"kind": "gauss_markov"})
    )
    kwargs = {"random_nodes": (2, 4), "ranges": ranges, "knowledge": "reports"}
    vec = MultiNodeVectorEnv(2, **kwargs)
    singles = [MultiNodeEnv(**kwargs) for _ in range(2)]
    nodes = ((40.0, 30.0), (-50.0, 60.0))
    configs = [ranges.base.replace(T=T, ground_nodes=nodes, ios_shape=(12, 5)) for T in (40.0, 60.0)]
    obs, _ = vec.reset(seed=3, options={"configs": configs})
    for i, env in enumerate(singles):
        assert same(env.reset(seed=3 + i, options={"config": configs[i]})[0], obs[i])
    draw = np.random.default_rng(3)
    actions = [draw.uniform(-1.2, 1.2, vec.action_space.shape) for _ in range(58)]
    records = ("paths", "reports", "measured", "tally")
    assert step_batch_and_singles(vec, singles, actions, records, False, ROUNDED)
    # (it flew on past the growth)
    assert vec.envs[1].track.nodes.shape[3] < vec.rows.kernel_rows.nodes.shape[3]


@pytest.mark.parametrize("kwargs", CASES)
def test_episodes_cut_short_leave_each_rows_generator_as_its_single_envs(kwargs):
    check_rows(kwargs, steps=10, cut=True)


def test_plain_python_nodes_equal_the_per_row_path():
    """Under IOS_UAV_ENV_NO_NUMBA=1 (plain-Python kernels) the batch equals its singles too."""
    code = (
        "import runpy, ios_uav_env.jit as j\n"
        "assert not j.HAVE_NUMBA\n"
        f"check = runpy.run_path({__file__!r})['check_rows']\n"
        f"for kwargs in {CASES[:3]!r}:\n"
        "    assert check(kwargs, rows=2, steps=45) > 0\n"
    )
    run_without_numba(code)


def test_a_slot_draws_the_reports_then_the_rates_normals():
    assert [draws(kind, 3) for kind in ("exact", "reports", "rates")] == [0, 12, 6]
