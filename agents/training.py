"""Training runs: SB3 PPO or SAC on a registered env id, one self-contained folder per run.

A run folder (``runs/<env>__<algo>__<seed>__<unix time>`` unless named) holds:

- ``config.json``: the resolved configuration (arguments, hyperparameters as written in the
  zoo-format file, env kwargs, scenario, library versions), written before training starts;
- ``model.zip`` (+ ``vecnormalize.pkl`` when the hyperparameters normalise) and
  ``summary.json`` (steps, wall time, steps/s, the final deterministic evaluation and the
  evaluation history), written at the end;
- ``checkpoints/`` (model, SAC replay buffer, VecNormalize statistics and the steps, wall
  time and evaluations of each checkpoint, every file written atomically and the ``.zip``
  last, so a checkpoint with its ``.zip`` is whole), ``monitor/`` (episode logs), ``tb/``
  (TensorBoard).

SIGINT or SIGTERM during :func:`train` stops at the next env step and saves a checkpoint of
that moment (PPO: of its last update; the unfinished rollout is redone on resume), then
raises :class:`TrainingInterrupted` (``train.py`` exits 130 or 143 and prints the resume
command). :func:`resume` continues a run from its newest checkpoint that loads (an unreadable
one is set aside as ``*.unreadable`` with a warning naming it) in the same folder: the step
count, the TensorBoard run, the monitor files and the wall-time clock go on where they
stopped. A run folder without a checkpoint (a run stopped before its first) is no dead end:
``--resume`` starts it again from step 0 with its own settings, and a new run may use it.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import platform
import re
import shutil
import signal
import sys
import threading
import time
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym

import ios_uav_env
from agents.hyperparams import Hyperparams, load_hyperparams
from agents.loading import ALGOS, CHECKPOINT_PREFIX, checkpoint_file, checkpoints, read_json
from agents.wrappers import apply_wrappers
from baselines.runner import check_writable
from ios_uav_env.io import atomic_write_bytes, atomic_write_text

RUNS_DIR = Path("runs")
DEFAULT_ENV_ID = "ios_uav_env/IOSUAV-v0"


# --- checks of the settings (ValueError / FileNotFoundError / FileExistsError with the reason);
# --- TrainSettings.validate and train.py's argument parser both use them


def check_algo(algo: str) -> str:
    if algo not in ALGOS:
        raise ValueError(f"unknown algorithm {algo!r}; choose from {', '.join(ALGOS)}")
    return algo


def check_env_id(env_id: str) -> str:
    if env_id not in gym.registry:
        ours = ", ".join(sorted(ios_uav_env.ENV_IDS))
        raise ValueError(f"unknown env id {env_id!r}; registered ids of this package: {ours}")
    return env_id


def check_positive(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
        raise ValueError(f"must be a positive integer, got {value!r}")
    return value


#: ``TrainSettings.vec_env``: SB3's DummyVecEnv of single envs, or the natively batched env
#: (``agents.vec_env.BatchedVecEnv``: the same episodes, stepped as one array computation).
VEC_ENVS = ("dummy", "batched")


def check_vec_env(vec_env: str) -> str:
    if vec_env not in VEC_ENVS:
        raise ValueError(f"unknown vec env {vec_env!r}; choose from {', '.join(VEC_ENVS)}")
    return vec_env


def check_env_kwargs(env_id: str, env_kwargs: dict[str, Any]) -> dict[str, Any]:
    """``env_kwargs`` if ``gym.make(env_id, **env_kwargs)`` accepts them and the env resets."""
    try:
        env = gym.make(env_id, **env_kwargs)
        try:
            env.reset(seed=0)
        finally:
            env.close()
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{env_kwargs!r} rejected by {env_id}: {exc}") from exc
    return env_kwargs


def check_hyperparams(
    algo: str,
    env_id: str,
    path: str | Path | None = None,
    env_kwargs: dict[str, Any] | None = None,
    n_envs: int | None = None,
    vec_env: str = "dummy",
) -> Hyperparams:
    """The resolved hyperparameters of ``env_id`` if the algorithm can be built with them on the
    env (``ValueError`` naming the file and the key otherwise, :func:`agents.hyperparams.check_entry`)."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    hp = load_hyperparams(algo, env_id, path)
    where = path or f"agents/hyperparams/{algo}.yml"
    if vec_env == "batched" and hp.env_wrappers:
        from agents.vec_env import VEC_FORMS

        for cls, _ in hp.env_wrappers:
            name = f"{cls.__module__}.{cls.__qualname__}"
            if name not in VEC_FORMS:
                raise ValueError(
                    f"{where}, {env_id}: env_wrapper {name!r} cannot wrap the batched env; "
                    f"wrappers with a VecEnv form: {', '.join(VEC_FORMS)}"
                )
    n = n_envs or hp.n_envs

    def make() -> gym.Env:
        env = gym.make(env_id, **(env_kwargs or {}))
        return apply_wrappers(env, hp.env_wrappers) if hp.env_wrappers else env

    venv = DummyVecEnv([make] * min(n, 2))
    try:
        ALGOS[algo](hp.policy, venv, device="cpu", **{**hp.model_kwargs, **_small_buffer(hp)})
    except (TypeError, ValueError, AssertionError, KeyError) as exc:
        raise ValueError(f"{where}, {env_id}: {algo.upper()} refuses these hyperparameters: {exc}") from None
    finally:
        venv.close()
    return hp


def _small_buffer(hp: Hyperparams) -> dict[str, Any]:
    """A trial build needs no full replay buffer."""
    return {"buffer_size": 10} if "buffer_size" in hp.model_kwargs else {}


#: What a run leaves in its folder before its first checkpoint: such a folder can be reused.
UNSTARTED_RUN = ("config.json", "monitor", "tb", "checkpoints")


def _unstarted(run_dir: Path) -> bool:
    """A run folder holding only what a run writes before its first checkpoint."""
    names = {p.name for p in run_dir.iterdir()}
    return names <= set(UNSTARTED_RUN) and not checkpoints(run_dir)


def check_new_run_dir(run_dir: str | Path) -> Path:
    """``run_dir`` if a new run can start there: missing, empty, or the leftovers of a run stopped
    before its first checkpoint (:data:`UNSTARTED_RUN`, replaced by the new run), and writable."""
    run_dir = Path(run_dir)
    if run_dir.exists() and not run_dir.is_dir():
        raise FileExistsError(f"run folder {run_dir} is a file")
    if run_dir.exists() and any(run_dir.iterdir()) and not _unstarted(run_dir):
        raise FileExistsError(f"run folder {run_dir} exists and is not empty (resume it instead)")
    return check_writable(run_dir)


def check_resumable(run_dir: str | Path) -> Path:
    """``run_dir`` if it is a run folder (a readable ``config.json``) that can be written to."""
    run_dir = Path(run_dir)
    config = run_dir / "config.json"
    if not config.exists():
        raise FileNotFoundError(f"{run_dir} is not a run folder (no config.json)")
    read_config(run_dir)
    return check_writable(run_dir)


def read_config(run_dir: Path) -> dict[str, Any]:
    """A run's ``config.json`` (``ValueError`` naming it if unreadable or incomplete)."""
    path = run_dir / "config.json"
    config = read_json(path)
    missing = [k for k in ("args", "total_timesteps", "algo") if k not in config]
    if missing:
        raise ValueError(f"{path} is not a run's config (no {', '.join(missing)})")
    return config


class TrainingInterrupted(Exception):
    """Training stopped by SIGINT or SIGTERM, after saving a checkpoint."""

    def __init__(self, signum: int, run_dir: Path, steps_at_signal: int, checkpoint: Path, steps: int):
        self.signum, self.run_dir, self.checkpoint = signum, run_dir, checkpoint
        self.steps_at_signal, self.steps = steps_at_signal, steps
        super().__init__(
            f"{signal.Signals(signum).name} at step {steps_at_signal}: saved checkpoint {checkpoint} "
            f"({steps} steps); continue with: python train.py --resume {run_dir}"
        )

    @property
    def exit_status(self) -> int:
        return 128 + self.signum


class StopFlag:
    """Set by SIGINT / SIGTERM while :func:`train` runs (``signum`` is the signal)."""

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


@dataclass
class TrainSettings:
    """Everything a run needs; the fields are ``train.py``'s arguments."""

    algo: str  # "ppo" or "sac"
    env_id: str = DEFAULT_ENV_ID  # a registered id
    timesteps: int | None = None  # total env steps; None = the hyperparameter file's n_timesteps
    seed: int = 0  # seeds torch, numpy, the model and the envs (env i gets seed + i)
    n_envs: int | None = None  # parallel envs; None = the file's n_envs
    vec_env: str = "dummy"  # "dummy" (SB3's DummyVecEnv) or "batched" (agents.vec_env.BatchedVecEnv)
    env_kwargs: dict[str, Any] = field(default_factory=dict)  # IOSUAVEnv arguments
    out: str | None = None  # run folder; None = runs/<env>__<algo>__<seed>__<time>
    hyperparams_file: str | None = None  # None = agents/hyperparams/<algo>.yml
    checkpoint_freq: int = 25_000  # env steps between checkpoints
    eval_freq: int = 10_000  # env steps between deterministic evaluations (0: none)
    progress_bar: bool = True

    def validate(self) -> None:
        """Raise ``ValueError`` naming the first bad field."""
        checks: list[tuple[str, Any, Any]] = [
            ("algo", check_algo, self.algo),
            ("env_id", check_env_id, self.env_id),
            ("vec_env", check_vec_env, self.vec_env),
        ]
        for name in ("timesteps", "n_envs", "checkpoint_freq"):
            if getattr(self, name) is not None:  # None: the hyperparameter file's value
                checks.append((name, check_positive, getattr(self, name)))
        checks.append(("env_kwargs", functools.partial(check_env_kwargs, self.env_id), self.env_kwargs))
        hyperparams = functools.partial(
            check_hyperparams,
            self.algo,
            self.env_id,
            env_kwargs=self.env_kwargs,
            n_envs=self.n_envs,
            vec_env=self.vec_env,
        )
        checks.append(("hyperparams_file", hyperparams, self.hyperparams_file))
        for name, check, value in checks:
            try:
                check(value)
            except ValueError as exc:
                raise ValueError(f"{name}: {exc}") from exc


@dataclass
class TrainResult:
    run_dir: Path
    model_path: Path
    summary: dict[str, Any]


def run_name(settings: TrainSettings) -> str:
    """CleanRL-style name: env, algorithm, seed and start time."""
    env = re.sub(r"[^A-Za-z0-9_.-]+", "-", settings.env_id)
    return f"{env}__{settings.algo}__{settings.seed}__{int(time.time())}"


def versions() -> dict[str, str]:
    import numpy
    import stable_baselines3
    import torch

    return {
        "python": platform.python_version(),
        "ios_uav_env": ios_uav_env.__version__,
        "stable_baselines3": stable_baselines3.__version__,
        "torch": torch.__version__,
        "gymnasium": gym.__version__,
        "numpy": numpy.__version__,
    }


def _make_venv(settings: TrainSettings, hp: Hyperparams, run_dir: Path, resume_from: str | None) -> Any:
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    if settings.vec_env == "batched":
        venv = _batched_venv(settings, hp, run_dir, resume_from)
        if hp.normalize is None:
            return venv
        if resume_from is not None:
            return VecNormalize.load(resume_from, venv)
        return VecNormalize(venv, gamma=hp.model_kwargs.get("gamma", 0.99), **hp.normalize)
    wrap = functools.partial(apply_wrappers, wrappers=hp.env_wrappers) if hp.env_wrappers else None
    venv = make_vec_env(
        settings.env_id,
        wrapper_class=wrap,
        n_envs=settings.n_envs,
        seed=settings.seed,
        env_kwargs=settings.env_kwargs,
        monitor_dir=str(run_dir / "monitor"),
        monitor_kwargs={"override_existing": resume_from is None},
        vec_env_cls=DummyVecEnv,
    )
    if hp.normalize is None:
        return venv
    if resume_from is not None:
        return VecNormalize.load(resume_from, venv)
    return VecNormalize(venv, gamma=hp.model_kwargs.get("gamma", 0.99), **hp.normalize)


def _batched_venv(settings: TrainSettings, hp: Hyperparams, run_dir: Path, resume_from: str | None) -> Any:
    """``BatchedVecEnv`` (row i seeded ``seed + i``, as ``make_vec_env`` seeds env i; rows staggered
    over the episode, see its ``stagger``) under a ``VecMonitor`` writing
    ``monitor/batched.monitor.csv`` (appended to on resume), then the hyperparameters'
    ``env_wrapper`` list in its VecEnv form (``agents.vec_env.wrap_batched``)."""
    from stable_baselines3.common.monitor import ResultsWriter
    from stable_baselines3.common.vec_env import VecMonitor

    from agents.vec_env import BatchedVecEnv, wrap_batched
    from agents.wrappers import ActionRepeat

    batched = BatchedVecEnv(
        settings.env_id, settings.n_envs, settings.env_kwargs, seed=settings.seed, stagger=True
    )
    # the action repeat steps the batched env's rows itself (its advance), under the monitor
    inner = [w for w in hp.env_wrappers if issubclass(w[0], ActionRepeat)]
    monitor = VecMonitor(wrap_batched(batched, inner))
    monitor.results_writer = ResultsWriter(
        str(run_dir / "monitor" / "batched"),
        header={"t_start": monitor.t_start, "env_id": settings.env_id},
        override_existing=resume_from is None,
    )
    return wrap_batched(monitor, [w for w in hp.env_wrappers if w not in inner])


def _read_progress(run_dir: Path, steps: int) -> tuple[float, list[dict[str, Any]]]:
    """Wall time and evaluation history at the checkpoint of ``steps`` (0 and [] if unknown)."""
    from agents.callbacks import PROGRESS_FILE

    for path in (checkpoint_file(run_dir, steps, "progress").with_suffix(".json"),
                 run_dir / "checkpoints" / PROGRESS_FILE):  # fmt: skip
        try:
            record = json.loads(path.read_text())
            if int(record["steps"]) == steps:
                history = [h for h in record["eval_history"] if h["steps"] <= steps]
                return float(record["wall_time_s"]), history
        except (OSError, ValueError, KeyError, TypeError):
            continue
    return 0.0, []


def load_checkpoint(run_dir: Path, settings: TrainSettings, hp: Hyperparams) -> tuple[int, Any, Any] | None:
    """``(steps, model, venv)`` of the newest checkpoint of ``run_dir`` that loads whole (model,
    VecNormalize statistics, SAC's replay buffer), or None if the run has none. A newer one that
    does not load is renamed ``*.unreadable`` with a warning naming the file and the reason;
    ``ValueError`` naming them all if none loads."""
    algo_cls = ALGOS[settings.algo]
    failures: list[tuple[Path, str]] = []
    found = checkpoints(run_dir)
    for steps, ckpt in reversed(found):
        venv, current = None, ckpt
        try:
            vecnorm = None
            if hp.normalize is not None:
                vecnorm = current = checkpoint_file(run_dir, steps, "vecnormalize")
                if not vecnorm.exists():
                    raise FileNotFoundError("missing")
            venv = _make_venv(settings, hp, run_dir, str(vecnorm) if vecnorm else None)
            current = ckpt
            model = algo_cls.load(ckpt, env=venv, device="cpu", tensorboard_log=str(run_dir / "tb"))
            if settings.algo == "sac":
                current = checkpoint_file(run_dir, steps, "replay_buffer")
                if not current.exists():
                    raise FileNotFoundError("missing")
                model.load_replay_buffer(str(current))
        except Exception as exc:  # a damaged file fails in many ways (zipfile, pickle, torch, SB3 asserts)
            if venv is not None:
                venv.close()
            reason = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
            failures.append((current, reason))
            warnings.warn(f"checkpoint file {current} cannot be loaded ({reason}); trying an older one",
                          RuntimeWarning, stacklevel=2)  # fmt: skip
            continue
        for newer, zip_path in found:  # set the broken newer ones aside: their steps will be redone
            if newer > steps:
                zip_path.rename(zip_path.with_name(zip_path.name + ".unreadable"))
        return steps, model, venv
    if failures:
        listing = "; ".join(f"{p}: {r}" for p, r in failures)
        raise ValueError(f"no checkpoint of {run_dir} loads ({listing})")
    return None


def _clear_unstarted(run_dir: Path) -> None:
    """Remove what a run stopped before its first checkpoint left (see :func:`check_new_run_dir`)."""
    if not run_dir.exists():
        return
    check_new_run_dir(run_dir)
    for name in UNSTARTED_RUN:
        path = run_dir / name
        if path.is_dir():
            shutil.rmtree(path)
        elif path.exists():
            path.unlink()


def train(settings: TrainSettings, *, _resume: bool = False) -> TrainResult:
    """Train (or, through :func:`resume`, continue) a run; return its folder, model and summary.

    Raises :class:`TrainingInterrupted` after saving a checkpoint if SIGINT or SIGTERM arrives
    (in the main thread)."""
    with stop_on_signals() as stop:
        return _train(settings, stop, _resume)


def _train(settings: TrainSettings, stop: StopFlag, _resume: bool) -> TrainResult:
    import torch
    from stable_baselines3.common.callbacks import CallbackList
    from stable_baselines3.common.utils import set_random_seed

    from agents.callbacks import Clock, RateEvalCallback, TimedCheckpointCallback, replace_into

    settings.validate()
    torch.set_num_threads(1)
    hp = load_hyperparams(settings.algo, settings.env_id, settings.hyperparams_file)
    settings.n_envs = settings.n_envs or hp.n_envs
    total = settings.timesteps or hp.n_timesteps
    run_dir = Path(settings.out) if settings.out else RUNS_DIR / run_name(settings)
    settings.out = str(run_dir)
    ckpt_dir = run_dir / "checkpoints"
    algo_cls = ALGOS[settings.algo]

    clock, history, start_steps = Clock(), [], 0
    loaded = load_checkpoint(run_dir, settings, hp) if _resume else None
    if loaded is not None:
        start_steps, model, venv = loaded
        prior, history = _read_progress(run_dir, start_steps)
        clock = Clock(prior)
        if total < start_steps:
            venv.close()
            raise ValueError(
                f"timesteps: the run is at {start_steps} steps already; the total must be at least that, "
                f"got {total}"
            )
        record_resume(run_dir, start_steps, total)
    else:
        if _resume:
            print(f"{run_dir} holds no checkpoint: starting it again from step 0 with its own settings",
                  file=sys.stderr)  # fmt: skip
        _clear_unstarted(run_dir)
        run_dir.mkdir(parents=True, exist_ok=True)
        set_random_seed(settings.seed)
        venv = _make_venv(settings, hp, run_dir, None)
        model = algo_cls(
            hp.policy,
            venv,
            seed=settings.seed,
            verbose=0,
            device="cpu",
            tensorboard_log=str(run_dir / "tb"),
            **hp.model_kwargs,
        )
        write_config(run_dir, settings, hp, total)
    resumed = loaded is not None

    clock.start()
    checkpoint = TimedCheckpointCallback(
        settings.checkpoint_freq,
        ckpt_dir,
        clock,
        history,
        stop=stop,
        name_prefix=CHECKPOINT_PREFIX,
        save_replay_buffer=settings.algo == "sac",
        save_vecnormalize=hp.normalize is not None,
    )
    evaluation = RateEvalCallback(
        settings.eval_freq, settings.env_id, settings.env_kwargs, clock, history, repeat=hp.repeat
    )
    print(f"training {run_dir}: step {start_steps} of {total}", file=sys.stderr, flush=True)
    model.learn(
        total_timesteps=max(0, total - start_steps),
        callback=CallbackList([*hp.callbacks, checkpoint, evaluation]),
        tb_log_name=settings.algo.upper(),
        reset_num_timesteps=not resumed,
        progress_bar=settings.progress_bar,
    )
    if checkpoint.stopped_at is not None:  # SIGINT / SIGTERM: keep this moment, then stop
        path = checkpoint.save()
        venv.close()
        assert stop.signum is not None
        raise TrainingInterrupted(stop.signum, run_dir, checkpoint.stopped_at, path, int(model.num_timesteps))
    checkpoint.save()  # the final state too, so that --resume can extend a finished run
    seconds = clock.seconds()
    model_path = run_dir / "model.zip"
    replace_into(model_path, model.save)
    if hp.normalize is not None:
        import pickle

        atomic_write_bytes(run_dir / "vecnormalize.pkl", pickle.dumps(model.get_vec_normalize_env()))
    if history and history[-1]["steps"] == model.num_timesteps:
        history.pop()  # evaluated during the last rollout, before the last update: not the saved model
    final = evaluation.evaluate()
    summary = {
        "steps": int(model.num_timesteps),
        "wall_time_s": round(seconds, 2),
        "steps_per_s": round((model.num_timesteps - start_steps) / max(seconds - clock.prior, 1e-9), 1),
        "final_eval": final,
        "eval_history": history,
    }
    atomic_write_text(run_dir / "summary.json", json.dumps(summary, indent=1))
    venv.close()
    return TrainResult(run_dir, model_path, summary)


def record_resume(run_dir: Path, steps: int, total: int) -> None:
    """Note a resume in ``config.json``: the steps it started from and the total it aims at
    (``total_timesteps`` becomes that total; the rest of the config is kept)."""
    config = read_config(run_dir)
    config.setdefault("resumes", []).append(
        {
            "from_steps": steps,
            "total_timesteps": total,
            "command": sys.argv,
            "time": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        }  # fmt: skip
    )
    config["total_timesteps"] = total
    config["args"]["timesteps"] = total
    atomic_write_text(run_dir / "config.json", json.dumps(config, indent=1, default=str))


def write_config(run_dir: Path, settings: TrainSettings, hp: Hyperparams, total: int) -> Path:
    """Write the resolved configuration ``config.json`` atomically."""
    env = gym.make(settings.env_id, **settings.env_kwargs)
    base = env.unwrapped
    config = {
        "algo": settings.algo,
        "env_id": settings.env_id,
        "seed": settings.seed,
        "total_timesteps": total,
        "n_envs": settings.n_envs,
        "vec_env": settings.vec_env,
        "env_kwargs": settings.env_kwargs,
        "args": dataclasses.asdict(settings),
        "hyperparams": hp.raw,
        "hyperparams_file": str(settings.hyperparams_file or f"agents/hyperparams/{settings.algo}.yml"),
        "scenario": base.config.to_dict(),
        "arrival_guard": base.arrival_guard,
        "channel": base.channel,
        "versions": versions(),
        "command": sys.argv,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }
    env.close()
    return atomic_write_text(run_dir / "config.json", json.dumps(config, indent=1, default=str))


def resume(run_dir: str | Path, *, timesteps: int | None = None, progress_bar: bool = True) -> TrainResult:
    """Continue the run in ``run_dir`` from its newest checkpoint that loads (same folder, same
    settings; from step 0 if it has none); ``timesteps`` changes the total number of steps
    (default: the run's own) and must not be below the steps already done (``ValueError``)."""
    run_dir = check_resumable(run_dir)
    config = read_config(run_dir)
    done = max((steps for steps, _ in checkpoints(run_dir)), default=0)
    if timesteps is not None and timesteps < done:
        raise ValueError(
            f"timesteps: {run_dir} is at {done} steps already (its total is {config['total_timesteps']}); "
            f"the new total must be at least {done}, got {timesteps}"
        )
    args = config["args"]
    args.update(out=str(run_dir), progress_bar=progress_bar)
    args["timesteps"] = config["total_timesteps"] if timesteps is None else timesteps
    return train(TrainSettings(**args), _resume=True)
