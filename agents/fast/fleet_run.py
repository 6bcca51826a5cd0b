"""A fast IPPO run on fleets (:mod:`agents.fast.fleet`): the run folder of :mod:`agents.fast.run`.

:func:`train_fleet` reads the recipe (``agents/hyperparams/fast_ippo_fleet.yml``, the entry
:data:`agents.fast.fleet.FLEET_KEY`: PPO's keys, ``n_envs`` the fleets, ``env_kwargs`` the fleets'
arguments, ``ios_uav_env.parallel_env``'s), trains ``FastPPO`` on the fleets' rows and writes the
folder a fast run writes (``agents.fast.run.run_loop``): ``config.json`` (with the fleets'
arguments and scenario under ``fleet``), ``progress.csv`` (``episode_score`` the fleets' team
max-min rate, once per fleet), ``checkpoints/``, ``model.zip`` (an SB3 PPO: one agent's policy),
``vecnormalize.pkl`` and ``summary.json``, whose evaluations are the policy's deterministic
flights of one fleet (:func:`agents.fast.fleet.fly_fleet`, seed 0): ``score`` the team's
``min_rate``, ``best_schedule_rate`` the same flights' best schedule. SIGINT / SIGTERM saves a
checkpoint and raises ``TrainingInterrupted``; a fleet run is not resumed (a new run starts over).
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from agents.fast.fleet import FLEET_KEY, FLEET_SCORE, FleetSpec, check_recipe, fly_fleet, policy_act
from agents.fast.recipe import FastRecipe
from agents.hyperparams import Hyperparams, load_hyperparams
from agents.training.resuming import TrainResult

#: The fleets' recipe file.
FLEET_HYPERPARAMS = Path(__file__).resolve().parents[1] / "hyperparams" / "fast_ippo_fleet.yml"


@dataclass
class FleetSettings:
    """A fleet run's settings (``examples/fast_ippo_fleet.py``'s arguments)."""

    timesteps: int | None = None  # agent steps; None = the recipe's n_timesteps
    seed: int = 0  # torch, the model, the fleets (fleet b seeded seed + b)
    n_envs: int | None = None  # fleets stepped at once; None = the recipe's n_envs
    env_kwargs: dict[str, Any] = field(default_factory=dict)  # over the recipe's, key by key
    out: str | None = None  # run folder; None = runs/fleet_ippo__<seed>__<time>
    hyperparams_file: str | None = None  # None = FLEET_HYPERPARAMS
    checkpoint_freq: int = 1_000_000  # agent steps between checkpoints
    eval_freq: int = 0  # agent steps between deterministic flights (0: at the end only)
    progress_bar: bool = True
    threads: int | None = None  # torch threads; None = 1
    env_threads: int | None = 1  # the fleets' kernel threads
    update: str = "auto"  # FastPPO's update: auto, kernel or torch

    def validate(self) -> None:
        """``ValueError`` naming the first field out of its range."""
        for name in ("timesteps", "n_envs", "checkpoint_freq", "threads", "env_threads"):
            value = getattr(self, name)
            if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < 1):
                raise ValueError(f"{name} must be an integer >= 1 or None, got {value!r}")
        for name in ("seed", "eval_freq"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise ValueError(f"{name} must be an integer >= 0, got {value!r}")
        if not isinstance(self.env_kwargs, dict):
            raise TypeError(f"env_kwargs must be a dict, got {type(self.env_kwargs).__name__}")

    def hyperparams(self) -> tuple[Hyperparams, FastRecipe, FleetSpec]:
        """The recipe's entry, the fast recipe (``n_envs`` fleets) and the fleets it trains on."""
        path = self.hyperparams_file or FLEET_HYPERPARAMS
        hp = load_hyperparams("ppo", FLEET_KEY, path)
        spec = FleetSpec({**hp.env_kwargs, **self.env_kwargs})
        fleets = self.n_envs or hp.n_envs
        try:  # checked on the rollout's agent rows (batch_size up to fleets x U x n_steps)
            recipe = FastRecipe.from_hyperparams(hp, fleets * spec.uavs)
            check_recipe(recipe)
        except ValueError as exc:
            raise ValueError(f"{path}, {FLEET_KEY}: {exc}") from None
        return hp, dataclasses.replace(recipe, n_envs=fleets), spec


def train_fleet(settings: FleetSettings) -> TrainResult:
    """Train IPPO with shared parameters on the fleets of ``settings`` (module docstring); its
    folder, model and summary. ``ValueError`` naming a bad setting before anything is written."""
    import torch
    from stable_baselines3.common.utils import set_random_seed

    from agents.callbacks import Clock
    from agents.fast.ppo import FastPPO
    from agents.fast.run import run_loop, torch_threads
    from agents.training.folder import check_new_run_dir, lock_run_dir
    from agents.training.interrupt import stop_on_signals
    from agents.training.resuming import RunStart

    settings.validate()
    hp, recipe, spec = settings.hyperparams()
    total = settings.timesteps or hp.n_timesteps
    out = settings.out or f"runs/fleet_ippo__{settings.seed}__{int(time.time())}"
    run_dir = check_new_run_dir(out)
    with stop_on_signals() as stop, lock_run_dir(run_dir):
        torch.set_num_threads(torch_threads(settings.threads))
        set_random_seed(settings.seed)
        algo = FastPPO(spec, recipe, total, seed=settings.seed, env_threads=settings.env_threads,
                       update=settings.update)  # fmt: skip
        try:
            _write_config(run_dir, settings, hp, spec, total, recipe.n_envs, algo.recipe.n_envs)
            start = RunStart(algo.model, algo, 0, Clock(), [])

            def evaluate() -> dict[str, Any]:
                flight = fly_fleet(policy_act(algo.model, algo.vecnormalize), spec, seed=0)
                label = {"score_name": FLEET_SCORE.name, "score_unit": FLEET_SCORE.unit}
                return {"steps": int(algo.steps), "wall_time_s": round(start.clock.seconds(), 2),
                        "score": flight.min_rate, **label, "best_schedule_rate": flight.best_schedule_rate,
                        "feasible": flight.feasible, "terminal_miss": flight.terminal_miss}  # fmt: skip

            return run_loop(settings, run_dir, algo, start, total, stop, evaluate)
        finally:
            algo.close()


def _write_config(
    run_dir: Path,
    settings: FleetSettings,
    hp: Hyperparams,
    spec: FleetSpec,
    total: int,
    fleets: int,
    rows: int,
) -> None:
    """``config.json``: the run's settings, recipe, fleets (``n_envs`` of them, ``rows`` agent rows)."""
    from agents.training.folder import normalized, versions
    from ios_uav_env.io import atomic_write_text

    config = {
        "algo": "ppo",
        "trainer": "fast",
        "env": FLEET_KEY,
        "fleet": spec.to_dict(),
        "seed": settings.seed,
        "total_timesteps": total,
        "n_envs": fleets,
        "rows": rows,
        "args": dataclasses.asdict(settings),
        "hyperparams": hp.raw,
        "hyperparams_file": str(settings.hyperparams_file or FLEET_HYPERPARAMS),
        "normalize": normalized(hp),
        "versions": versions(),
        "command": sys.argv,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }
    atomic_write_text(run_dir / "config.json", json.dumps(config, indent=1, default=str))
