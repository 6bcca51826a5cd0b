"""The whole-episode timing of ``benchmarks/vector_speed.py``: which ids are timed and against which
bar (:func:`classify`, from how an id's registration behaves), and the runner that drives a vector
env call by call, interleaved with Gymnasium's ``CartPoleVectorEnv`` (:func:`run_interleaved`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import gymnasium as gym
import numpy as np

from ios_uav_env.model.config import ScenarioConfig

#: The namespace whose registered ids the episode table times by default.
NAMESPACE = "ios_uav_env"
#: The bars, as multiples of CartPoleVectorEnv's env steps/s over whole episodes at the same B.
FIXED_BAR, RANDOM_BAR = 0.1, 0.03
FIXED, RANDOM = "fixed", "random"
#: The seeds whose resets tell whether an id draws its scenario.
PROBE_SEEDS = (0, 1, 2)


def registered_ids(namespace: str = NAMESPACE) -> list[str]:
    """The ids registered in ``namespace``, in registration order."""
    return [env_id for env_id, spec in gym.registry.items() if spec.namespace == namespace]


@dataclass(frozen=True)
class Classification:
    """An id's bar class: ``kind`` "fixed", "random" (reset draws a scenario, or nodes move) or
    None (cannot classify), and ``why``."""

    kind: str | None
    why: str

    @property
    def bar(self) -> float | None:
        return {FIXED: FIXED_BAR, RANDOM: RANDOM_BAR}.get(self.kind or "")


def classify(env_id: str) -> Classification:
    """Whether ``env_id`` is a fixed-scenario id or a randomised / moving-node one, from its
    registration: the env its spec makes is reset with each of :data:`PROBE_SEEDS` and its
    episode scenario (``env.unwrapped.config``, a ``ScenarioConfig``) read. It draws a scenario if
    two seeds give different scenarios; its nodes move if a scenario has a motion model. The
    spec's keywords must agree (``random_nodes`` draws, ``motion`` moves). An env without a
    ``ScenarioConfig`` or one whose keywords and resets disagree cannot be classified."""
    spec = gym.spec(env_id)
    try:
        env = gym.make(env_id).unwrapped
    except Exception as exc:  # noqa: BLE001  (reported, not raised: the table names the id)
        return Classification(None, f"cannot make it ({type(exc).__name__}: {exc})")
    try:
        configs = []
        for seed in PROBE_SEEDS:
            env.reset(seed=seed)
            configs.append(getattr(env, "config", None))
    except Exception as exc:  # noqa: BLE001
        return Classification(None, f"cannot reset it ({type(exc).__name__}: {exc})")
    finally:
        env.close()
    if not all(isinstance(config, ScenarioConfig) for config in configs):
        return Classification(
            None,
            f"its env ({type(env).__name__}) has no ScenarioConfig `config`: draws? moving nodes?",
        )
    draws = any(config != configs[0] for config in configs[1:])
    moves = any(config.motion is not None for config in configs)
    kwargs = spec.kwargs or {}
    said = [
        (bool(kwargs.get("random_nodes")), draws, "random_nodes"),
        (kwargs.get("motion") is not None, moves, "motion"),
    ]
    disagree = [name for declared, seen, name in said if declared and not seen]
    if disagree:
        return Classification(None, f"its keywords set {disagree} but its resets show no effect of them")
    if draws or moves:
        why = " and ".join(w for w, on in (("reset draws a scenario", draws), ("nodes move", moves)) if on)
        return Classification(RANDOM, why)
    return Classification(FIXED, f"one scenario for seeds {list(PROBE_SEEDS)}, static nodes")


class EpisodeRunner:
    """A vector env driven call by call: the first call is ``reset(seed)``, then ``step`` with
    actions drawn (seeded) from its action space. It counts the timed seconds of its calls, the env
    steps (rows that moved: in next-step autoreset mode a row's reset call is not one) and the
    episodes ended."""

    def __init__(self, vec: gym.vector.VectorEnv, seed: int, pool: int = 32) -> None:
        self.vec, self.seed = vec, seed
        vec.action_space.seed(seed)
        self.actions = [vec.action_space.sample() for _ in range(pool)]
        mode = vec.metadata.get("autoreset_mode", "next_step")
        self.same_step = "same" in str(getattr(mode, "value", mode)).lower()
        self.calls = self.steps = self.ended = self.last_ended = 0
        self.seconds = self.reset_seconds = 0.0
        self._resetting = np.zeros(vec.num_envs, dtype=np.bool_)

    def call(self) -> float:
        """One call (reset or step); its seconds."""
        if self.calls == 0:
            start = time.perf_counter()
            self.vec.reset(seed=self.seed)
            took = self.reset_seconds = time.perf_counter() - start
        else:
            action = self.actions[self.calls % len(self.actions)]
            start = time.perf_counter()
            _, _, terminated, truncated, _ = self.vec.step(action)
            took = time.perf_counter() - start
            done = np.logical_or(terminated, truncated)
            self.steps += self.vec.num_envs - (0 if self.same_step else int(self._resetting.sum()))
            self._resetting = done
            self.last_ended = int(done.sum())
            self.ended += self.last_ended
        self.calls += 1
        self.seconds += took
        return took

    @property
    def rate(self) -> float:
        """Env steps per timed second."""
        return self.steps / self.seconds if self.seconds > 0 else float("nan")


def run_interleaved(
    ours: EpisodeRunner,
    cartpole: EpisodeRunner,
    *,
    episodes: int,
    seconds: float,
    min_seconds: float,
    slice_seconds: float = 0.1,
    cartpole_cap: float = 1.0,
    progress: Callable[[EpisodeRunner], None] | None = None,
) -> bool:
    """Run ``ours`` in slices of about ``slice_seconds``, each followed by as long a slice of
    ``cartpole`` (at most ``cartpole_cap``, at least one call), until ``ours`` has ended
    ``episodes`` x B episodes and ``min_seconds`` (stopping at an episode end), or has spent
    ``seconds`` after at least one step; whether its episodes were completed (False: partial)."""
    target = episodes * ours.vec.num_envs
    while True:
        spent = 0.0
        complete = over = False
        while not (complete or over or spent >= slice_seconds):
            spent += ours.call()
            complete = ours.ended >= target and ours.seconds >= min_seconds and ours.last_ended > 0
            over = ours.seconds >= seconds and ours.calls >= 2
        budget, used = min(spent, cartpole_cap), 0.0
        while used < budget or cartpole.calls < 2:
            used += cartpole.call()
        if progress is not None:
            progress(ours)
        if complete or over:
            return complete


def warm_up(make: Callable[[int], gym.vector.VectorEnv], seed: int, max_calls: int = 2000) -> None:
    """Compile and import what an episode runs (numba kernels, the LP), untimed, on 2 rows: reset,
    steps until an episode ends, then its autoreset."""
    vec = make(2)
    try:
        runner = EpisodeRunner(vec, seed, pool=4)
        while runner.calls < max_calls and runner.ended == 0:
            runner.call()
        runner.call()
    finally:
        vec.close()
