"""Gymnasium wrappers for training (named in the zoo's ``env_wrapper`` key of a hyperparameter file).

They change what the learner sees, never the episode: trajectories, ``info`` and the
evaluation (``agents.rollout``, on the plain env) are those of the env. Each is a thin adapter
over its trick in ``agents.tricks`` (the one implementation, on the batched env's rows) applied
to one row, for the zoo and SB3's ``DummyVecEnv``; the batched env's forms are in
``agents.vec_env`` and the fast trainer's in ``agents.fast.ppo``.
"""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from agents import tricks
from agents.tricks import EXPLORE_BOX, StartsField, check_exploring, check_repeat, draw_targets
from ios_uav_env.envs.policies import move_toward

__all__ = [
    "EXPLORE_BOX", "ActionRepeat", "ExploringStarts", "FrameStack", "ShiftReward", "action_repeat",
    "apply_wrappers", "check_exploring", "check_repeat", "draw_targets", "memory_frames",
]  # fmt: skip


class ShiftReward(gym.RewardWrapper):
    """Reward ``scale * (reward - offset)``.

    Every episode of the fixed ids has exactly N - 1 steps, so subtracting a constant leaves
    the optimal policy unchanged, but it changes what a bootstrapped critic has to fit: with
    the raw rate (~2.4 bps/Hz per slot) SAC's Q-values run from ~190 at the start to ~2 at
    the end of an episode (gamma 0.99, 149 steps), and the differences between hover points (a few
    hundredths of a bps/Hz per slot) drown in that time trend. With ``offset`` near the
    rate of the best hover point the trend nearly vanishes and the critic spends its
    capacity on where to fly. The monitor (``monitor/``) still logs the env's own rewards.
    """

    def __init__(self, env: gym.Env, offset: float = 0.0, scale: float = 1.0) -> None:
        super().__init__(env)
        self.shift = tricks.RewardShift(offset, scale)

    @property
    def offset(self) -> float:
        """The shift's offset (``agents.tricks.RewardShift``)."""
        return self.shift.offset

    @property
    def scale(self) -> float:
        """The shift's scale (``agents.tricks.RewardShift``)."""
        return self.shift.scale

    def reward(self, reward: SupportsFloat) -> float:
        return float(self.shift(np.float64(reward)))


def action_repeat(spec: Any) -> int:
    """The ``repeat`` of the :class:`ActionRepeat` in a zoo ``env_wrapper`` value ("module.Class",
    or a list of names and {"module.Class": {kwargs}} mappings, as a run's ``config.json`` keeps
    it); 1 without one."""
    kwargs = _wrapper_kwargs(spec, ActionRepeat)
    return 1 if kwargs is None else check_repeat(kwargs.get("repeat", 1))


class ActionRepeat(gym.Wrapper):
    """Hold each action for ``repeat`` slots (fewer at the end of the episode), the rewards summed.

    The episode is the env's, slot by slot (trajectory, shares, the return); only the agent's
    decisions are ``repeat`` slots apart, so a 149-slot episode is 38 decisions at ``repeat=4``:
    fewer steps for the credit of a detour to travel, and exploration noise held for
    ``repeat`` slots moves the UAV ``repeat`` times as far. The agent must be rolled out the
    same way (``agents.loading.Agent.repeat``, read from the run's hyperparameters).
    """

    def __init__(self, env: gym.Env, repeat: int = 1) -> None:
        super().__init__(env)
        self.hold = tricks.ActionRepeat(repeat)
        self.repeat = self.hold.repeat

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        flags: list[tuple[bool, bool]] = []

        def advance(rows: np.ndarray) -> tuple[Any, np.ndarray, np.ndarray, dict[str, Any]]:
            obs, reward, terminated, truncated, info = self.env.step(action)
            flags.append((terminated, truncated))
            return obs, np.array([float(reward)]), np.array([terminated or truncated]), info

        obs, total, _, info = self.hold.step(advance, 1)
        return obs, float(total[0]), *flags[-1], info


class ExploringStarts(gym.Wrapper):
    """Begin an episode, with probability ``prob``, part-way through: after m ~ U{1..max_moves}
    hidden moves at full speed towards a point drawn uniformly in ``box`` (and hovering there),
    with equal shares, at most N - 3 of the episode's N - 1 moves (the arrival guard keeps the
    flight feasible). With ``peak_prob`` > 0 that share of the targets is a node's rate peak
    (drawn among the nodes) plus ``peak_noise`` m of Gaussian noise: starts where some node
    is served best, late in the flight (the points of the ``peak_hint`` features, which the
    policy is shown anyway; they say where a node alone is served best, not the route).

    The agent then starts from states its own policy rarely reaches yet (another hover point,
    late in the episode with some node under-served), so it can learn routes that plain starts
    rarely lead to (the multi-node runs: ``results/log.md``). A training wrapper: the episode's return
    and its scorer are the env's, the learner sees only the part after the prefix, and
    evaluation runs on the plain env. The draws come from the wrapper's own generator, seeded
    by ``reset(seed=...)`` (``agents.tricks.ExploringStarts`` on one row). The batched env's form
    is ``agents.vec_env.VecExploringStarts``; the prefix is flown by ``self.env.step``, so list
    this wrapper before (under) an ``ActionRepeat``.
    """

    prob = StartsField()
    max_moves = StartsField()
    box = StartsField()
    peak_prob = StartsField()
    peak_noise = StartsField()

    def __init__(
        self,
        env: gym.Env,
        prob: float = 0.5,
        max_moves: int = 110,
        box: Any = EXPLORE_BOX,
        peak_prob: float = 0.0,
        peak_noise: float = 25.0,
    ) -> None:
        super().__init__(env)
        self.starts = tricks.ExploringStarts(prob, max_moves, box, peak_prob, peak_noise)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        if seed is not None:
            self.starts.seed(seed)
        obs, info = self.env.reset(seed=seed, options=options)
        cfg = self.env.unwrapped.config
        rows, targets, moves = self.starts.draw(np.zeros(1, dtype=np.int64), lambda rows: [cfg])
        # one row: its prefix flown by the env's own steps (a single env has no batched fly)
        action = np.zeros(self.action_space.shape, dtype=np.float32)  # node scores 0: equal shares
        for _ in range(int(moves[0]) if rows.size else 0):
            action[:2] = move_toward(targets[0] - info["position"], cfg.D)
            obs, _, _, _, info = self.env.step(action)
        return obs, info


def _wrapper_kwargs(spec: Any, cls: type) -> dict[str, Any] | None:
    """The arguments of ``cls`` in a zoo ``env_wrapper`` value (None if it is not listed)."""
    for item in spec if isinstance(spec, list) else [spec] if spec else []:
        name, kwargs = next(iter(item.items())) if isinstance(item, dict) and len(item) == 1 else (item, {})
        if name == f"{__name__}.{cls.__name__}":
            return dict(kwargs or {})
    return None


class FrameStack(gym.Wrapper):
    """Memory in the observation: the last ``frames`` observations, oldest first, flattened into
    one vector of ``frames * d`` values (an episode's history begins as its first observation
    repeated). It is Gymnasium's ``FrameStackObservation(env, frames)`` followed by
    ``FlattenObservation``, written once on arrays of rows (``agents.tricks.FrameStack``) so that
    the batched env's form (``agents.vec_env.VecFrameStack``) and the fast trainer stack alike.

    A noisy position report, one slot at a time, says where the node was told to be; several
    slots of them say where it is heading and how far each report is to be trusted. A model
    trained with it is flown on the plain env with its memory kept beside it
    (``agents.loading.Agent.memory``, ``agents.tricks.History``), so that the benchmark scores it
    on the env's own observations. Not with ``ActionRepeat``: the memory is one frame a slot.
    """

    def __init__(self, env: gym.Env, frames: int = 4) -> None:
        super().__init__(env)
        self.stack = tricks.FrameStack(frames)
        self.frames = self.stack.frames
        self.observation_space = self.stack.space(env.observation_space)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        obs, info = self.env.reset(seed=seed, options=options)
        return self.stack.reset(np.asarray(obs)[None])[0], info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        stacked = self.stack.step(np.asarray(obs)[None], np.zeros(1, dtype=bool))[0]
        return stacked, reward, terminated, truncated, info


def memory_frames(spec: Any) -> int:
    """The ``frames`` of the :class:`FrameStack` in a zoo ``env_wrapper`` value (as for
    :func:`action_repeat`); 1 without one. ``ValueError`` if it is listed with an action repeat
    above 1 (the memory holds one observation a slot, a repeated action sees one in ``repeat``)."""
    kwargs = _wrapper_kwargs(spec, FrameStack)
    if kwargs is None:
        return 1
    frames = tricks.check_frames(kwargs.get("frames", 4))
    if frames > 1 and action_repeat(spec) > 1:
        raise ValueError(
            "FrameStack and ActionRepeat cannot be combined: the memory holds one observation a slot"
        )
    return frames


def apply_wrappers(env: gym.Env, wrappers: list[tuple[Any, dict[str, Any]]]) -> gym.Env:
    """Wrap ``env`` in each ``(class, kwargs)`` of ``wrappers``, in order."""
    for cls, kwargs in wrappers:
        env = cls(env, **kwargs)
    return env
