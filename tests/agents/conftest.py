"""Fixtures of the agents' tests."""

from __future__ import annotations

import pytest


@pytest.fixture
def one_torch_thread():
    """One torch thread, the fast trainer's default (``train_fast`` sets it; ``FastPPO`` used
    directly does not), restored after the test."""
    torch = pytest.importorskip("torch")
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)
