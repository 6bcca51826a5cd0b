"""``jit.threads_for``: a batched call of fewer rows than ``jit.FEW_ROWS`` runs on the caller's thread
alone; larger calls keep the threads asked for."""

from __future__ import annotations

from ios_uav_env.jit import FEW_ROWS, threads_for


def test_few_rows_take_one_thread():
    assert threads_for(2, FEW_ROWS - 1) == 1 and threads_for(None, FEW_ROWS - 1) == 1
    assert threads_for(2, FEW_ROWS) == 2 and threads_for(None, FEW_ROWS) is None
