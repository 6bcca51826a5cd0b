"""What a fast run steps: :class:`RunEnv`, the rows of a registered id's batched form or of B
fleets of U agents (built by :func:`agents.fast.envs.run_env`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from agents.scores import ScoreLabel

__all__ = ["RunEnv"]


@dataclass
class RunEnv:
    """What a fast run steps and builds its model on (module docstring)."""

    base: Any  # the rows: vector_env, seed(s), reset() -> (rows, obs), close()
    template: Any  # a one-env DummyVecEnv of a row's spaces (the model's and the statistics')
    score: ScoreLabel  # the finished episodes' score (a key of the vector env's final info)
    episode_rows: int = 1  # rows of one episode (U for a fleet): its score is counted once

    @property
    def rows(self) -> int:
        """The number of rows (env steps per slot)."""
        return int(self.base.vector_env.num_envs)
