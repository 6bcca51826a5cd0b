"""A fast-trainer run: the run folder, checkpoints, resume and interrupts of ``train.py``, around
:class:`agents.fast.ppo.FastPPO`.

``agents.training.train`` calls :func:`train_fast` for ``TrainSettings(trainer="fast")`` once it
holds the run folder's lock. The folder is the SB3 path's (``agents.training``): ``config.json``
(with ``"trainer": "fast"`` in its ``args``), ``model.zip`` (an SB3 PPO file: the policy and its
Adam state) and ``vecnormalize.pkl`` (a ``VecNormalize``'s statistics), ``summary.json``, and
``checkpoints/`` with the same files per checkpoint plus ``rl_model_trainer_<steps>_steps.pkl``
(the trainer's own state: its update count and random generators), all written atomically with
the ``.zip`` last (``agents.callbacks.save_checkpoint``), and ``progress.csv``, one JSON line per
update appended whole as the update ends (``ios_uav_env.io.append_line``: a process killed at any
moment has lost no finished update's line, a full disk leaves no half line). So
``agents.loading.load_agent`` loads its models and checkpoints,
``agents.numpy_policy.NumpyPolicy`` exports them and ``ios_uav_env.benchmark`` scores them like
any other.

A new run may start from a trained model's weights and observation statistics
(``settings.init_from``, ``--init-from``: :mod:`agents.fast.init_from`); a resumed run reads
its own checkpoint instead.

A checkpoint is taken after the update that crosses each multiple of ``checkpoint_freq`` steps,
and at the end. SIGINT / SIGTERM stops the rollout under way (its steps are dropped: no update
used them) and saves a checkpoint of the last update; ``--resume`` continues from the newest
checkpoint that loads with the same Adam state, statistics, step count (hence the schedules)
and random generators; its rows start new episodes (seeded from the run's seed and the update
count), as an SB3 run's resume does; ``progress.csv`` is cut back to the checkpoint's updates
first (:func:`trim_progress`: the lines of updates past it, which the resumed run redoes, and a
torn last line). A full disk ends the run with ``ios_uav_env.io.DiskFullError`` naming the file;
the newest whole checkpoint stays, so ``--resume`` goes on from it once there is room.
"""

from __future__ import annotations

import json
import pickle
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agents.fast.ppo import FastPPO
from agents.fast.recipe import FastRecipe
from agents.hyperparams import Hyperparams
from agents.training.folder import start_fresh, write_config
from agents.training.interrupt import StopFlag, TrainingInterrupted
from agents.training.resuming import RunStart, TrainResult, Unloadable, continue_run
from agents.training.settings import TrainSettings
from ios_uav_env.io import append_line, atomic_write_bytes, atomic_write_text

#: The checkpoint pickle of the trainer's own state (``rl_model_trainer_<steps>_steps.pkl``).
STATE_KIND = "trainer"
#: The run's log: one JSON line per update (steps, wall time, the update's statistics, the score).
PROGRESS_LOG = "progress.csv"


@dataclass
class _Loaded:
    """What a checkpoint holds beside the model: the statistics and the trainer's state."""

    vecnormalize: Any
    state: dict[str, Any]

    def close(self) -> None:  # a RunStart's venv is closed when a resume is refused
        return None


def torch_threads(threads: int | None) -> int:
    """The torch threads of a fast run: ``threads``, default 1. More threads pay only on cores
    nothing else uses: torch's threads wait for each other at every operation, and one that
    another process holds stalls them all (the measurements: ``results/log.md``)."""
    return 1 if threads is None else threads


def _load(run_dir: Path, steps: int, ckpt: Path, settings: TrainSettings, hp: Hyperparams) -> tuple[Any, Any]:
    """The model and :class:`_Loaded` of one checkpoint; :class:`Unloadable` naming the file that fails."""
    from stable_baselines3 import PPO

    from agents.loading import checkpoint_file

    current = checkpoint_file(run_dir, steps, STATE_KIND)
    try:
        with current.open("rb") as fh:
            state = pickle.load(fh)
        vecnormalize = None
        if hp.normalize is not None:
            current = checkpoint_file(run_dir, steps, "vecnormalize")
            with current.open("rb") as fh:
                vecnormalize = pickle.load(fh)
        current = ckpt
        model = PPO.load(ckpt, device="cpu")
    except Exception as exc:  # a damaged file fails in many ways (zipfile, pickle, torch, SB3 asserts)
        reason = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
        raise Unloadable(current, reason) from exc
    return model, _Loaded(vecnormalize, state)


def trim_progress(run_dir: Path, steps: int) -> int:
    """Cut ``progress.csv`` back to the updates of the checkpoint of ``steps``: its whole lines of
    updates at or before ``steps`` are kept, in order; a torn or unreadable line and the lines of
    later updates (a resumed run redoes them) are dropped. The lines dropped (the file is
    rewritten atomically only if there are any)."""
    path = run_dir / PROGRESS_LOG
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except FileNotFoundError:
        return 0
    lines = text.split("\n")  # the last item: the unfinished line after the last newline, or ""
    kept = []
    for line in lines[:-1]:
        try:
            if int(json.loads(line)["steps"]) <= steps:
                kept.append(line)
        except (ValueError, KeyError, TypeError):  # glued or torn by an older writer
            continue
    dropped = len(lines) - 1 - len(kept) + (lines[-1] != "")
    if dropped:
        atomic_write_text(path, "".join(f"{line}\n" for line in kept))
    return dropped


def _state(algo: FastPPO) -> dict[str, Any]:
    import torch

    return {"steps": algo.steps, "updates": algo.updates, "torch_rng": torch.get_rng_state(),
            "rng": algo._rng.bit_generator.state}  # fmt: skip


def _save(run_dir: Path, algo: FastPPO, start: RunStart) -> Path:
    from agents.callbacks import save_checkpoint

    return save_checkpoint(run_dir, algo.model, start.clock, start.history, algo.vecnormalize,
                           extra={STATE_KIND: _state(algo)})  # fmt: skip


def train_fast(
    settings: TrainSettings, stop: StopFlag, resume: bool, hp: Hyperparams, total: int, run_dir: Path
) -> Any:
    """Train (or continue) the fast run of ``settings`` in ``run_dir`` (its lock held) to ``total``
    steps; ``agents.training.TrainResult``. Raises ``TrainingInterrupted`` after saving a
    checkpoint if ``stop`` is set."""
    import torch
    from stable_baselines3.common.utils import set_random_seed

    from agents.callbacks import Clock

    recipe = FastRecipe.from_hyperparams(hp, settings.n_envs)
    torch.set_num_threads(torch_threads(settings.threads))
    start = continue_run(run_dir, settings, hp, total, loader=_load) if resume else None
    if start is None:
        start_fresh(run_dir, resume)
        set_random_seed(settings.seed)
        algo = FastPPO(settings.env_id, recipe, total, env_kwargs=settings.env_kwargs, seed=settings.seed,
                       init_from=settings.init_from)  # fmt: skip
        write_config(run_dir, settings, hp, total)
        start = RunStart(algo.model, None, 0, Clock(), [])
        if recipe.clone is not None:  # the warm start (agents.fast.clone), recorded in clone.json
            from agents.fast.clone import clone

            print(
                f"cloning {recipe.clone.expert} ({recipe.clone.rounds} rounds)", file=sys.stderr, flush=True
            )
            record = clone(algo, recipe.clone)
            atomic_write_text(run_dir / "clone.json", json.dumps(record, indent=1))
    else:
        loaded: _Loaded = start.venv
        algo = FastPPO(settings.env_id, recipe, total, env_kwargs=settings.env_kwargs, seed=settings.seed,
                       model=start.model, vecnormalize=loaded.vecnormalize, steps=start.steps)  # fmt: skip
        algo.updates = int(loaded.state["updates"])
        dropped = trim_progress(run_dir, start.steps)
        if dropped:
            print(f"{run_dir / PROGRESS_LOG}: {dropped} lines past the checkpoint of {start.steps} steps "
                  "dropped (their updates are done again)", file=sys.stderr)  # fmt: skip
        torch.set_rng_state(loaded.state["torch_rng"])
        algo.reset()
        algo._rng.bit_generator.state = loaded.state["rng"]
    start.venv = algo

    def evaluate() -> dict[str, Any]:
        from agents.callbacks import evaluate_agent
        from agents.loading import Agent

        agent = Agent(algo.model, algo.vecnormalize, settings.env_id, settings.env_kwargs,
                      memory=algo.recipe.frames)  # fmt: skip
        return evaluate_agent(agent, algo.steps, start.clock.seconds())

    try:
        return run_loop(settings, run_dir, algo, start, total, stop, evaluate)
    finally:
        algo.close()


def run_loop(
    settings: Any, run_dir: Path, algo: FastPPO, start: RunStart, total: int, stop: StopFlag,
    evaluate: Callable[[], dict[str, Any]],
) -> TrainResult:  # fmt: skip
    """Train ``algo`` from its steps to ``total`` in ``run_dir`` (``progress.csv``, checkpoints every
    ``settings.checkpoint_freq`` steps, ``evaluate()``'s record every ``settings.eval_freq``, a
    progress bar if ``settings.progress_bar``), then save the model and ``summary.json``."""
    import numpy as np
    from tqdm.auto import tqdm

    def evaluated() -> dict[str, Any]:
        record = evaluate()
        start.history.append(record)
        return record

    start.clock.start()
    print(f"training {run_dir} (fast PPO): step {algo.steps} of {total}", file=sys.stderr, flush=True)
    bar = tqdm(
        total=total, initial=algo.steps, unit="step", unit_scale=True, disable=not settings.progress_bar
    )
    log = run_dir / PROGRESS_LOG
    try:
        while algo.steps < total:
            if not algo.collect(stop):
                steps_at_signal = algo.steps + algo.cut_steps
                path = _save(run_dir, algo, start)
                assert stop.signum is not None
                raise TrainingInterrupted(stop.signum, run_dir, steps_at_signal, path, algo.steps)
            before = algo.steps
            stats = algo.update()
            bar.update(algo.steps - before)
            scores = algo.take_scores()  # the value of the env's objective, labelled
            stats.update(episode_score=float(np.mean(scores)) if scores else float("nan"),
                         score_name=algo.score.name, score_unit=algo.score.unit)  # fmt: skip
            append_line(log, json.dumps({"steps": algo.steps, "wall_time_s": round(start.clock.seconds(), 3),
                                         **stats}))  # fmt: skip
            if settings.eval_freq and algo.steps // settings.eval_freq > before // settings.eval_freq:
                record = evaluated()
                bar.set_postfix_str(algo.score.text(record["score"]))
            if algo.steps // settings.checkpoint_freq > before // settings.checkpoint_freq:
                _save(run_dir, algo, start)
    finally:
        bar.close()
    _save(run_dir, algo, start)  # the final state too, so that --resume can extend a finished run
    seconds = start.clock.seconds()
    model_path = _save_model(run_dir, algo)
    final = evaluate()
    summary = {
        "steps": int(algo.steps),
        "wall_time_s": round(seconds, 2),
        "steps_per_s": round((algo.steps - start.steps) / max(seconds - start.clock.prior, 1e-9), 1),
        "trainer": "fast",
        "timing_s": {key: round(value, 3) for key, value in algo.timing.items()},
        "final_eval": final,
        "eval_history": start.history,
    }
    atomic_write_text(run_dir / "summary.json", json.dumps(summary, indent=1))
    return TrainResult(run_dir, model_path, summary)


def _save_model(run_dir: Path, algo: FastPPO) -> Path:
    """``model.zip`` (and ``vecnormalize.pkl`` when the recipe normalises), written atomically."""
    from agents.callbacks import replace_into

    model_path = replace_into(run_dir / "model.zip", algo.model.save)
    if algo.vecnormalize is not None:
        atomic_write_bytes(run_dir / "vecnormalize.pkl", pickle.dumps(algo.vecnormalize))
    return model_path
