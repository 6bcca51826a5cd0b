"""SB3 callbacks of a training run: a checkpoint that also records the wall time, and an
evaluation that logs the paper's metrics (average rate, feasibility, terminal miss)."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

from stable_baselines3.common.callbacks import BaseCallback, CheckpointCallback

from ios_uav_env.io import atomic_write_text

PROGRESS_FILE = "progress.json"


class Clock:
    """Wall time of a run across resumes: ``prior`` seconds plus the time since ``start()``."""

    def __init__(self, prior: float = 0.0) -> None:
        self.prior = float(prior)
        self._start = time.perf_counter()

    def start(self) -> None:
        self._start = time.perf_counter()

    def seconds(self) -> float:
        return self.prior + time.perf_counter() - self._start


class TimedCheckpointCallback(CheckpointCallback):
    """SB3's ``CheckpointCallback`` (model, replay buffer, VecNormalize stats) that also writes
    ``progress.json`` (steps and wall time at the checkpoint) next to the checkpoints, so that
    ``--resume`` can continue the run's clock and evaluation history."""

    def __init__(self, every: int, save_path: str | Path, clock: Clock, history: list, **kwargs: Any):
        super().__init__(1, str(save_path), **kwargs)
        self.every, self.clock, self.history = every, clock, history
        self._last = -1

    def _init_callback(self) -> None:
        super()._init_callback()
        self._last = self.model.num_timesteps // self.every  # a resumed run goes on from its count

    def save(self) -> None:
        """Checkpoint now (model, replay buffer, VecNormalize statistics, progress.json)."""
        self.model.save(self._checkpoint_path(extension="zip"))  # (re)written: the model of now
        if self.save_replay_buffer and getattr(self.model, "replay_buffer", None) is not None:
            self.model.save_replay_buffer(self._checkpoint_path("replay_buffer_", extension="pkl"))
        if self.save_vecnormalize and self.model.get_vec_normalize_env() is not None:
            self.model.get_vec_normalize_env().save(self._checkpoint_path("vecnormalize_", extension="pkl"))
        record = {
            "steps": int(self.num_timesteps),
            "wall_time_s": self.clock.seconds(),
            "eval_history": self.history,
        }
        atomic_write_text(Path(self.save_path) / PROGRESS_FILE, json.dumps(record, indent=1))

    def _on_step(self) -> bool:  # at every multiple of ``every`` env steps, resumed or not
        if self.num_timesteps // self.every > self._last:
            self._last = self.num_timesteps // self.every
            self.save()
        return True


class RateEvalCallback(BaseCallback):
    """Every ``eval_freq`` env steps: a deterministic episode on the training scenario, scored by the
    model (``eval/average_rate``, ``eval/terminal_miss``, ``eval/feasible`` in TensorBoard)."""

    def __init__(self, eval_freq: int, env_id: str, env_kwargs: dict[str, Any], clock: Clock, history: list):
        super().__init__()
        self.eval_freq, self.env_id, self.env_kwargs = eval_freq, env_id, dict(env_kwargs)
        self.clock, self.history = clock, history
        self._last = -1

    def _init_callback(self) -> None:
        self._last = self.model.num_timesteps // self.eval_freq if self.eval_freq > 0 else 0

    def evaluate(self) -> dict[str, Any]:
        """One deterministic episode (seed 0) of the model now; recorded, logged and returned."""
        import gymnasium as gym

        from agents.loading import Agent
        from ios_uav_env.rollout import run_episode

        agent = Agent(self.model, self.model.get_vec_normalize_env(), self.env_id, self.env_kwargs)
        env = gym.make(self.env_id, **self.env_kwargs)
        try:
            result = run_episode(env, agent.act, seed=0)
        finally:
            env.close()
        record = {
            "steps": int(self.num_timesteps),
            "wall_time_s": round(self.clock.seconds(), 2),
            "average_rate": result.average_rate,
            "feasible": result.feasible,
            "terminal_miss": result.terminal_miss,
        }
        self.history.append(record)
        self.logger.record("eval/average_rate", result.average_rate)
        self.logger.record("eval/terminal_miss", result.terminal_miss)
        self.logger.record("eval/feasible", float(result.feasible))
        return record

    def _on_step(self) -> bool:
        if self.eval_freq > 0 and self.num_timesteps // self.eval_freq > self._last:
            self._last = self.num_timesteps // self.eval_freq
            self.evaluate()
            self.logger.dump(self.num_timesteps)
        return True


class LogStdSchedule(BaseCallback):
    """Anneal the exploration noise of a PPO Gaussian policy: ``log_std`` goes linearly from
    ``start`` to ``end`` over the run (it is no longer learned). SB3's state-independent std
    otherwise stays near 0.1 (2.5 m per move), too noisy for the last move to learn to land
    within 1 m of qF; a small final std lets the mean policy refine that move."""

    def __init__(self, start: float = -1.0, end: float = -3.5):
        super().__init__()
        self.start, self.end = float(start), float(end)

    def _on_training_start(self) -> None:
        self.model.policy.log_std.requires_grad_(False)
        self._update()

    def _update(self) -> None:
        import torch

        total = max(1, self.model._total_timesteps)
        frac = min(1.0, self.model.num_timesteps / total)
        with torch.no_grad():
            self.model.policy.log_std.fill_(self.start + frac * (self.end - self.start))

    def _on_rollout_start(self) -> None:
        self._update()

    def _on_step(self) -> bool:
        return True


class TargetEntropySchedule(BaseCallback):
    """Anneal SAC's target entropy linearly from ``start`` to ``end`` (nats) over the run.

    SB3's automatic temperature holds the policy's entropy near ``target_entropy`` (-|A| = -2
    by default): a std of ~0.1 (2.5 m per move) to the end of training. Near the rate peak that
    noise keeps the critic's picture of the hover point blurred and the deterministic policy
    hovers metres off it; lowering the target as the run goes shrinks the noise, as
    :class:`LogStdSchedule` does for PPO, while keeping the early exploration.
    """

    def __init__(self, start: float = -2.0, end: float = -6.0):
        super().__init__()
        self.start, self.end = float(start), float(end)

    def _update(self) -> None:
        total = max(1, self.model._total_timesteps)
        frac = min(1.0, self.model.num_timesteps / total)
        self.model.target_entropy = self.start + frac * (self.end - self.start)

    def _on_training_start(self) -> None:
        if not hasattr(self.model, "target_entropy"):
            name = type(self.model).__name__
            raise TypeError(f"TargetEntropySchedule needs SAC (an entropy target), got {name}")
        if getattr(self.model, "ent_coef_optimizer", None) is None:  # a fixed ent_coef ignores the target
            raise ValueError(
                "TargetEntropySchedule needs SAC's automatic entropy coefficient (ent_coef: 'auto')"
            )
        self._update()

    def _on_step(self) -> bool:
        self._update()
        return True
