"""The training tricks, each once, on the batched env's arrays (B rows).

A recipe names its tricks by the zoo's ``env_wrapper`` key (``agents.wrappers.ShiftReward``,
``ActionRepeat``, ``ExploringStarts``, ``FrameStack``; ``agents.callbacks.ExploringStartsSchedule``
winds the starts down). Each is implemented here, on arrays of rows: observations (B, d), actions
(B, a), rewards (B,), dones (B,). Every training path calls these:

- the SB3 VecEnv path over the batched env (``agents.vec_env``: ``VecShiftReward``,
  ``VecActionRepeat``, ``VecExploringStarts``);
- the fast trainer (``agents.fast.ppo.FastPPO``: the shift, the exploring starts with their
  schedule, and the memory);
- the Gymnasium wrappers of one env (``agents.wrappers``, for the zoo and SB3's
  ``DummyVecEnv``): the same functions on one row.

A model trained with a memory is flown on the env's own observations with :class:`History`
beside it (``agents.loading``), which rebuilds the stack the model was trained on.

They change what the learner sees, never the episode: trajectories, ``info`` and the score are the
env's. Arguments are checked on construction (``ValueError`` naming the wrapper's field).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

#: The box the exploring starts fly towards (x, y ranges in m): the nodes' ranges of the
#: randomised ids (``MULTINODE_RANGES``), a little higher in y for the far side of the IOS.
EXPLORE_BOX = ((-250.0, 250.0), (-150.0, 200.0))


# --- the reward shift ----------------------------------------------------------------------
class RewardShift:
    """Rewards ``scale * (reward - offset)`` (``agents.wrappers.ShiftReward``); the array's dtype
    is kept (float32 rewards stay float32)."""

    def __init__(self, offset: float = 0.0, scale: float = 1.0, who: str = "ShiftReward") -> None:
        for name, value in (("offset", offset), ("scale", scale)):
            if isinstance(value, bool) or not (isinstance(value, (int, float)) and math.isfinite(value)):
                raise ValueError(f"{who} {name} must be a finite number, got {value!r}")
        if scale <= 0:
            raise ValueError(f"{who} scale must be > 0, got {scale!r}")
        self.offset, self.scale = float(offset), float(scale)

    def __call__(self, reward: np.ndarray) -> np.ndarray:
        return self.scale * (reward - self.offset)


# --- the action repeat ---------------------------------------------------------------------
def check_repeat(repeat: Any) -> int:
    """``repeat`` checked: an integer >= 1."""
    if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 1:
        raise ValueError(f"ActionRepeat repeat must be an integer >= 1, got {repeat!r}")
    return repeat


#: One slot of the rows of a mask: (observations, rewards (B,), dones (B,), info).
Advance = Callable[[np.ndarray], tuple[Any, np.ndarray, np.ndarray, Any]]


class ActionRepeat:
    """Hold each action for ``repeat`` slots, the rewards summed (``agents.wrappers.ActionRepeat``):
    every row steps until its ``repeat`` slots are done or its episode ends, whichever is first;
    a row that ended stops there while the others finish the repeat."""

    def __init__(self, repeat: int = 1) -> None:
        self.repeat = check_repeat(repeat)

    def step(
        self, advance: Advance, n: int, dtype: Any = np.float64,
        ended: Callable[[np.ndarray, Any], None] | None = None,
    ) -> tuple[Any, np.ndarray, np.ndarray, Any]:  # fmt: skip
        """One decision of ``n`` rows: ``advance(rows)`` steps the rows of the mask ``rows`` one slot
        (the others keep their state); ``ended(done, info)`` is told each slot's rows that ended.
        Returns the last slot's observations and info, the rewards summed in ``dtype`` and the
        rows that ended."""
        rows = np.ones(n, dtype=np.bool_)
        total, dones = np.zeros(n, dtype=dtype), np.zeros(n, dtype=np.bool_)
        for _ in range(self.repeat):
            obs, reward, done, info = advance(rows)
            total += np.asarray(reward, dtype=dtype)
            if ended is not None and done.any():
                ended(done, info)
            dones |= done
            rows &= ~done
            if not rows.any():
                break
        return obs, total, dones, info


# --- the exploring starts --------------------------------------------------------------------
def check_exploring(
    prob: Any, max_moves: Any, box: Any, peak_prob: Any = 0.0, peak_noise: Any = 0.0
) -> tuple[float, int, np.ndarray, float, float]:
    """The arguments of :class:`ExploringStarts` checked (``ValueError`` naming the field)."""
    for name, value in (("prob", prob), ("peak_prob", peak_prob)):
        if isinstance(value, bool) or not (isinstance(value, (int, float)) and 0.0 <= value <= 1.0):
            raise ValueError(f"ExploringStarts {name} must be a number in [0, 1], got {value!r}")
    if isinstance(peak_noise, bool) or not (
        isinstance(peak_noise, (int, float)) and math.isfinite(peak_noise) and peak_noise >= 0
    ):
        raise ValueError(f"ExploringStarts peak_noise must be a finite number >= 0 (m), got {peak_noise!r}")
    if isinstance(max_moves, bool) or not isinstance(max_moves, int) or max_moves < 1:
        raise ValueError(f"ExploringStarts max_moves must be an integer >= 1, got {max_moves!r}")
    area = np.asarray(box, dtype=np.float64)
    if area.shape != (2, 2) or not np.all(np.isfinite(area)) or np.any(area[:, 0] > area[:, 1]):
        raise ValueError(f"ExploringStarts box must be ((x_min, x_max), (y_min, y_max)) in m, got {box!r}")
    return float(prob), max_moves, area, float(peak_prob), float(peak_noise)


def draw_targets(
    rng: np.random.Generator, configs: list[Any], box: np.ndarray, peak_prob: float, peak_noise: float
) -> np.ndarray:
    """One prefix target per scenario of ``configs`` ((n, 2) m): with probability ``peak_prob`` the
    reachable rate peak of one of its nodes drawn uniformly (``node_peaks``, the ``peak_hint``
    points) plus Gaussian noise of ``peak_noise`` m per axis, else a point uniform in ``box``."""
    from ios_uav_env.envs.multi import node_peaks

    targets = rng.uniform(box[:, 0], box[:, 1], (len(configs), 2))
    near = rng.random(len(configs)) < peak_prob
    for i in np.flatnonzero(near):
        peaks = node_peaks(configs[i])
        targets[i] = np.asarray(peaks[int(rng.integers(len(peaks)))][:2]) + rng.normal(0.0, peak_noise, 2)
    return targets


def scheduled_prob(initial: float, done: float, hold: float, end: float) -> float:
    """``ExploringStartsSchedule``'s probability once ``done`` of the run is done: ``initial`` for
    the first ``hold``, then linearly to ``end`` at the end."""
    late = max(0.0, done - hold) / (1.0 - hold) if hold < 1.0 else 0.0
    return initial + late * (end - initial)


class ExploringStarts:
    """The exploring starts (``agents.wrappers.ExploringStarts``, whose docstring says why): each row
    whose episode just ended starts its next one, with probability ``prob``, after a hidden prefix
    of m ~ U{1..max_moves} full-speed moves (at most N - 3) towards a target of
    :func:`draw_targets`, equal shares. The draws come from :attr:`rng` (:meth:`seed`);
    ``prob`` may be changed between steps (:func:`scheduled_prob`), ``initial`` keeps its first value."""

    def __init__(
        self, prob: float = 0.5, max_moves: int = 110, box: Any = EXPLORE_BOX, peak_prob: float = 0.0,
        peak_noise: float = 25.0,
    ) -> None:  # fmt: skip
        checked = check_exploring(prob, max_moves, box, peak_prob, peak_noise)
        self.prob, self.max_moves, self.box, self.peak_prob, self.peak_noise = checked
        self.initial = self.prob
        self.rng = np.random.default_rng()

    def seed(self, seed: Any) -> None:
        """Restart the draws from ``seed`` (anything ``np.random.default_rng`` takes)."""
        self.rng = np.random.default_rng(seed)

    def draw(
        self, rows: np.ndarray, configs: Callable[[np.ndarray], Sequence[Any]]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The prefixes of the rows ``rows`` (indices) that just ended: (the rows drawn to start
        part-way, their targets (n, 2) m, their moves (n,)); ``configs(rows)`` are the scenarios of
        the rows drawn. No further draw when no row is drawn."""
        rows = rows[self.rng.random(rows.size) < self.prob]
        if not rows.size:
            return rows, np.zeros((0, 2)), np.zeros(0, dtype=np.int64)
        scenarios = list(configs(rows))
        drawn = self.rng.integers(1, self.max_moves, rows.size, endpoint=True)
        moves = np.maximum(np.minimum(drawn, [c.N - 3 for c in scenarios]), 0)
        targets = draw_targets(self.rng, scenarios, self.box, self.peak_prob, self.peak_noise)
        return rows, targets, moves

    def apply(self, vec: Any, dones: np.ndarray, obs: np.ndarray) -> np.ndarray:
        """The starts of one step of the batched env ``vec`` (same-step autoreset: the rows of
        ``dones`` have just begun their next episode): the drawn rows fly their prefix through
        ``vec.fly``; ``obs`` with those rows' observations after it (a copy if any row changed)."""
        rows, targets, moves = self.draw(
            np.flatnonzero(dones), lambda ended: [vec.envs[i].config for i in ended]
        )
        if not rows.size:
            return obs
        obs = obs.copy()
        obs[rows] = vec.fly(rows, targets, moves)[rows]
        return obs


class StartsField:
    """An attribute of a wrapper's :class:`ExploringStarts` (``wrapper.starts``) under the same
    name on the wrapper: ``ExploringStartsSchedule`` reads and sets ``prob`` there."""

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, obj: Any, owner: type | None = None) -> Any:
        return self if obj is None else getattr(obj.starts, self.name)

    def __set__(self, obj: Any, value: Any) -> None:
        setattr(obj.starts, self.name, value)


# --- the memory: the last observations ------------------------------------------------------
def check_frames(frames: Any, who: str = "FrameStack") -> int:
    """``frames`` checked: an integer >= 1 (1: the observation alone)."""
    if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or frames < 1:
        raise ValueError(f"{who} frames must be an integer >= 1, got {frames!r}")
    return int(frames)


class FrameStack:
    """The last ``frames`` observations of each of B rows, oldest first, as one flat row
    (``agents.wrappers.FrameStack``): observations (B, d) in, (B, frames * d) out, of their dtype.

    It is Gymnasium's ``FrameStackObservation(env, frames)`` with its default padding
    (``"reset"``: an episode's history begins as its first observation repeated ``frames``
    times) followed by ``FlattenObservation``, on the rows of a batched env with same-step
    autoreset: a row whose episode just ended (``dones``) gets the new episode's first
    observation repeated, and its final observation's stack is :meth:`final` (``tests/agents/
    test_memory.py`` compares the two on a seeded episode)."""

    def __init__(self, frames: int = 4, who: str = "FrameStack") -> None:
        self.frames = check_frames(frames, who)
        self._stack: np.ndarray | None = None  # (B, frames, d)

    def space(self, space: Any) -> Any:
        """The Box of the stacked observations of ``space`` (a Box of shape (d,)): its bounds repeated."""
        import gymnasium as gym

        low, high = (np.tile(np.asarray(b).reshape(-1), self.frames) for b in (space.low, space.high))
        return gym.spaces.Box(low, high, dtype=space.dtype)

    def reset(self, obs: np.ndarray) -> np.ndarray:
        """Every row starts an episode at ``obs`` (B, d); the stacked observations."""
        obs = np.asarray(obs)
        self._stack = np.repeat(obs[:, None, :], self.frames, axis=1)
        return self._flat(self._stack)

    def step(self, obs: np.ndarray, dones: np.ndarray) -> np.ndarray:
        """One slot: ``obs`` (B, d) joins each row's history, oldest out; the rows of ``dones``
        have begun a new episode at ``obs``. The stacked observations."""
        if self._stack is None or self._stack.shape[0] != len(obs):
            return self.reset(obs)
        obs = np.asarray(obs, dtype=self._stack.dtype)
        self._stack[:, :-1] = self._stack[:, 1:]
        self._stack[:, -1] = obs
        rows = np.flatnonzero(dones)
        if rows.size:
            self._stack[rows] = obs[rows, None, :]
        return self._flat(self._stack)

    def final(self, rows: np.ndarray, final_obs: np.ndarray) -> np.ndarray:
        """The stacked final observations ``final_obs`` (n, d) of the rows ``rows`` whose episodes
        just ended (their histories, then the final one), before :meth:`step` starts them anew."""
        assert self._stack is not None, "reset() first"
        stack = np.concatenate([self._stack[rows, 1:], np.asarray(final_obs)[:, None, :]], axis=1)
        return self._flat(stack.astype(self._stack.dtype))

    def latest(self, stacked: np.ndarray) -> np.ndarray:
        """The newest observation of each stacked row: (..., frames * d) -> (..., d)."""
        d = stacked.shape[-1] // self.frames
        return stacked[..., -d:]

    @staticmethod
    def _flat(stack: np.ndarray) -> np.ndarray:
        return stack.reshape(len(stack), -1).copy()


class History:
    """The memory of a policy flown on the env's own observations (evaluation, the benchmark's
    scorer, which know nothing of it): a :class:`FrameStack` of ``frames`` fed one call a slot,
    whose rows start anew at the first call, when the batch size changes, or when their clock
    (column ``clock``: the ``time_left`` feature, 1 at a reset and lower by 1/N each slot) does
    not fall from the previous call's: a new episode. One observation (d,) gives (frames * d,),
    a batch (B, d) gives (B, frames * d)."""

    def __init__(self, frames: int, clock: int) -> None:
        self.stack, self.clock = FrameStack(frames), int(clock)
        self._last: np.ndarray | None = None

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        obs = np.asarray(obs)
        rows = obs[None] if obs.ndim == 1 else obs
        clock = rows[:, self.clock].astype(np.float64)
        if self._last is None or len(self._last) != len(rows):
            stacked = self.stack.reset(rows)
        else:
            stacked = self.stack.step(rows, clock >= self._last)
        self._last = clock
        return stacked[0] if obs.ndim == 1 else stacked
