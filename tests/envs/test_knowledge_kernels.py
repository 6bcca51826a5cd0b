"""The moving-node batched env's compiled observation (ios_uav_env/envs/knowledge_kernels.py)
equals the single env's per-row path (knowledge.observe_slot) bit for bit: observations, reports,
measured rates and the filtered estimates, across episode ends; compiled and plain Python."""

from __future__ import annotations

import numpy as np
import pytest

from ios_uav_env.envs.random_env import RandomIOSUAVEnv
from ios_uav_env.envs.single_vector import RandomIOSUAVVectorEnv
from tests.envs.batch_rows import CASES, same, step_batch_and_singles
from tests.processes import run_without_numba


def check_rows(kwargs: dict, rows: int = 3, steps: int = 90, seed: int = 11) -> int:
    """Step a batch and its rows' single envs with the same actions (the singles reset as the
    batch's NEXT_STEP autoreset does) and assert every output and track record equal bit for
    bit; returns the number of episode ends seen."""
    kwargs = {"ranges": {"T": (40.0, 60.0)}, "motion": {"kind": "gauss_markov"}, **kwargs}
    vec = RandomIOSUAVVectorEnv(rows, **kwargs)
    singles = [RandomIOSUAVEnv(**kwargs) for _ in range(rows)]
    actions = np.random.default_rng(seed).uniform(-1.2, 1.2, (steps, rows, 2))
    obs, _ = vec.reset(seed=seed)
    for i, env in enumerate(singles):
        assert same(env.reset(seed=seed + i)[0], obs[i])
    records = ("reports", "measured")
    return step_batch_and_singles(vec, singles, actions, records, bool(kwargs.get("filter_estimate")))


@pytest.mark.parametrize("kwargs", CASES)
def test_compiled_observation_equals_the_per_row_path(kwargs):
    assert check_rows(kwargs) > 0  # (the episodes end: the autoreset's observations are compared too)


def test_plain_python_observation_equals_the_per_row_path():
    """Under IOS_UAV_ENV_NO_NUMBA=1 (plain-Python kernels) the batch equals its singles too."""
    code = (
        "import runpy, ios_uav_env.jit as j\n"
        "assert not j.HAVE_NUMBA\n"
        f"check = runpy.run_path({__file__!r})['check_rows']\n"
        f"for kwargs in {CASES!r}:\n"
        "    assert check(kwargs, rows=2, steps=60) > 0\n"
    )
    run_without_numba(code)


def test_one_call_of_four_normals_is_two_calls_of_two():
    """The batch draws a slot's report and measured-rate normals in one call per row: numpy's
    Generator gives one call of four the stream of two calls of two (and ``out=`` the same)."""
    a, b, c = (np.random.default_rng(3) for _ in range(3))
    out = np.zeros((2, 4))
    for _ in range(5):
        c.standard_normal(out=out[1, :4])
        one = a.standard_normal(4)
        assert same(one, np.concatenate([b.standard_normal(2), b.standard_normal(2)]))
        assert same(one, out[1])
