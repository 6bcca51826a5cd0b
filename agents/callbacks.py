"""SB3 callbacks of a training run: a checkpoint that also records the wall time, and an
evaluation that logs the episode's score (the value of its id's objective, ``agents.scores``:
the average rate, the max-min rate of several nodes, or the energy efficiency), feasibility
and terminal miss."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from stable_baselines3.common.callbacks import BaseCallback, CheckpointCallback

from agents.scores import score_label
from agents.tricks import scheduled_prob
from ios_uav_env.io import atomic_write_bytes, atomic_write_text, naming_full_disk

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


def replace_into(path: str | Path, write: Callable[[Path], Any]) -> Path:
    """Write ``path`` atomically: ``write(tmp)`` writes a temporary file in the same folder (its name
    starts with a dot and keeps the suffix), which then replaces ``path``; a full disk raises
    ``ios_uav_env.io.DiskFullError`` naming ``path`` (left as it was)."""
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.tmp{os.getpid()}{path.suffix}")
    with naming_full_disk(path):
        try:
            write(tmp)
            os.replace(tmp, path)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
    return path


def save_checkpoint(
    run_dir: str | Path,
    model: Any,
    clock: Clock,
    history: list,
    vecnormalize: Any = None,
    replay_buffer: Any = None,
    extra: dict[str, Any] | None = None,
) -> Path:
    """Write the checkpoint of ``model`` at its step count into ``run_dir/checkpoints``: the steps,
    wall time and evaluation history (``rl_model_progress_<steps>_steps.json``), the
    VecNormalize statistics and SAC's replay buffer when given, each ``extra`` object as the
    pickle ``rl_model_<name>_<steps>_steps.pkl``, then the model's ``.zip`` (last: a checkpoint
    whose ``.zip`` exists has all its files) and the run's latest ``progress.json``. Every file is
    written atomically. Returns the ``.zip``'s path."""
    import pickle

    from agents.loading import checkpoint_file

    steps = int(model.num_timesteps)
    folder = Path(run_dir) / "checkpoints"
    folder.mkdir(parents=True, exist_ok=True)
    record = {"steps": steps, "wall_time_s": clock.seconds(), "eval_history": history}
    text = json.dumps(record, indent=1)
    atomic_write_text(checkpoint_file(run_dir, steps, "progress").with_suffix(".json"), text)
    if vecnormalize is not None:
        atomic_write_bytes(checkpoint_file(run_dir, steps, "vecnormalize"), pickle.dumps(vecnormalize))
    for name, obj in (extra or {}).items():
        atomic_write_bytes(checkpoint_file(run_dir, steps, name), pickle.dumps(obj))
    if replay_buffer is not None:

        def dump(tmp: Path) -> None:
            with tmp.open("wb") as fh:
                pickle.dump(replay_buffer, fh, protocol=pickle.HIGHEST_PROTOCOL)

        replace_into(checkpoint_file(run_dir, steps, "replay_buffer"), dump)
    path = replace_into(checkpoint_file(run_dir, steps), model.save)  # last: it marks a whole checkpoint
    atomic_write_text(folder / PROGRESS_FILE, text)
    return path


class TimedCheckpointCallback(CheckpointCallback):
    """SB3's ``CheckpointCallback`` (model, replay buffer, VecNormalize stats) that also writes
    the steps, wall time and evaluation history of each checkpoint (``rl_model_progress_<steps>_steps.json``
    and the run's latest, ``progress.json``), so that ``--resume`` continues the run's clock and
    evaluation history.

    Every file is written atomically (a temporary file, then a rename) and the model's ``.zip``
    last: a checkpoint whose ``.zip`` exists has all its files. ``stop()`` (the training's
    signal flag) is asked at every step: when true, the step ends training (``learn`` returns)
    with nothing of it lost: SAC's transition goes into the replay buffer first; PPO's
    unfinished rollout, which no update has used, is dropped and its steps are not counted
    (``num_timesteps`` goes back to the rollout's start), so a resume redoes them.
    """

    def __init__(
        self,
        every: int,
        save_path: str | Path,
        clock: Clock,
        history: list,
        stop: Callable[[], bool] | None = None,
        **kwargs: Any,
    ):
        super().__init__(1, str(save_path), **kwargs)
        self.every, self.clock, self.history, self.stop = every, clock, history, stop
        self._last = -1
        self.rollout_start = 0
        self.stopped_at: int | None = None  # the step count when ``stop()`` was seen

    def _init_callback(self) -> None:
        super()._init_callback()
        self._last = self.model.num_timesteps // self.every  # a resumed run goes on from its count
        self.rollout_start = self.model.num_timesteps

    def file(self, kind: str = "", extension: str = "pkl") -> Path:
        """The checkpoint file of the model's step count: the model (``kind=""``, a .zip) or its
        ``"replay_buffer"`` / ``"vecnormalize"`` pickle or ``"progress"`` JSON."""
        self.num_timesteps = self.model.num_timesteps
        return Path(self._checkpoint_path(f"{kind}_" if kind else "", extension))

    def save(self) -> Path:
        """Checkpoint now (progress, VecNormalize statistics, replay buffer, then the model); return
        the model's path."""
        vecnormalize = self.model.get_vec_normalize_env() if self.save_vecnormalize else None
        replay = getattr(self.model, "replay_buffer", None) if self.save_replay_buffer else None
        return save_checkpoint(
            Path(self.save_path).parent, self.model, self.clock, self.history, vecnormalize, replay
        )

    def _on_rollout_start(self) -> None:
        self.rollout_start = self.model.num_timesteps

    def _keep_last_step(self) -> None:
        """Before training stops at this step: SAC stores its transition (SB3 would drop it);
        PPO goes back to the step count of its last update."""
        from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

        if isinstance(self.model, OffPolicyAlgorithm):
            loc = self.locals
            self.model._update_info_buffer(loc["infos"], loc["dones"])
            self.model._store_transition(
                loc["replay_buffer"], loc["buffer_actions"], loc["new_obs"], loc["rewards"], loc["dones"],
                loc["infos"],
            )  # fmt: skip
        else:
            self.model.num_timesteps = self.rollout_start

    def _on_step(self) -> bool:  # at every multiple of ``every`` env steps, resumed or not
        if self.stop is not None and self.stop():
            self.stopped_at = int(self.model.num_timesteps)
            self._keep_last_step()
            return False
        if self.num_timesteps // self.every > self._last:
            self._last = self.num_timesteps // self.every
            self.save()
        return True


def evaluate_agent(agent: Any, steps: int, seconds: float) -> dict[str, Any]:
    """The record of one deterministic episode (seed 0) of ``agent`` on its own env (``env_id``
    with ``env_kwargs``) at ``steps`` env steps and ``seconds`` of wall time: its ``score`` (the
    value of the env's objective) with its ``score_name`` and ``score_unit`` (:func:`score_label`),
    ``average_rate`` (bps/Hz; the multi-node ids' own max-min rate), feasibility and terminal miss."""
    import gymnasium as gym

    from ios_uav_env.envs.rollout import run_episode

    env = gym.make(agent.env_id, **agent.env_kwargs)
    try:
        label = score_label(env)
        result = run_episode(env, agent.act, seed=0)
    finally:
        env.close()
    return {
        "steps": int(steps),
        "wall_time_s": round(seconds, 2),
        "score": result.score,
        "score_name": label.name,
        "score_unit": label.unit,
        "average_rate": result.average_rate,
        "feasible": result.feasible,
        "terminal_miss": result.terminal_miss,
    }


class RateEvalCallback(BaseCallback):
    """Every ``eval_freq`` env steps: a deterministic episode on the training scenario, scored by the
    model (:func:`evaluate_agent`): ``eval/<score name>`` (its objective's value, e.g.
    ``eval/energy_efficiency`` on the energy ids), ``eval/average_rate``, ``eval/terminal_miss``
    and ``eval/feasible`` in TensorBoard."""

    def __init__(
        self,
        eval_freq: int,
        env_id: str,
        env_kwargs: dict[str, Any],
        clock: Clock,
        history: list,
        repeat: int = 1,
        memory: int = 1,
    ):
        super().__init__()
        self.memory = memory  # the training's FrameStack: the agent keeps this many observations
        self.eval_freq, self.env_id, self.env_kwargs = eval_freq, env_id, dict(env_kwargs)
        self.repeat = repeat  # the training's ActionRepeat: the agent holds each action this many slots
        self.clock, self.history = clock, history
        self._last = -1

    def _init_callback(self) -> None:
        self._last = self.model.num_timesteps // self.eval_freq if self.eval_freq > 0 else 0

    def evaluate(self) -> dict[str, Any]:
        """One deterministic episode (seed 0) of the model now; recorded, logged and returned."""
        from agents.loading import Agent

        agent = Agent(self.model, self.model.get_vec_normalize_env(), self.env_id, self.env_kwargs,
                      repeat=self.repeat, memory=self.memory)  # fmt: skip
        record = evaluate_agent(agent, int(self.num_timesteps), self.clock.seconds())
        self.history.append(record)
        self.logger.record(f"eval/{record['score_name']}", float(record["score"]))
        for key in ("average_rate", "terminal_miss", "feasible"):
            self.logger.record(f"eval/{key}", float(record[key]))
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


class CloneStart(BaseCallback):
    """Start the fast trainer's PPO from a behaviour clone of ``expert`` (``agents.fast.clone``:
    the rounds, the fit and what is recorded). ``expert`` is PKG.MODULE:ATTR of a policy on the
    raw observation, e.g. ``ios_uav_env.envs.policies:HoverAt('ground')``. A recipe entry of
    ``agents/hyperparams/fast_ppo.yml``; SB3's own loop (``train.py --trainer sb3``) refuses it."""

    def __init__(self, expert: str, rounds: int = 4, slots: int = 128, epochs: int = 8,
                 learning_rate: float = 1e-3, noise: float = 0.3, batch_size: int = 4096):  # fmt: skip
        super().__init__()
        from agents.fast.recipe import CloneSettings

        self.settings = CloneSettings(expert, rounds, slots, epochs, learning_rate, noise, batch_size)

    def _on_training_start(self) -> None:
        raise ValueError(
            "agents.callbacks.CloneStart is applied by the fast trainer only (train.py --trainer fast, "
            "agents/hyperparams/fast_ppo.yml)"
        )

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


def exploring_starts(env: Any) -> list[Any]:
    """The exploring-starts wrappers of a training env: the ``VecExploringStarts`` in a VecEnv's
    wrapper chain, or the ``ExploringStarts`` in each env of a ``DummyVecEnv``."""
    import gymnasium as gym

    from agents.vec_env import VecExploringStarts
    from agents.wrappers import ExploringStarts

    found = []
    while env is not None:
        if isinstance(env, VecExploringStarts):
            found.append(env)
        for single in vars(env).get("envs", []):  # a DummyVecEnv's own envs (not forwarded by wrappers)
            while isinstance(single, gym.Wrapper):
                if isinstance(single, ExploringStarts):
                    found.append(single)
                single = single.env
        env = vars(env).get("venv")
    return found


class ExploringStartsSchedule(BaseCallback):
    """Wind the exploring starts down: their ``prob`` stays as configured for the first ``hold`` of
    the run, then falls linearly to ``end`` at its end, so the last part of training is spent
    on the episodes the agent will be judged on (all from q0). ``ValueError`` at the start if
    the training env has no ``agents.wrappers.ExploringStarts``."""

    def __init__(self, hold: float = 0.5, end: float = 0.0):
        super().__init__()
        if not (0.0 <= hold <= 1.0 and 0.0 <= end <= 1.0):
            raise ValueError(f"ExploringStartsSchedule hold and end must be in [0, 1], got {hold!r}, {end!r}")
        self.hold, self.end = float(hold), float(end)
        self._wrappers: list[Any] = []
        self._start = 0.0

    def _on_training_start(self) -> None:
        self._wrappers = exploring_starts(self.training_env)
        if not self._wrappers:
            raise ValueError("ExploringStartsSchedule needs agents.wrappers.ExploringStarts in env_wrapper")
        self._start = self._wrappers[0].prob
        self._update()

    def _update(self) -> None:
        frac = min(1.0, self.model.num_timesteps / max(1, self.model._total_timesteps))
        prob = scheduled_prob(self._start, frac, self.hold, self.end)
        for wrapper in self._wrappers:
            wrapper.prob = prob

    def _on_rollout_start(self) -> None:
        self._update()

    def _on_step(self) -> bool:
        return True
