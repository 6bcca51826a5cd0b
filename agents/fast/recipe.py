"""A fast-trainer recipe: one zoo-format entry (the keys of ``agents/hyperparams/*.yml``) read as
the settings of :class:`agents.fast.ppo.FastPPO`.

The fast trainer reads the same file format as ``train.py``'s SB3 path, so a recipe is checked by
the same code (``agents.hyperparams.load_hyperparams`` with ``algo="ppo"``) and its keys mean what
they mean for SB3's PPO: ``n_envs`` rows of the batched env, ``n_steps`` slots per rollout,
minibatches of ``batch_size``, ``n_epochs`` passes, ``gamma``, ``gae_lambda``, ``learning_rate``
and ``clip_range`` (a number or ``lin_<number>``), ``ent_coef``, ``vf_coef``,
``max_grad_norm``, ``target_kl``, ``normalize_advantage``, ``policy_kwargs`` (the SB3 policy is
the network), ``normalize`` (VecNormalize's statistics and rules). Of the zoo's ``callback`` and
``env_wrapper`` keys the trainer honours the ones whose effect it reproduces on arrays
(:data:`CALLBACKS`, :data:`WRAPPERS`: their ``agents.tricks`` forms, checked here) and refuses
any other by name. A ``CloneStart`` expert is
checked on the run's env with the recipe (:func:`checked_expert`), before the run writes anything.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from agents.hyperparams import Hyperparams
from agents.tricks import ExploringStarts, RewardShift, check_frames

#: PPO keyword arguments the fast trainer reads (every other PPO argument is refused by name).
PPO_KEYS = (
    "n_steps", "batch_size", "n_epochs", "gamma", "gae_lambda", "learning_rate", "clip_range",
    "ent_coef", "vf_coef", "max_grad_norm", "target_kl", "normalize_advantage", "policy_kwargs",
)  # fmt: skip
#: Callbacks of the zoo's ``callback`` key the trainer applies itself (by their parameters).
CALLBACKS = (
    "agents.callbacks.LogStdSchedule",
    "agents.callbacks.ExploringStartsSchedule",
    "agents.callbacks.CloneStart",
)
#: Wrappers of the zoo's ``env_wrapper`` key the trainer applies on the batched env's arrays
#: (``agents.tricks.ExploringStarts``, ``RewardShift`` and ``FrameStack``; the action repeat is not
#: one of them).
WRAPPERS = ("agents.wrappers.ExploringStarts", "agents.wrappers.ShiftReward", "agents.wrappers.FrameStack")


def _name(obj: Any) -> str:
    cls = obj if isinstance(obj, type) else type(obj)
    return f"{cls.__module__}.{cls.__qualname__}"


@dataclass(frozen=True)
class Schedule:
    """A value over the run: ``initial``, linearly down to 0 at the end if ``linear`` (SB3's
    ``lin_`` schedules: ``value(progress_remaining) = progress_remaining * initial``)."""

    initial: float
    linear: bool = False

    def __call__(self, progress_remaining: float) -> float:
        return self.initial * progress_remaining if self.linear else self.initial

    @classmethod
    def of(cls, value: Any, name: str) -> Schedule:
        """The schedule of a resolved hyperparameter (a number or SB3's linear schedule function)."""
        if callable(value):  # agents.hyperparams' lin_ schedule: value(1) is the initial value
            return cls(float(value(1.0)), linear=math.isclose(value(0.5), 0.5 * value(1.0)))
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
            raise ValueError(f"hyperparameter {name} must be > 0, got {value!r}")
        return cls(float(value))


@dataclass(frozen=True)
class CloneSettings:
    """``agents.callbacks.CloneStart``'s arguments, checked (what they do: ``agents.fast.clone``)."""

    expert: str  # PKG.MODULE:ATTR of the expert (ios_uav_env.benchmark.cli.load_policy)
    rounds: int = 4  # rounds of data (round 0 by the expert, then DAgger)
    slots: int = 128  # slots of every row per round
    epochs: int = 8  # passes over the data after each round
    learning_rate: float = 1e-3  # Adam's step size of the fit
    noise: float = 0.3  # std of the noise on round 0's moves (units of D)
    batch_size: int = 4096  # minibatch of the fit (samples)

    def __post_init__(self) -> None:
        if not isinstance(self.expert, str) or ":" not in self.expert:
            raise ValueError(f"CloneStart expert must be PKG.MODULE:ATTR, got {self.expert!r}")
        for name in ("rounds", "slots", "epochs", "batch_size"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"CloneStart {name} must be an integer >= 1, got {value!r}")
        for name, positive in (("learning_rate", True), ("noise", False)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"CloneStart {name} must be a finite number, got {value!r}")
            if value < 0 or (positive and value == 0):
                raise ValueError(f"CloneStart {name} must be {'> 0' if positive else '>= 0'}, got {value!r}")


@dataclass(frozen=True)
class FastRecipe:
    """The resolved settings of one fast-trainer run (see the module docstring)."""

    n_envs: int  # B, rows of the batched env
    n_steps: int  # slots per rollout: a rollout is n_envs * n_steps env steps
    batch_size: int  # minibatch size (samples)
    n_epochs: int  # passes over each rollout
    gamma: float  # discount
    gae_lambda: float  # GAE lambda
    learning_rate: Schedule  # Adam's step size
    clip_range: Schedule  # PPO's ratio clip
    ent_coef: float = 0.0
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5
    target_kl: float | None = None  # stop an update's epochs once the KL passes 1.5 x this
    normalize_advantage: bool = True  # per minibatch, as SB3
    policy_kwargs: dict[str, Any] = field(default_factory=dict)
    normalize: dict[str, Any] | None = None  # VecNormalize's arguments (None: raw observations and rewards)
    log_std: tuple[float, float] | None = None  # LogStdSchedule (start, end): log std set, not learned
    exploring: dict[str, Any] | None = None  # ExploringStarts' arguments
    exploring_schedule: tuple[float, float] | None = None  # ExploringStartsSchedule (hold, end)
    reward_shift: tuple[float, float] | None = None  # ShiftReward (offset, scale)
    clone: CloneSettings | None = None  # CloneStart: behaviour cloning before PPO (agents.fast.clone)
    frames: int = 1  # FrameStack: the policy sees the last `frames` observations (1: the current one)

    @property
    def rollout_size(self) -> int:
        return self.n_envs * self.n_steps

    @classmethod
    def from_hyperparams(
        cls, hp: Hyperparams, n_envs: int | None = None, env_id: str | None = None,
        env_kwargs: Mapping[str, Any] | None = None,
    ) -> FastRecipe:  # fmt: skip
        """The recipe of a resolved zoo entry (``agents.hyperparams.load_hyperparams("ppo", ...)``);
        ``ValueError`` naming the key the fast trainer cannot honour. With ``env_id`` (and the run's
        ``env_kwargs``), a ``CloneStart`` expert is checked on that env too (:func:`checked_expert`)."""
        kwargs = dict(hp.model_kwargs)
        unknown = sorted(set(kwargs) - set(PPO_KEYS))
        if unknown:
            raise ValueError(
                f"hyperparameter {unknown[0]!r} is not read by the fast trainer "
                f"(it reads {', '.join(PPO_KEYS)})"
            )
        if hp.policy != "MlpPolicy":
            raise ValueError(
                f"hyperparameter policy must be 'MlpPolicy' for the fast trainer, got {hp.policy!r}"
            )
        log_std = exploring_schedule = exploring = shift = clone = None
        frames = 1
        for callback in hp.callbacks:
            name = _name(callback)
            if name == CALLBACKS[0]:
                log_std = (callback.start, callback.end)
            elif name == CALLBACKS[1]:
                exploring_schedule = (callback.hold, callback.end)
            elif name == CALLBACKS[2]:
                clone = callback.settings
            else:
                raise ValueError(
                    f"hyperparameter callback {name!r} is not applied by the fast trainer (it applies "
                    f"{', '.join(CALLBACKS)})"
                )
        for wrapper, wrapper_kwargs in hp.env_wrappers:
            name = _name(wrapper)
            if name == WRAPPERS[0]:
                ExploringStarts(**wrapper_kwargs)  # checked now (ValueError naming the field)
                exploring = dict(wrapper_kwargs)
            elif name == WRAPPERS[1]:
                trick = RewardShift(**wrapper_kwargs)
                shift = (trick.offset, trick.scale)
            elif name == WRAPPERS[2]:
                frames = check_frames(dict(wrapper_kwargs).get("frames", 4))
            else:
                raise ValueError(
                    f"hyperparameter env_wrapper {name!r} is not applied by the fast trainer (it applies "
                    f"{', '.join(WRAPPERS)})"
                )
        if exploring_schedule is not None and exploring is None:
            raise ValueError(f"hyperparameter callback {CALLBACKS[1]!r} needs {WRAPPERS[0]!r} in env_wrapper")
        recipe = cls(
            n_envs=int(n_envs or hp.n_envs),
            n_steps=int(kwargs.get("n_steps", 16)),
            batch_size=int(kwargs.get("batch_size", 4096)),
            n_epochs=int(kwargs.get("n_epochs", 4)),
            gamma=float(kwargs.get("gamma", 0.99)),
            gae_lambda=float(kwargs.get("gae_lambda", 0.95)),
            learning_rate=Schedule.of(kwargs.get("learning_rate", 3e-4), "learning_rate"),
            clip_range=Schedule.of(kwargs.get("clip_range", 0.2), "clip_range"),
            ent_coef=float(kwargs.get("ent_coef", 0.0)),
            vf_coef=float(kwargs.get("vf_coef", 0.5)),
            max_grad_norm=float(kwargs.get("max_grad_norm", 0.5)),
            target_kl=None if kwargs.get("target_kl") is None else float(kwargs["target_kl"]),
            normalize_advantage=bool(kwargs.get("normalize_advantage", True)),
            policy_kwargs=dict(kwargs.get("policy_kwargs") or {}),
            normalize=None if hp.normalize is None else dict(hp.normalize),
            log_std=log_std,
            exploring=exploring,
            exploring_schedule=exploring_schedule,
            reward_shift=shift,
            clone=clone,
            frames=frames,
        )
        recipe.validate()
        if recipe.clone is not None and env_id is not None:
            checked_expert(recipe.clone.expert, env_id, env_kwargs or {})
        return recipe

    def validate(self) -> None:
        """``ValueError`` naming the first field out of its range."""
        if self.n_envs < 1 or self.n_steps < 1 or self.n_epochs < 1:
            raise ValueError(
                f"n_envs, n_steps and n_epochs must be >= 1, "
                f"got {self.n_envs}, {self.n_steps}, {self.n_epochs}"
            )
        if not 2 <= self.batch_size <= self.rollout_size:
            raise ValueError(
                f"batch_size must be in [2, n_envs * n_steps = {self.rollout_size}], got {self.batch_size}"
            )
        for name in ("gamma", "gae_lambda"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {getattr(self, name)}")
        for name in ("ent_coef", "vf_coef", "max_grad_norm"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value}")
        if self.target_kl is not None and not self.target_kl > 0:
            raise ValueError(f"target_kl must be > 0 or unset, got {self.target_kl}")


#: An expert: (B, obs) observations -> (B, action) actions.
Expert = Callable[[np.ndarray], np.ndarray]


def load_expert(spec: str) -> Expert:
    """The expert of ``spec`` (``ValueError`` naming it if it does not load or is not callable)."""
    from ios_uav_env.benchmark.cli import load_policy

    try:
        expert = load_policy(spec)
    except ValueError as exc:
        raise ValueError(f"CloneStart expert: {exc}") from None
    if not callable(expert):
        raise ValueError(f"CloneStart expert {spec!r} is not callable (observations -> actions)")
    return expert


def checked_expert(spec: str, env_id: str, env_kwargs: Mapping[str, Any]) -> Expert:
    """The expert of ``spec`` for the env ``env_id`` with ``env_kwargs`` (the run's), bound to its
    observation layout; ``ValueError`` naming the expert unless it loads (an unknown module or
    attribute named), the env publishes every observation feature it declares (each missing one
    named with the env argument that provides it, e.g. ``peak_hint=True``), and on a batch of the
    env's first observations (seeds 0 and 1) it returns finite actions of shape (2, action size)."""
    import gymnasium as gym

    expert = load_expert(spec)
    who, where = f"CloneStart expert {spec!r}", f"{env_id} with env_kwargs {dict(env_kwargs)}"
    env = gym.make(env_id, **env_kwargs)
    try:
        names = getattr(env.unwrapped, "observation_names", None)
        needed = tuple(getattr(expert, "observation_features", ()) or ())
        if needed:  # read by name: checked against the env's layout, then bound to it
            from ios_uav_env.envs.observation_layout import require_features

            require_features(needed, names, who, where)
            if callable(getattr(expert, "bind", None)):
                expert = expert.bind(names)
        batch = np.stack([env.reset(seed=seed)[0] for seed in (0, 1)])
        shape = (2, *env.action_space.shape)
    finally:
        env.close()
    try:
        actions = np.asarray(expert(batch), dtype=np.float64)
    except Exception as exc:  # the expert's own failure on this env's observations
        raise ValueError(f"{who} fails on the observations of {where}: {type(exc).__name__}: {exc}") from exc
    if actions.shape != shape:
        raise ValueError(
            f"{who} returns actions of shape {actions.shape} for a batch of {shape[0]} observations of "
            f"{where}; the env's actions need shape {shape}"
        )
    if not np.all(np.isfinite(actions)):
        raise ValueError(f"{who} returns non-finite actions (NaN or inf) on the first observations of "
                         f"{where}")  # fmt: skip
    return expert
