"""The moving-node batched env's compiled observation (ios_uav_env/envs/knowledge_kernels.py)
equals the single env's per-row path (knowledge.observe_slot) bit for bit: observations, reports,
measured rates and the filtered estimates, across episode ends; compiled and plain Python."""

from __future__ import annotations

import numpy as np
import pytest

from ios_uav_env.envs.knowledge_kernels import EpisodeDraws
from ios_uav_env.envs.random_env import RandomIOSUAVEnv
from ios_uav_env.envs.single_vector import RandomIOSUAVVectorEnv
from tests.envs.batch_rows import CASES, cut_episodes, same, step_batch_and_singles
from tests.processes import run_without_numba


def check_rows(kwargs: dict, rows: int = 3, steps: int = 90, seed: int = 11, cut: bool = False) -> int:
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
    if cut:  # (episodes cut short by a restart and a reset without a seed)
        cut_episodes(vec, singles, actions, records, bool(kwargs.get("filter_estimate")))
        return 0
    return step_batch_and_singles(vec, singles, actions, records, bool(kwargs.get("filter_estimate")))


@pytest.mark.parametrize("kwargs", CASES)
def test_compiled_observation_equals_the_per_row_path(kwargs):
    assert check_rows(kwargs) > 0  # (the episodes end: the autoreset's observations are compared too)


@pytest.mark.parametrize("kwargs", CASES)
def test_episodes_cut_short_leave_each_rows_generator_as_its_single_envs(kwargs):
    check_rows(kwargs, steps=10, cut=True)


def test_an_episodes_draw_is_its_slots_draws_and_a_cut_one_rewinds():
    """``EpisodeDraws``: one draw of n slots x d normals hands out the stream of n calls of d, slot by
    slot; rewinding after k slots leaves the generator as k calls of d would (a seeded reset, or an
    episode that took every slot, leaves it as it is)."""
    draws = EpisodeDraws(3, 2, 4)
    for taken, seed, slots in ((2, None, 5), (5, None, 5), (1, 9, 5)):
        mine, theirs = np.random.default_rng(4), np.random.default_rng(4)
        mine.random(), theirs.random()  # (the episode's draws come after the scenario's)
        draws.draw(1, mine, slots, 3)  # (more slots than the array had: it grows)
        out = np.zeros((3, 4))
        for slot in range(taken):
            draws.take(np.array([1]), np.array([slot]), out)
            assert same(out[1, :3], theirs.standard_normal(3)) and not out[1, 3]
        draws.rewind(np.array([1]), [seed])
        if seed is None:
            assert mine.random() == theirs.random()
        else:  # (the generator is replaced by the seeded reset: left where the draw left it)
            theirs.standard_normal(3 * (slots - taken))
            assert mine.random() == theirs.random()
        assert not draws.width[1]


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
