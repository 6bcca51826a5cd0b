"""``jit.run_halves``: a per-row function split in two calls on the halves of its rows, one on a
helper thread, where two or more threads are asked for and the rows are many; one call otherwise."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from ios_uav_env import jit
from ios_uav_env.jit import FEW_EPISODES, FEW_ROWS, HAVE_NUMBA, run_halves, threads_for

pytestmark = pytest.mark.skipif(not HAVE_NUMBA, reason="without numba every batched call is one call")


def recorder() -> tuple[list[tuple[list[int], int]], object]:
    calls: list[tuple[list[int], int]] = []

    def function(rows: np.ndarray, out: np.ndarray, add: float) -> None:
        calls.append((rows.tolist(), threading.get_ident()))
        out[rows] += add

    return calls, function


def test_many_rows_on_two_threads_run_as_two_halves_at_once():
    calls, function = recorder()
    rows, out = np.arange(FEW_ROWS + 1), np.zeros(FEW_ROWS + 1)
    run_halves(function, rows, 2, out, 1.5)
    half = rows.size // 2
    assert sorted(part for part, _ in calls) == [rows[:half].tolist(), rows[half:].tolist()]
    idents = {ident for _, ident in calls}
    assert len(idents) == 2 and threading.get_ident() in idents  # (one half on the caller's thread)
    assert (out == 1.5).all()


@pytest.mark.parametrize(("size", "threads"), [(FEW_ROWS + 1, 1), (FEW_ROWS - 1, 2)])
def test_one_thread_or_few_rows_is_one_call(size, threads):
    calls, function = recorder()
    rows, out = np.arange(size), np.zeros(size)
    run_halves(function, rows, threads, out, 2.0)
    assert calls == [(rows.tolist(), threading.get_ident())] and (out == 2.0).all()


def test_an_error_of_the_helpers_half_is_raised_after_both_ran():
    done = []

    def function(rows: np.ndarray) -> None:
        if rows[0] == 0:
            raise ValueError("first half")
        done.append(rows.size)

    with pytest.raises(ValueError, match="first half"):
        run_halves(function, np.arange(2 * FEW_ROWS), 2)
    assert done == [FEW_ROWS]


def test_a_forked_process_makes_its_own_helper(monkeypatch):
    monkeypatch.setattr(jit, "_helper", jit._helper)  # (restored after)
    first = jit._helper_thread()
    assert jit._helper_thread() is first
    monkeypatch.setattr(jit.os, "getpid", lambda: -1)
    assert jit._helper_thread() is not first


def test_episodes_split_from_fewer_rows():
    calls, function = recorder()
    run_halves(function, np.arange(FEW_EPISODES), 2, np.zeros(FEW_EPISODES), 1.0, episodes=True)
    assert len(calls) == 2
    calls, function = recorder()
    run_halves(function, np.arange(FEW_EPISODES - 1), 2, np.zeros(FEW_EPISODES), 1.0, episodes=True)
    assert len(calls) == 1


def test_few_rows_take_one_thread():
    assert threads_for(2, FEW_ROWS - 1) == 1 and threads_for(None, FEW_ROWS - 1) == 1
    assert threads_for(2, FEW_ROWS) == 2 and threads_for(None, FEW_ROWS) is None
