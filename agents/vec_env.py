"""Stable-Baselines3 on the natively batched env: a ``VecEnv`` over ``IOSUAVVectorEnv``.

SB3's ``DummyVecEnv`` steps B Python envs one by one and deep-copies every info dict; this
adapter steps the B episodes as one array computation (``ios_uav_env.envs.single_vector``, or
``ios_uav_env.envs.multi_vector`` for the multi-node ids; same-step autoreset as SB3 expects: a
finished row's last observation is in its info's ``terminal_observation``) and hands SB3 an
empty info dict for every row that did not just finish. Wrap it in ``VecMonitor`` for episode
statistics and in ``VecNormalize`` as usual.

>>> venv = BatchedVecEnv("ios_uav_env/IOSUAV-v0", n_envs=256, seed=0)  # doctest: +SKIP
>>> model = PPO("MlpPolicy", VecMonitor(venv))                        # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import (
    VecEnv,
    VecEnvIndices,
    VecEnvStepReturn,
    VecEnvWrapper,
)

import ios_uav_env  # registers the ids
from agents import tricks
from agents.tricks import EXPLORE_BOX, StartsField
from ios_uav_env.envs.registration import presets
from ios_uav_env.jit import prefer_passive_threads

FLIGHT_IDS = frozenset(presets())  # the ids this wrapper takes: the agent flies the UAV

prefer_passive_threads()  # numba's threads must not spin while torch trains (see the function)


class BatchedVecEnv(VecEnv):
    """``n_envs`` episodes of the registered id ``env_id`` (its ``vector_entry_point``) as an SB3
    ``VecEnv``; ``env_kwargs`` are the env's arguments, ``seed`` seeds row i with ``seed + i``.

    ``stagger=True`` spreads the rows over the episode at each ``reset()``: row i's first episode
    starts ``(i * L) // n_envs`` hover moves in (zero actions from q0; L its number of steps),
    so later episodes end at different times. Without it every row of a fixed id starts and
    ends its episodes together, and a PPO rollout of n_steps << L steps holds one slice of
    the episode at a time (the value and the policy are then fitted to slot 1-16, then to
    slot 17-32, ...). The hover prefix is not returned (the monitor's first episodes are
    shorter); the default (off) keeps the rows equal to single envs seeded ``seed + i``.

    The multi-node ids skip the LP of ``best_schedule_rate`` at episode ends (18 ms per episode
    at N = 150, far more than the steps; training needs the reward only) unless ``env_kwargs``
    sets ``best_schedule=True``. A finished row's info has ``average_rate`` (for the multi-node
    ids the agent's own score ``min_rate``, as ``ios_uav_env.envs.rollout`` reports it) and
    ``feasible``.
    """

    def __init__(
        self,
        env_id: str,
        n_envs: int,
        env_kwargs: dict[str, Any] | None = None,
        seed: int | None = None,
        stagger: bool = False,
    ):
        if env_id not in FLIGHT_IDS:
            raise ValueError(
                f"env_id: BatchedVecEnv wraps the flight ids (ios_uav_env.envs.registration.presets(): "
                f"the agent flies, episodes end with average_rate); {env_id!r} is not one. Wrap its "
                "single env in SB3's DummyVecEnv instead (examples/star_control_ppo.py does)"
            )
        self.env_id, self.stagger = env_id, bool(stagger)
        kwargs = dict(env_kwargs or {})
        if env_id in ios_uav_env.MULTINODE_IDS:
            kwargs.setdefault("best_schedule", False)
        self.vector_env = gym.make_vec(
            env_id,
            num_envs=n_envs,
            vectorization_mode="vector_entry_point",
            autoreset_mode="same_step",
            **kwargs,
        )
        vec = self.vector_env
        super().__init__(n_envs, vec.single_observation_space, vec.single_action_space)
        self._actions: np.ndarray | None = None
        if seed is not None:
            self.seed(seed)

    def reset(self) -> np.ndarray:
        seeds = [s for s in self._seeds] if any(s is not None for s in self._seeds) else None
        obs, _ = self.vector_env.reset(seed=seeds)
        self._reset_seeds()
        self._reset_options()
        return self._stagger(obs) if self.stagger else obs

    def _stagger(self, obs: np.ndarray) -> np.ndarray:
        """Hover row i for (i * L_i) // n moves into its episode (see the class); the current observations."""
        vec = self.vector_env
        n = self.num_envs
        lengths = np.array([round(env.config.T / env.config.dt) - 1 for env in vec.envs])
        phase = (np.arange(n) * lengths) // n
        last = int(phase.max())
        hover = np.zeros((n, *vec.single_action_space.shape))  # multi-node: equal shares
        for j in range(1, last + 1):
            obs = vec.step(hover)[0]
            rows = np.flatnonzero(last - phase == j)  # these take the remaining phase[i] moves from here
            if rows.size:
                obs = vec.restart(rows)
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions, dtype=np.float64).reshape(self.num_envs, -1)

    def step_wait(self) -> VecEnvStepReturn:
        return self.advance(self._actions)

    def advance(self, actions: np.ndarray, rows: np.ndarray | None = None) -> VecEnvStepReturn:
        """Step the rows of the mask ``rows`` only (None: all), SB3's step return; the others keep
        their last observation, reward 0, not done (the batched env's ``advance``)."""
        obs, reward, terminated, truncated, info = self.vector_env.advance(actions, rows)
        dones = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        final = info.get("final_info", {})
        score = final.get("average_rate", final.get("min_rate"))  # multi-node: the agent's own score
        for i in np.flatnonzero(dones):
            infos[i] = {
                "terminal_observation": info["final_obs"][i],
                "TimeLimit.truncated": bool(truncated[i] and not terminated[i]),
                "average_rate": float(score[i]),
                "feasible": bool(final["feasible"][i]),
            }
        return obs, reward.astype(np.float32), dones, infos

    def close(self) -> None:
        self.vector_env.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None] * self.num_envs

    # --- the per-env API: the rows are not separate env objects -------------------------
    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        return [getattr(self.vector_env.envs[i], attr_name) for i in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        raise AttributeError(f"BatchedVecEnv cannot set {attr_name!r} on its rows (they share one kernel)")

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **method_kwargs: Any
    ) -> list[Any]:
        rows = self._get_indices(indices)
        return [getattr(self.vector_env.envs[i], method_name)(*method_args, **method_kwargs) for i in rows]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]

    def _get_indices(self, indices: VecEnvIndices) -> Iterable[int]:
        if indices is None:
            return range(self.num_envs)
        if isinstance(indices, int):
            return [indices]
        return indices


class VecShiftReward(VecEnvWrapper):
    """``agents.wrappers.ShiftReward`` on a whole VecEnv (``agents.tricks.RewardShift`` on its
    rewards): rewards become ``scale * (reward - offset)`` (the terminal observations and infos
    pass through unchanged)."""

    def __init__(self, venv: VecEnv, offset: float = 0.0, scale: float = 1.0):
        self.shift = tricks.RewardShift(offset, scale, who="VecShiftReward")
        super().__init__(venv)

    @property
    def offset(self) -> float:
        """The shift's offset (``agents.tricks.RewardShift``)."""
        return self.shift.offset

    @property
    def scale(self) -> float:
        """The shift's scale (``agents.tricks.RewardShift``)."""
        return self.shift.scale

    def reset(self) -> np.ndarray:
        return self.venv.reset()

    def step_wait(self) -> VecEnvStepReturn:
        obs, reward, dones, infos = self.venv.step_wait()
        return obs, self.shift(reward).astype(np.float32), dones, infos


class VecActionRepeat(VecEnvWrapper):
    """``agents.wrappers.ActionRepeat`` on a :class:`BatchedVecEnv` (``agents.tricks.ActionRepeat``
    over its ``advance``): each action is held for ``repeat`` slots, the rewards summed in
    float32; a row whose episode ends within the repeat stops there (its info and
    ``terminal_observation`` are that slot's, its observation the next episode's first), while
    the other rows finish the repeat."""

    def __init__(self, venv: VecEnv, repeat: int = 1):
        if not isinstance(venv, BatchedVecEnv):
            raise ValueError(
                "VecActionRepeat wraps a BatchedVecEnv directly (list ActionRepeat first), "
                f"got {type(venv).__name__}"
            )
        super().__init__(venv)
        self.hold = tricks.ActionRepeat(repeat)
        self.repeat = self.hold.repeat
        self._actions: np.ndarray | None = None

    def reset(self) -> np.ndarray:
        return self.venv.reset()

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions, dtype=np.float64).reshape(self.num_envs, -1)

    def step_wait(self) -> VecEnvStepReturn:
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]

        def ended(done: np.ndarray, info: list[dict[str, Any]]) -> None:
            for i in np.flatnonzero(done):
                infos[i] = info[i]

        def advance(rows: np.ndarray) -> VecEnvStepReturn:
            return self.venv.advance(self._actions, rows)

        obs, total, dones, _ = self.hold.step(advance, self.num_envs, np.float32, ended)
        return obs, total, dones, infos


class VecExploringStarts(VecEnvWrapper):
    """``agents.wrappers.ExploringStarts`` on a batched env (``agents.tricks.ExploringStarts`` on its
    rows): each row's next episode (after an episode end, not the first), with probability
    ``prob``, starts after the hidden prefix of the single form (m ~ U{1..max_moves} full-speed
    moves towards a point of ``box``, equal shares), flown on the rows of the ``BatchedVecEnv``
    under ``venv`` (its batched env's ``fly``), below any wrapper in between: the monitor counts
    the episode from the agent's first move. The generator is seeded from the seed of the
    batched env's next reset (``venv.seed(s)``)."""

    prob = StartsField()
    max_moves = StartsField()
    box = StartsField()
    peak_prob = StartsField()
    peak_noise = StartsField()

    def __init__(
        self,
        venv: VecEnv,
        prob: float = 0.5,
        max_moves: int = 110,
        box: Any = EXPLORE_BOX,
        peak_prob: float = 0.0,
        peak_noise: float = 25.0,
    ):
        base = venv.unwrapped
        if not isinstance(base, BatchedVecEnv):
            raise ValueError(f"VecExploringStarts needs a BatchedVecEnv under it, got {type(base).__name__}")
        super().__init__(venv)
        self.starts = tricks.ExploringStarts(prob, max_moves, box, peak_prob, peak_noise)
        self._base = base

    def reset(self) -> np.ndarray:
        seed = self._base._seeds[0] if self._base._seeds else None  # SB3's VecEnv.seed(s), kept to the reset
        if seed is not None:
            self.starts.seed(seed)
        return self.venv.reset()

    def step_wait(self) -> VecEnvStepReturn:
        obs, reward, dones, infos = self.venv.step_wait()
        return self.starts.apply(self._base.vector_env, dones, obs), reward, dones, infos


class VecFrameStack(VecEnvWrapper):
    """``agents.wrappers.FrameStack`` on a batched VecEnv (``agents.tricks.FrameStack`` on its rows):
    each row's last ``frames`` observations, oldest first, flattened; a row that just finished
    has its next episode's first observation repeated, and the ``terminal_observation`` of its
    info is the stack of its final observation. List it after (outside) ``ExploringStarts``, so
    that a drawn row's history begins after its hidden prefix."""

    def __init__(self, venv: VecEnv, frames: int = 4):
        self.stack = tricks.FrameStack(frames, who="VecFrameStack")
        self.frames = self.stack.frames
        super().__init__(venv, observation_space=self.stack.space(venv.observation_space))

    def reset(self) -> np.ndarray:
        return self.stack.reset(self.venv.reset())

    def step_wait(self) -> VecEnvStepReturn:
        obs, reward, dones, infos = self.venv.step_wait()
        rows = np.flatnonzero(dones)
        if rows.size:
            finals = np.stack([infos[i]["terminal_observation"] for i in rows])
            infos = list(infos)
            for i, final in zip(rows, self.stack.final(rows, finals), strict=True):
                infos[i] = {**infos[i], "terminal_observation": final}
        return self.stack.step(obs, dones), reward, dones, infos


#: Gymnasium wrappers of the zoo's ``env_wrapper`` key that have a VecEnv form here.
VEC_FORMS: dict[str, type[VecEnvWrapper]] = {
    "agents.wrappers.ShiftReward": VecShiftReward,
    "agents.wrappers.ActionRepeat": VecActionRepeat,
    "agents.wrappers.ExploringStarts": VecExploringStarts,
    "agents.wrappers.FrameStack": VecFrameStack,
}


def wrap_batched(venv: VecEnv, wrappers: Sequence[tuple[Any, dict[str, Any]]]) -> VecEnv:
    """Apply the zoo's ``env_wrapper`` list (``(class, kwargs)`` pairs, as ``agents.hyperparams``
    resolves them) to a batched VecEnv through their VecEnv forms (:data:`VEC_FORMS`);
    ``ValueError`` naming a wrapper that has none (its rows are not separate gym envs)."""
    for cls, kwargs in wrappers:
        name = f"{cls.__module__}.{cls.__qualname__}"
        if name not in VEC_FORMS:
            raise ValueError(
                f"env_wrapper {name!r} cannot wrap the batched env (its rows are not separate gym envs); "
                f"wrappers with a VecEnv form: {', '.join(VEC_FORMS)}"
            )
        venv = VEC_FORMS[name](venv, **kwargs)
    return venv
