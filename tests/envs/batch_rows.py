"""What the batch-equals-singles tests of the moving-node batched envs share
(tests/envs/test_knowledge_kernels.py: one node, tests/envs/test_nodes_kernels.py: K nodes): the
knowledge cases, the bit-for-bit comparison and the loop that steps a batch and its rows' single
envs with the same actions and compares them."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.mobility import GaussMarkov
from ios_uav_env.model.scenarios import ScenarioRanges
from tests.tolerances import BATCH_MEASURED_REL

#: The moving nodes' knowledge settings both tests run.
CASES = [
    {"knowledge": "reports"},
    {"knowledge": "reports", "filter_estimate": True},
    {"knowledge": "rates"},
    {"knowledge": "exact"},
    {"knowledge": "exact", "channel": "rician"},
    {"knowledge": "reports", "report_sigma": 40.0, "filter_estimate": True},
]


def same(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal bit for bit (NaN where the other is NaN)."""
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def close(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal to ``BATCH_MEASURED_REL`` relative (NaN where the other is NaN; shape and dtype alike)."""
    return (
        a.shape == b.shape and a.dtype == b.dtype
        and bool(np.allclose(a, b, rtol=BATCH_MEASURED_REL, atol=0.0, equal_nan=True))
    )  # fmt: skip


def step_batch_and_singles(
    vec: Any,
    singles: Sequence[Any],
    actions: Iterable[np.ndarray],
    records: Sequence[str],
    filtered: bool,
    rounded: Sequence[str] = (),
) -> int:
    """Step the batch ``vec`` and its rows' single envs ``singles`` (both just reset alike) with
    each (B, A) array of ``actions`` in turn, the singles reset as the batch's NEXT_STEP autoreset
    does, and assert after every step: each row's observation equal bit for bit, its reward to
    1e-9 (the step kernel's, not the observation's: the batch's parallel kernel and the single
    env's agree to rounding, as test_single_vector and test_multi_vector check), its track's
    ``records`` equal bit for bit (those also in ``rounded``: to ``BATCH_MEASURED_REL``, the
    multi-node rows' measured rates and tally, taken from the step's node rates) and, when
    ``filtered``, its Kalman filter's position. Returns the number of episode ends seen."""
    pending, ends = [False] * len(singles), 0
    for t, step in enumerate(actions):
        obs, reward, _, _, _ = vec.step(step)
        for i, env in enumerate(singles):
            if pending[i]:
                o, r = env.reset()[0], 0.0
                pending[i] = False
            else:
                o, r, term, _, _ = env.step(step[i])
                pending[i], ends = term, ends + term
            assert same(o, obs[i]), (t, i, o, obs[i])
            assert abs(r - reward[i]) <= 1e-9
            mine, theirs = vec.envs[i].track, env.track
            for name in records:
                equal = close if name in rounded else same
                assert equal(getattr(mine, name), getattr(theirs, name)), (t, i, name)
            if filtered:
                assert same(mine.filter.position, theirs.filter.position)
    return ends


def cut_episodes(
    vec: Any,
    singles: Sequence[Any],
    actions: Iterable[np.ndarray],
    records: Sequence[str],
    filtered: bool,
    rounded: Sequence[str] = (),
) -> None:
    """After the batch and its singles were reset alike: step them, restart row 0 (its single env's
    ``reset()``), step, reset every row without a seed, step, comparing as
    :func:`step_batch_and_singles` does. Each cut episode has drawn only part of its slots' normals
    (the batch draws an episode's at its start): the next episode must see each row's generator
    as the single env leaves it."""
    steps = iter(actions)
    step_batch_and_singles(vec, singles, [next(steps) for _ in range(4)], records, filtered, rounded)
    obs = vec.restart([0])
    assert same(singles[0].reset()[0], obs[0])
    step_batch_and_singles(vec, singles, [next(steps) for _ in range(3)], records, filtered, rounded)
    obs, _ = vec.reset()
    for i, env in enumerate(singles):
        assert same(env.reset()[0], obs[i]), i
    step_batch_and_singles(vec, singles, [next(steps) for _ in range(3)], records, filtered, rounded)


#: The message of a drawn node outside its motion rectangle (``mobility.rectangles``).
OUTSIDE = "starts outside its motion rectangle"


def refused_ranges() -> Any:
    """Ranges that check out at construction (their corners) but some of whose draws the config
    refuses (a node drawn outside its motion box: forced after construction)."""
    good = ScenarioRanges(
        ground_y=(-40.0, 40.0), T=(40.0, 60.0), ios_rows=(20, 20), surfaces=("ios",),
        base=ScenarioConfig(motion=GaussMarkov(box=((-300.0, 300.0), (-50.0, 50.0)))),
    )  # fmt: skip
    bad = dataclasses.replace(good)
    object.__setattr__(bad, "ground_y", (-40.0, 150.0))  # (what construction would have refused)
    return bad


def refused_after(single: Any, tries: int = 200) -> int:
    """The first seed s whose reset of the env ``single`` passes and whose s + 1's raises the
    config's :data:`OUTSIDE` error (a batch reset with seed s refuses its row 1, not its row 0)."""

    def refused(seed: int) -> bool:
        try:
            single.reset(seed=seed)
        except ValueError as err:
            assert OUTSIDE in str(err)
            return True
        return False

    return next(s for s in range(tries) if not refused(s) and refused(s + 1))
