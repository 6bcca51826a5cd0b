"""Gymnasium wrappers for training (named in the zoo's ``env_wrapper`` key of a hyperparameter file).

They change what the learner sees, never the episode: trajectories, ``info`` and the
evaluation (``agents.rollout``, on the plain env) are those of the env.
"""

from __future__ import annotations

import math
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from ios_uav_env.envs.policies import move_toward


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
        for name, value in (("offset", offset), ("scale", scale)):
            if not (isinstance(value, (int, float)) and math.isfinite(value)):
                raise ValueError(f"ShiftReward {name} must be a finite number, got {value!r}")
        if scale <= 0:
            raise ValueError(f"ShiftReward scale must be > 0, got {scale!r}")
        self.offset, self.scale = float(offset), float(scale)

    def reward(self, reward: SupportsFloat) -> float:
        return self.scale * (float(reward) - self.offset)


def action_repeat(spec: Any) -> int:
    """The ``repeat`` of the :class:`ActionRepeat` in a zoo ``env_wrapper`` value ("module.Class",
    or a list of names and {"module.Class": {kwargs}} mappings, as a run's ``config.json`` keeps
    it); 1 without one."""
    for item in spec if isinstance(spec, list) else [spec] if spec else []:
        name, kwargs = next(iter(item.items())) if isinstance(item, dict) and len(item) == 1 else (item, {})
        if name == f"{__name__}.{ActionRepeat.__name__}":
            return check_repeat((kwargs or {}).get("repeat", 1))
    return 1


def check_repeat(repeat: Any) -> int:
    """``repeat`` checked: an integer >= 1."""
    if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 1:
        raise ValueError(f"ActionRepeat repeat must be an integer >= 1, got {repeat!r}")
    return repeat


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
        self.repeat = check_repeat(repeat)

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        total = 0.0
        for _ in range(self.repeat):
            obs, reward, terminated, truncated, info = self.env.step(action)
            total += float(reward)
            if terminated or truncated:
                break
        return obs, total, terminated, truncated, info


#: The box the exploring starts fly towards (x, y ranges in m): the nodes' ranges of the
#: randomised ids (``MULTINODE_RANGES``), a little higher in y for the far side of the IOS.
EXPLORE_BOX = ((-250.0, 250.0), (-150.0, 200.0))


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
    by ``reset(seed=...)``. The batched env's form is ``agents.vec_env.VecExploringStarts``.
    """

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
        checked = check_exploring(prob, max_moves, box, peak_prob, peak_noise)
        self.prob, self.max_moves, self.box, self.peak_prob, self.peak_noise = checked
        self._rng = np.random.default_rng()

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        obs, info = self.env.reset(seed=seed, options=options)
        if self._rng.random() >= self.prob:
            return obs, info
        base = self.env.unwrapped
        cfg = base.config
        moves = min(int(self._rng.integers(1, self.max_moves, endpoint=True)), cfg.N - 3)
        target = draw_targets(self._rng, [cfg], self.box, self.peak_prob, self.peak_noise)[0]
        action = np.zeros(self.action_space.shape, dtype=np.float32)  # node scores 0: equal shares
        for _ in range(max(moves, 0)):
            action[:2] = move_toward(target - info["position"], cfg.D)
            obs, _, _, _, info = self.env.step(action)
        return obs, info


def apply_wrappers(env: gym.Env, wrappers: list[tuple[Any, dict[str, Any]]]) -> gym.Env:
    """Wrap ``env`` in each ``(class, kwargs)`` of ``wrappers``, in order."""
    for cls, kwargs in wrappers:
        env = cls(env, **kwargs)
    return env
