"""Training runs: SB3 PPO or SAC on a registered env id, one self-contained folder per run.

A run folder (``runs/<env>__<algo>__<seed>__<unix time>`` unless named) holds:

- ``config.json``: the resolved configuration (arguments, hyperparameters as written in the
  zoo-format file, whether VecNormalize normalises the observations and the rewards
  (``"normalize": {"obs": ..., "reward": ...}``), env kwargs, scenario, library versions),
  written before training starts;
- ``model.zip`` (+ ``vecnormalize.pkl`` when the hyperparameters normalise) and
  ``summary.json`` (steps, wall time, steps/s, the final deterministic evaluation and the
  evaluation history), written at the end;
- ``checkpoints/`` (model, SAC replay buffer, VecNormalize statistics and the steps, wall
  time and evaluations of each checkpoint, every file written atomically and the ``.zip``
  last, so a checkpoint with its ``.zip`` is whole), ``monitor/`` (episode logs), ``tb/``
  (TensorBoard);
- ``.lock``: the lock the process writing the folder holds (an exclusive ``flock``, released
  when the run ends or its process dies); a second run or resume of the folder meanwhile is
  refused (:class:`~agents.training.folder.RunFolderInUse`, naming the holder's pid).

SIGINT or SIGTERM during :func:`train` stops at the next env step and saves a checkpoint of
that moment (PPO: of its last update; the unfinished rollout is redone on resume), then
raises :class:`TrainingInterrupted` (``train.py`` exits 130 or 143 and prints the resume
command). :func:`resume` continues a run from its newest checkpoint that loads (an unreadable
one is set aside as ``*.unreadable`` with a warning naming it) in the same folder: the step
count, the TensorBoard run, the monitor files and the wall-time clock go on where they
stopped. A run folder without a checkpoint (a run stopped before its first) is no dead end:
``--resume`` starts it again from step 0 with its own settings, and a new run may use it; a
folder with a finished model but no checkpoint (a shipped model) is refused before anything is
written to it. A full disk ends a run with ``ios_uav_env.io.DiskFullError`` naming the file
(nothing left half written: every file is written atomically, the logs a whole line at a time).

The modules, by concern:

- :mod:`agents.training.settings`: :class:`TrainSettings` and the checks of each setting;
- :mod:`agents.training.folder`: the run folder (its name, new or resumable, its lock,
  ``config.json``);
- :mod:`agents.training.envs`: the training envs and their wrappers;
- :mod:`agents.training.interrupt`: SIGINT / SIGTERM and :class:`TrainingInterrupted`;
- :mod:`agents.training.resuming`: continuing a run from its newest checkpoint that loads;
- :mod:`agents.training.run`: the training loop, :func:`train` and :func:`resume`.
"""

from agents.training.folder import (
    LOCK_FILE,
    RUNS_DIR,
    UNSTARTED_RUN,
    RunFolderInUse,
    check_new_run_dir,
    check_resumable,
    check_unlocked,
    lock_run_dir,
    read_config,
    run_name,
    versions,
    write_config,
)
from agents.training.interrupt import StopFlag, TrainingInterrupted, stop_on_signals
from agents.training.resuming import load_checkpoint, record_resume
from agents.training.run import TrainResult, resume, train
from agents.training.settings import (
    DEFAULT_ENV_ID,
    VEC_ENVS,
    TrainSettings,
    check_algo,
    check_env_id,
    check_env_kwargs,
    check_hyperparams,
    check_positive,
    check_vec_env,
)
from baselines.runner import check_writable

__all__ = [
    "DEFAULT_ENV_ID",
    "LOCK_FILE",
    "RUNS_DIR",
    "UNSTARTED_RUN",
    "VEC_ENVS",
    "RunFolderInUse",
    "StopFlag",
    "TrainResult",
    "TrainSettings",
    "TrainingInterrupted",
    "check_algo",
    "check_env_id",
    "check_env_kwargs",
    "check_hyperparams",
    "check_new_run_dir",
    "check_positive",
    "check_resumable",
    "check_unlocked",
    "check_vec_env",
    "check_writable",
    "load_checkpoint",
    "lock_run_dir",
    "read_config",
    "record_resume",
    "resume",
    "run_name",
    "stop_on_signals",
    "train",
    "versions",
    "write_config",
]
