"""The settings of an imitation run (``python -m agents.imitation``), and the checks of a resumed one.

:class:`ImitationSettings` holds every argument of a run, each field the CLI's argument of that
name, and :meth:`ImitationSettings.validate` refuses a bad one by name before a run computes or
writes anything. :func:`check_resume` records a run's settings in ``out/settings.json`` or checks
them against the recorded ones (a resumed run may change :data:`RESUMABLE`, and :data:`LATE`
while no finished round is a hindsight round); :func:`finished_rounds` reads how many rounds a
run has finished, and :func:`naming` names the file of a failed write.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from agents.expert import FIRST_SEED, RANDOM_ID
from ios_uav_env.io import atomic_write_text

#: The largest seed: the model's seed goes to ``np.random.seed``, which takes 32 bits.
MAX_SEED = 2**32 - 1
#: The policy networks a run can train: SB3's MLP over the whole observation, or the node-set
#: actor of ``agents.node_set`` (the same weights for every node; its statistics pooled over the
#: nodes).
POLICIES = ("mlp", "node-set")


@dataclass(frozen=True)
class ImitationSettings:
    """Everything a run needs; the fields are the CLI's arguments."""

    out: str  # run folder
    scenarios: int = 6000  # training scenarios (tour plans)
    rounds: int = 5  # round 0 (the expert's episodes) and rounds - 1 DAgger rounds
    noise: float = 0.3  # std of the move noise of round 0's second pass (units of D)
    epochs: int = 12  # passes over all the labels so far, each round
    batch_size: int = 2048
    learning_rate: float = 1e-3
    net_arch: tuple[int, ...] = (256, 256)
    log_std_init: float = -2.0  # the Gaussian's log std, for PPO fine-tuning
    env_kwargs: dict[str, Any] = field(default_factory=lambda: {"softmin_beta": 20, "peak_hint": True})
    first_seed: int = FIRST_SEED
    seed: int = 0  # torch, the noise and the batch order
    jobs: int | None = None  # planner processes (default: all cores)
    plans: str | None = None  # cache folder of the tour plans (default out/plans)
    progress: bool = True
    hindsight_from: int | None = None  # first round labelled by hindsight shares (None: never)
    hindsight_block: int = 5  # slots between the re-solves of the hindsight labels
    polish_epochs: int = 0  # after the last round: passes with the nodes in random order (0: none)
    permute: bool = False  # every round's fit sees each batch's nodes in a random order, too
    round_fraction: float = 1.0  # of each DAgger round's labelled states, the share kept (random)
    polish_learning_rate: float = 5e-4
    policy: str = "mlp"  # "mlp": SB3's MlpPolicy; "node-set": agents.node_set's equivariant actor (shipped)

    def validate(self) -> None:
        """``ValueError`` naming the first bad field (``OSError`` subclasses for an ``out`` or
        ``plans`` folder that cannot be written): every field is checked, the env made with
        ``env_kwargs`` and reset, before a run computes or writes anything."""
        if not isinstance(self.out, str) or not self.out:
            raise ValueError(f"out: must be a folder path, got {self.out!r}")
        for name in ("scenarios", "rounds", "epochs", "batch_size", "hindsight_block"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name}: must be an integer >= 1, got {value!r}")
        if not (isinstance(self.noise, (int, float)) and np.isfinite(self.noise) and self.noise >= 0):
            raise ValueError(f"noise: must be a finite number >= 0 (units of D), got {self.noise!r}")
        if not (isinstance(self.learning_rate, (int, float)) and 0 < self.learning_rate < 1):
            raise ValueError(f"learning_rate: must be in (0, 1), got {self.learning_rate!r}")
        if not self.net_arch or any(not isinstance(w, int) or w < 1 for w in self.net_arch):
            raise ValueError(f"net_arch: must be layer widths >= 1, got {self.net_arch!r}")
        if (
            isinstance(self.polish_epochs, bool)
            or not isinstance(self.polish_epochs, int)
            or self.polish_epochs < 0
        ):
            raise ValueError(f"polish_epochs: must be an integer >= 0, got {self.polish_epochs!r}")
        if not (isinstance(self.polish_learning_rate, (int, float)) and 0 < self.polish_learning_rate < 1):
            raise ValueError(f"polish_learning_rate: must be in (0, 1), got {self.polish_learning_rate!r}")
        f = self.round_fraction
        if isinstance(f, bool) or not (isinstance(f, (int, float)) and 0 < f <= 1):
            raise ValueError(f"round_fraction: must be in (0, 1] (the share of states kept), got {f!r}")
        if self.policy not in POLICIES:
            raise ValueError(f"policy: must be one of {', '.join(POLICIES)}, got {self.policy!r}")
        if not isinstance(self.permute, bool):
            raise ValueError(f"permute: must be True or False, got {self.permute!r}")
        h = self.hindsight_from
        if h is not None and (isinstance(h, bool) or not isinstance(h, int) or h < 1):
            raise ValueError(f"hindsight_from: must be None or a round >= 1 (a policy's round), got {h!r}")
        for name, high in (("seed", MAX_SEED), ("first_seed", None)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= (high or value):
                allowed = f"in [0, {high}]" if high else ">= 0"
                raise ValueError(f"{name}: must be an integer {allowed}, got {value!r}")
        j = self.jobs
        if j is not None and (isinstance(j, bool) or not isinstance(j, int) or j < 1):
            raise ValueError(f"jobs: must be None (all cores) or an integer >= 1, got {j!r}")
        if not (isinstance(self.log_std_init, (int, float)) and np.isfinite(self.log_std_init)):
            raise ValueError(f"log_std_init: must be a finite number, got {self.log_std_init!r}")
        if not isinstance(self.env_kwargs, dict) or not all(isinstance(k, str) for k in self.env_kwargs):
            raise ValueError(f"env_kwargs: must be a dict of env arguments by name, got {self.env_kwargs!r}")
        if "max_nodes" in self.env_kwargs or "random_nodes" in self.env_kwargs:
            raise ValueError("env_kwargs: max_nodes and random_nodes are the random id's own (2 to 4 nodes)")
        if self.env_kwargs.get("objective", "rate") != "rate":
            raise ValueError(
                f"env_kwargs: objective={self.env_kwargs['objective']!r}: the expert (the tour heuristic) "
                "plans the max-min rate, and its scenarios have objective 'rate', which an env of another "
                "objective refuses; train an energy-efficiency policy with PPO instead (agents.node_set's "
                "NodeSetPolicy reads the energy features after the node blocks)"
            )
        try:
            json.dumps(self.env_kwargs)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"env_kwargs: must be JSON values (settings.json records them): {exc}") from None
        self._check_folders()
        from agents.training.settings import check_env_kwargs

        try:
            check_env_kwargs(RANDOM_ID, self.env_kwargs)
        except ValueError as exc:
            raise ValueError(f"env_kwargs: {exc}") from None

    def _check_folders(self) -> None:
        """``out`` and the plan cache can be written (and the cache, if it exists, read)."""
        from baselines.runner import check_writable

        for name, folder in (("out", self.out), ("plans", self.plans)):
            if folder is None:
                continue
            if not isinstance(folder, str) or not folder:
                raise ValueError(f"{name}: must be a folder path, got {folder!r}")
            path = Path(folder)
            try:
                check_writable(path)
            except OSError as exc:
                raise type(exc)(f"{name}: {exc}") from None
            if path.exists() and not os.access(path, os.R_OK | os.W_OK | os.X_OK):
                raise PermissionError(f"{name}: {path} cannot be read and written")


#: Settings a resumed run may change: they do not change what a finished round holds.
RESUMABLE = ("out", "rounds", "jobs", "plans", "progress", "polish_epochs", "polish_learning_rate")
#: Settings a resumed run may change while no finished round is at or after ``hindsight_from``.
LATE = ("hindsight_from", "hindsight_block")


def finished_rounds(out: str | Path) -> int:
    """How many rounds the run in ``out`` has finished (its ``summary.json``; 0 without one);
    ``ValueError`` naming the file if it cannot be read."""
    from agents.loading import read_json

    path = Path(out) / "summary.json"
    if not path.exists():
        return 0
    rounds = read_json(path).get("rounds")
    if not isinstance(rounds, list) or not all(isinstance(e, dict) and "round" in e for e in rounds):
        raise ValueError(f"{path}: rounds: must be a list of the finished rounds, got {rounds!r}")
    return len(rounds)


def check_resume(settings: ImitationSettings) -> None:
    """Record the run's settings in ``out/settings.json``, or check them against the recorded ones:
    ``ValueError`` naming every field that differs (other than :data:`RESUMABLE`, and :data:`LATE`
    while the hindsight rounds, before and now, all come after the finished rounds), or naming
    ``rounds`` if it is below the rounds already finished (a finished round is never dropped)."""
    from agents.loading import read_json

    path = Path(settings.out) / "settings.json"
    now = json.loads(json.dumps(asdict(settings)))  # tuples as lists, as recorded
    if path.exists():
        before = read_json(path)
        before.setdefault("hindsight_block", now["hindsight_block"])  # runs recorded before the field
        before.setdefault("permute", False)  # (likewise)
        before.setdefault("round_fraction", 1.0)  # (likewise)
        before.setdefault("policy", "mlp")  # (likewise)
        finished = finished_rounds(settings.out)
        if settings.rounds < finished:
            raise ValueError(
                f"rounds: {settings.out} has finished {finished} rounds already (its total is "
                f"{before.get('rounds')!r}); the new total must be at least {finished}, got {settings.rounds}"
            )
        starts = [h for h in (before.get("hindsight_from"), now["hindsight_from"]) if h is not None]
        free = RESUMABLE + (LATE if all(h >= finished for h in starts) else ())
        changed = sorted(k for k in now if k not in free and before.get(k) != now[k])
        if changed:
            diff = ", ".join(f"{k}: {before.get(k)!r} -> {now[k]!r}" for k in changed)
            where = settings.out
            raise ValueError(f"out: {where} holds a run with other settings ({diff}); use a new --out")
    with naming(path):
        atomic_write_text(path, json.dumps(now, indent=1))


@contextmanager
def naming(path: Path) -> Iterator[None]:
    """An ``OSError`` of a write without a file name (a full disk: ``File too large``, ``No space
    left on device``) names ``path``, the file being written."""
    try:
        yield
    except OSError as exc:
        if exc.filename is not None:
            raise
        raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from exc
