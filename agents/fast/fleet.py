"""IPPO with shared parameters on the fast trainer: B fleets of U UAVs, every agent a row.

``FastPPO(FleetSpec(env_kwargs), recipe, total)`` trains one policy on the rows of
``ios_uav_env.envs.fleet_vector.FleetVectorEnv(n_envs, **env_kwargs)``: row ``b U + u`` is agent
``uav_u`` of fleet b, with its own observation and action and its fleet's team reward (every agent
gets it, as ``ios_uav_env.parallel_env`` gives it), so every UAV shares the actor, the critic and
the observation statistics, and each agent step is one sample. ``n_envs`` counts fleets; the
rollout has ``n_envs x U x n_steps`` agent steps, and the run's steps count agent steps. The score
of a finished episode is its fleet's team max-min rate (``min_rate``, bps/Hz), counted once per
fleet. All fleets start and end their episodes together (the fleets have no staggered starts), so
a rollout of ``n_steps`` = N - 1 slots holds whole episodes.

Of the recipe's tricks the fleets take the reward shift and the log-std schedule; the exploring
starts, the memory and the clone warm start are refused by name. :func:`fly_fleet` flies a policy
deterministically on ``ios_uav_env.parallel_env(**env_kwargs)`` and returns the flights, their team
max-min rate and the best schedule of the same flights (``model.fleet.fleet_maxmin``). The fleets
need the ``marl`` extra (PettingZoo: the fleet's rules live in its parallel env).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

from agents.fast.recipe import FastRecipe
from agents.fast.rows import RunEnv
from agents.scores import ScoreLabel

#: The recipe's key of the fleets in a zoo-format file (``agents/hyperparams/fast_ippo_fleet.yml``).
FLEET_KEY = "ios_uav_env.parallel_env"
#: The fleets' score: the team max-min rate of the nodes (``FleetVectorEnv``'s ``min_rate``).
FLEET_SCORE = ScoreLabel("rate", "min_rate", "bps/Hz")
#: Keywords the fast trainer sets itself (the fleets' count and threads, no episode-end schedule).
OWN_KEYWORDS = ("num_fleets", "num_threads", "best_schedule", "render_mode")


@dataclass(frozen=True)
class FleetSpec:
    """The fleets of ``ios_uav_env.parallel_env(**env_kwargs)`` (``uavs`` >= 2, the lanes, the
    separation, the access, a ``ScenarioConfig`` field as a keyword changing the scenario) as the
    rows of a fast run; ``config``: the base scenario (default the parallel env's)."""

    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    config: Any = None

    def __post_init__(self) -> None:
        if not isinstance(self.env_kwargs, Mapping):
            raise TypeError(f"env_kwargs must be a mapping, got {type(self.env_kwargs).__name__}")
        own = sorted(set(self.env_kwargs) & set(OWN_KEYWORDS))
        if own:
            raise ValueError(
                f"env_kwargs: {own[0]!r} is set by the fast trainer (it sets {', '.join(OWN_KEYWORDS)})"
            )

    def vector_env(self, num_fleets: int, num_threads: int | None = None) -> Any:
        """``num_fleets`` fleets as ``FleetVectorEnv`` rows (``num_threads``: its kernels' threads)."""
        from ios_uav_env.envs.fleet_vector import FleetVectorEnv

        threads = {} if num_threads is None else {"num_threads": num_threads}
        return FleetVectorEnv(num_fleets, self.config, **threads, **self.env_kwargs)

    @property
    def uavs(self) -> int:
        """U, the UAVs of a fleet (``ValueError`` if the arguments are not a fleet's)."""
        env = self.parallel_env()
        env.close()
        return len(env.possible_agents)

    def parallel_env(self) -> Any:
        """One fleet on PettingZoo's Parallel API (``ios_uav_env.parallel_env``), scored at its end."""
        import ios_uav_env

        return ios_uav_env.parallel_env(self.config, **self.env_kwargs)

    def to_dict(self) -> dict[str, Any]:
        """The fleets' arguments as ``config.json`` records them (the scenario resolved)."""
        env = self.parallel_env()
        try:
            return {"env_kwargs": dict(self.env_kwargs), "uavs": len(env.possible_agents),
                    "scenario": env.config.to_dict(), "access": env.access}  # fmt: skip
        finally:
            env.close()


class AgentSpaces(gym.Env):
    """One agent row's spaces, the env SB3's model and ``VecNormalize`` are built on: the rows are
    stepped by the fleets (``FleetVectorEnv``), never through it, so ``reset`` and ``step`` refuse."""

    def __init__(self, observation_space: gym.Space, action_space: gym.Space) -> None:
        self.observation_space, self.action_space = observation_space, action_space

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> Any:
        raise TypeError("AgentSpaces holds one agent row's spaces; the fleets (FleetVectorEnv) step the rows")

    def step(self, action: Any) -> Any:
        raise TypeError("AgentSpaces holds one agent row's spaces; the fleets (FleetVectorEnv) step the rows")


class FleetRows:
    """The fleets' rows as the fast trainer steps them: ``seed(s)`` for the next ``reset()``."""

    def __init__(self, vector_env: Any) -> None:
        self.vector_env = vector_env
        self._seed: int | None = None

    def seed(self, seed: int | None = None) -> None:
        self._seed = seed

    def reset(self) -> np.ndarray:
        obs, _ = self.vector_env.reset(seed=self._seed)
        self._seed = None
        return obs

    def close(self) -> None:
        self.vector_env.close()


def fleet_run_env(spec: FleetSpec, n_envs: int, recipe: FastRecipe, env_threads: int | None) -> RunEnv:
    """The :class:`agents.fast.rows.RunEnv` of ``n_envs`` fleets of ``spec`` for ``recipe``
    (``ValueError`` naming a trick the fleets do not take)."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    check_recipe(recipe)
    vec = spec.vector_env(n_envs, env_threads)
    spaces = (vec.single_observation_space, vec.single_action_space)
    template = DummyVecEnv([lambda: AgentSpaces(*spaces)])
    return RunEnv(FleetRows(vec), template, FLEET_SCORE, episode_rows=vec.uavs)


def check_recipe(recipe: FastRecipe) -> None:
    """``ValueError`` naming the first trick of ``recipe`` the fleets do not take."""
    refused = {
        "env_wrapper agents.wrappers.ExploringStarts": recipe.exploring is not None,
        "env_wrapper agents.wrappers.FrameStack": recipe.frames > 1,
        "callback agents.callbacks.CloneStart": recipe.clone is not None,
    }
    for name, present in refused.items():
        if present:
            raise ValueError(
                f"hyperparameter {name} is not applied on fleets (they take ShiftReward and LogStdSchedule)"
            )


@dataclass
class FleetFlight:
    """A fleet's deterministic flights: ``trajectories`` (U, N, 2) m, the team's max-min rate
    ``min_rate`` of the flown schedule and ``best_schedule_rate`` (the flights' best schedule,
    ``fleet_maxmin``; bps/Hz), ``feasible`` (every UAV), the largest ``terminal_miss`` (m)."""

    trajectories: np.ndarray
    min_rate: float
    best_schedule_rate: float
    feasible: bool
    terminal_miss: float


def fly_fleet(act: Callable[[np.ndarray], np.ndarray], spec: FleetSpec, seed: int = 0) -> FleetFlight:
    """Fly ``spec``'s fleet (``ios_uav_env.parallel_env``, seeded ``seed``) to its end, ``act``
    mapping the agents' observations (U, obs) in agent order to their actions (U, act)."""
    env = spec.parallel_env()
    try:
        obs, _ = env.reset(seed=seed)
        agents = list(env.possible_agents)
        infos: dict[str, Any] = {}
        while env.agents:
            actions = np.asarray(act(np.stack([obs[a] for a in agents])))
            obs, _, _, _, infos = env.step({a: actions[u] for u, a in enumerate(agents)})
        info = infos[agents[0]]
        feasible = all(bool(infos[a]["feasible"]) for a in agents)
        miss = max(float(infos[a]["terminal_miss"]) for a in agents)
        rates = float(info["min_rate"]), float(info["best_schedule_rate"])
        return FleetFlight(env.trajectories, *rates, feasible, miss)
    finally:
        env.close()


def policy_act(model: Any, vecnormalize: Any = None) -> Callable[[np.ndarray], np.ndarray]:
    """The deterministic actions of an SB3 ``model`` (its observations normalised by
    ``vecnormalize``'s statistics when it normalises them)."""

    def act(obs: np.ndarray) -> np.ndarray:
        if vecnormalize is not None and vecnormalize.norm_obs:
            obs = vecnormalize.normalize_obs(obs)
        return model.predict(np.asarray(obs, dtype=np.float32), deterministic=True)[0]

    return act
