"""SIGINT and SIGTERM during a run: a flag the checkpoint callback reads, and the exception raised
once the checkpoint of that moment is saved."""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any


class TrainingInterrupted(Exception):
    """Training stopped by SIGINT or SIGTERM, after saving a checkpoint."""

    def __init__(
        self, signum: int, run_dir: Path, steps_at_signal: int, checkpoint: Path, steps: int
    ) -> None:
        self.signum, self.run_dir, self.checkpoint = signum, run_dir, checkpoint
        self.steps_at_signal, self.steps = steps_at_signal, steps
        super().__init__(
            f"{signal.Signals(signum).name} at step {steps_at_signal}: saved checkpoint {checkpoint} "
            f"({steps} steps); continue with: python train.py --resume {run_dir}"
        )

    def __reduce__(self) -> tuple[Any, ...]:  # raised in a worker process, re-raised in its parent
        return type(self), (self.signum, self.run_dir, self.steps_at_signal, self.checkpoint, self.steps)

    @property
    def exit_status(self) -> int:
        return 128 + self.signum


class StopFlag:
    """Set by SIGINT / SIGTERM while :func:`agents.training.train` runs (``signum`` is the signal)."""

    def __init__(self) -> None:
        self.signum: int | None = None

    def __call__(self) -> bool:
        return self.signum is not None


@contextmanager
def stop_on_signals() -> Iterator[StopFlag]:
    """SIGINT and SIGTERM set the flag instead of killing (a second one acts as usual); in the
    main thread only (elsewhere the flag is never set)."""
    flag = StopFlag()
    if threading.current_thread() is not threading.main_thread():
        yield flag
        return
    signals = (signal.SIGINT, signal.SIGTERM)

    def handler(signum: int, frame: Any) -> None:
        flag.signum = signum
        for s, h in old.items():
            signal.signal(s, h)

    old = {s: signal.signal(s, handler) for s in signals}
    try:
        yield flag
    finally:
        for s, h in old.items():
            signal.signal(s, h)
