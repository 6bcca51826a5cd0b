"""A training sweep's trials (``python -m agents.sweep``): what each runs, the settings that
decide its record, and the records' table.

A :class:`Trial` is one ``train.py`` run: an algorithm, an env id, a seed and hyperparameter
overrides, named by them (its run folder ``OUT/runs/<trial>``). :func:`make_trials` is the
sweep's cartesian product (:func:`parse_overrides` reads ``--set KEY=VALUE``);
:func:`trial_hyperparams` writes a trial's hyperparameters (the shipped entry with its
overrides). :func:`trial_settings` is every setting of a trial's record, :func:`record_key` its
cache name, and :func:`check_run_folder` refuses a run folder of other settings or one another
process writes. :func:`dp_rate` is the DP optimum a record is compared with, where known, and
:func:`write_csv` writes the records as ``sweep.csv`` (:data:`CSV_COLUMNS`).
"""

from __future__ import annotations

import csv
import functools
import hashlib
import io
import itertools
import json
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from ios_uav_env.io import atomic_write_text

ROOT = Path(__file__).resolve().parents[1]
#: The shipped sweep of the figures (the DP optimum of each fixed id's default scenario).
DP_RESULTS = ROOT / "results" / "sweep.csv"
#: The DP scheme (``baselines.schemes``) of each fixed id; a scheme without a row in ``DP_RESULTS``
#: (the STAR id's ``dp-sta``: the paper's figures have no STAR surface) gives no % of DP.
DP_SCHEME = {
    "ios_uav_env/IOSUAV-v0": "dp-ia",
    "ios_uav_env/RISUAV-v0": "dp-ra",
    "ios_uav_env/UAV-v0": "dp-cuc",
    "ios_uav_env/STARUAV-v0": "dp-sta",
}
CSV_COLUMNS = (
    "trial", "algo", "env_id", "seed", "overrides", "average_rate", "pct_of_dp", "feasible", "steps",
    "wall_time_s", "run_dir",
)  # fmt: skip
#: The keys of a trial's record (a cached record without one of them is run again).
RECORD_KEYS = ("trial", "algo", "env_id", "seed", "overrides", "average_rate", "feasible", "steps")
#: The settings of a run folder that must match the sweep's for the folder to be read back or
#: continued, with the command-line argument of each.
RUN_FIELDS = {
    "algo": "--algos", "env_id": "--env", "seed": "--seeds", "vec_env": None, "env_kwargs": "--env-kwargs",
    "hyperparams": "--set", "eval_freq": "--eval-freq", "checkpoint_freq": "--checkpoint-freq",
}  # fmt: skip


@dataclass(frozen=True)
class Trial:
    """One run of the sweep."""

    algo: str
    env_id: str
    seed: int
    overrides: tuple[tuple[str, Any], ...] = ()  # hyperparameter (key, value), in the order given

    @property
    def name(self) -> str:
        """The run folder's name: env, algorithm, seed and overrides (hashed beyond 120 characters)."""
        parts = [self.env_id.rsplit("/", 1)[-1], self.algo, f"seed{self.seed}"]
        parts += [f"{k}-{v}" for k, v in self.overrides]
        name = re.sub(r"[^A-Za-z0-9_.=-]+", "-", "__".join(parts))
        if len(name) > 120:
            digest = hashlib.sha1(json.dumps(self.to_dict(), sort_keys=True).encode()).hexdigest()[:10]
            name = f"{name[:100]}__{digest}"
        return name

    @property
    def overrides_text(self) -> str:
        return ";".join(f"{k}={v}" for k, v in self.overrides)

    def to_dict(self) -> dict[str, Any]:
        return {"algo": self.algo, "env_id": self.env_id, "seed": self.seed,
                "overrides": [[k, v] for k, v in self.overrides]}  # fmt: skip

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Trial:
        return cls(
            data["algo"], data["env_id"], int(data["seed"]), tuple((k, v) for k, v in data["overrides"])
        )


def parse_overrides(items: Sequence[str] | None) -> dict[str, list[Any]]:
    """``KEY=VALUE`` items (the value read as YAML) to ``{key: [values]}``; a key given more than
    once gets all its values (a dimension of the sweep). ``ValueError`` naming a malformed item."""
    out: dict[str, list[Any]] = {}
    for item in items or []:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key.isidentifier() or not text.strip():
            raise ValueError(f"expected KEY=VALUE (e.g. learning_rate=1e-4), got {item!r}")
        try:
            value = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise ValueError(f"cannot read the value of {item!r} as YAML: {exc}") from None
        if isinstance(value, str) and re.fullmatch(r"[-+]?(\d+\.?\d*|\.\d+)[eE][-+]?\d+", value):
            value = float(value)  # YAML 1.1 reads 1e-4 (no dot) as a string
        if value not in out.setdefault(key, []):
            out[key].append(value)
    return out


def make_trials(
    algos: Sequence[str], env_ids: Sequence[str], seeds: Sequence[int], overrides: dict[str, list[Any]]
) -> list[Trial]:
    """The cartesian product of the algorithms, env ids, seeds and override values (each trial
    once, in that order)."""
    keys = list(overrides)
    combos = list(itertools.product(*(overrides[k] for k in keys)))
    trials = [
        Trial(algo, env_id, int(seed), tuple(zip(keys, combo, strict=True)))
        for algo, env_id, combo, seed in itertools.product(algos, env_ids, combos, seeds)
    ]
    return list({t.name: t for t in trials}.values())  # values may be lists: not hashable


def trial_entry(trial: Trial) -> dict[str, Any]:
    """The trial's hyperparameters as written: the shipped entry of its algorithm and env id with
    its overrides (``ValueError`` naming the file if it has no entry for the env id)."""
    from agents.hyperparams import hyperparams_path

    table = yaml.safe_load(hyperparams_path(trial.algo).read_text())
    if trial.env_id not in table:
        raise ValueError(
            f"env_id: {hyperparams_path(trial.algo)} has no hyperparameters for {trial.env_id!r}"
        )
    return {**table[trial.env_id], **dict(trial.overrides)}


def trial_hyperparams(trial: Trial, out: Path) -> Path | None:
    """``OUT/hyperparams/<trial>.yml``: the shipped entry of the trial's algorithm and env id with
    its overrides (None without overrides: the shipped file itself)."""
    if not trial.overrides:
        return None
    entry = trial_entry(trial)
    text = f"# {trial.name}: agents/hyperparams/{trial.algo}.yml with {trial.overrides_text}\n"
    return atomic_write_text(
        out / "hyperparams" / f"{trial.name}.yml", text + yaml.safe_dump({trial.env_id: entry})
    )


@functools.lru_cache(maxsize=1)
def _dp_rates() -> dict[str, float]:
    from ios_uav_env import ScenarioConfig

    config = ScenarioConfig()
    m = config.ios_shape[0] * config.ios_shape[1]
    try:
        rows = list(csv.DictReader(DP_RESULTS.open()))
    except OSError:
        return {}
    return {
        r["scheme"]: float(r["average_rate"])
        for r in rows
        if r["scheme"].startswith("dp") and float(r["T"]) == config.T and int(r["M"]) == m
    }


def dp_rate(env_id: str, env_kwargs: dict[str, Any]) -> float | None:
    """The DP optimum of the env's scenario if it is known (a fixed id with its default scenario)."""
    scenario_kwargs = {k for k in env_kwargs if k not in ("arrival_guard",)}
    if env_id not in DP_SCHEME or scenario_kwargs:
        return None
    return _dp_rates().get(DP_SCHEME[env_id])


def _plain(value: Any) -> Any:
    """``value`` as JSON reads it back (tuples as lists, other objects as their text)."""
    return json.loads(json.dumps(value, default=str))


def trial_settings(
    trial: Trial,
    *,
    timesteps: int,
    env_kwargs: dict[str, Any] | None = None,
    eval_freq: int = 10_000,
    checkpoint_freq: int = 25_000,
) -> dict[str, Any]:
    """Every setting that decides a trial's record (as JSON reads it back): the settings of its run
    folder (:data:`RUN_FIELDS`, the hyperparameters resolved from the shipped file and the
    overrides) and its total steps."""
    return _plain({
        "algo": trial.algo, "env_id": trial.env_id, "seed": trial.seed, "vec_env": "dummy",
        "env_kwargs": dict(env_kwargs or {}), "hyperparams": trial_entry(trial), "eval_freq": eval_freq,
        "checkpoint_freq": checkpoint_freq, "timesteps": timesteps,
    })  # fmt: skip


def check_run_folder(trial: Trial, out: str | Path, **settings: Any) -> Path:
    """``OUT/runs/<trial>`` if a sweep of these settings (:func:`trial_settings`'s keyword
    arguments) may read it back or continue it: it holds no run yet, or a run of the same
    settings (its total steps aside), and no other process is writing it. ``ValueError`` naming
    each setting that differs, with the run's value and the sweep's;
    :class:`agents.training.RunFolderInUse` naming the process that writes it."""
    from agents.training import check_unlocked, read_config

    run_dir = Path(out).resolve() / "runs" / trial.name
    check_unlocked(run_dir)
    if not (run_dir / "config.json").exists():
        return run_dir
    config = read_config(run_dir)
    have = {**config["args"], "hyperparams": config.get("hyperparams")}
    have.setdefault("vec_env", "dummy")
    wanted = trial_settings(trial, **settings)
    changed = [k for k in RUN_FIELDS if _plain(have.get(k)) != wanted[k]]
    if changed:
        listing = "; ".join(
            f"{k}{'' if RUN_FIELDS[k] is None else f' ({RUN_FIELDS[k]})'}: the run's {have.get(k)!r}, "
            f"this sweep's {wanted[k]!r}"
            for k in changed
        )
        raise ValueError(
            f"run folder {run_dir} holds a run of other settings ({listing}); its results are not this "
            "sweep's: use another --out (or remove the folder to train it again)"
        )
    return run_dir


def record_key(settings: dict[str, Any], trial: Trial) -> str:
    """A trial record's cache name: the trial, its total steps and a digest of every setting of
    it (:func:`trial_settings` of the trial with the sweep's ``settings``), so that a record is
    read back only by a sweep of the same settings."""
    text = json.dumps(trial_settings(trial, **settings), sort_keys=True)
    return f"{trial.name}__t{settings['timesteps']}__{hashlib.sha1(text.encode()).hexdigest()[:12]}"


def write_csv(records: Sequence[dict[str, Any]], path: str | Path) -> Path:
    """``sweep.csv``: one row per trial (:data:`CSV_COLUMNS`; % of DP empty when unknown)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(CSV_COLUMNS)
    for r in records:
        pct = "" if r["pct_of_dp"] is None else f"{r['pct_of_dp']:.4f}"
        writer.writerow([r["trial"], r["algo"], r["env_id"], r["seed"], r["overrides"],
                         f"{r['average_rate']:.8f}", pct, int(bool(r["feasible"])), r["steps"],
                         f"{r['wall_time_s']:.2f}", r["run_dir"]])  # fmt: skip
    return atomic_write_text(path, buffer.getvalue())
