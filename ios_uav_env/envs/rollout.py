"""One episode of a policy in an env, scored by the one model: the episode loop of every report.

A policy is any callable from an observation to an action (an SB3 agent's ``act``, a
:class:`~ios_uav_env.envs.policies.HoverAt`, a lambda). :func:`run_episode` resets the env, steps
it until the episode ends and scores the trajectory (``env.unwrapped.trajectory``) with
``average_rate`` (eq. (9); with several ground nodes, ``scheduled_rates`` of the agent's own
shares ``env.unwrapped.shares``, its min_k R_k) and ``check_trajectory`` (eq. (10)), as every
planner's plan is: ``score_plan``, whose energy (J), energy efficiency (bits/J) and value of
the scenario's objective the :class:`Episode` carries too (``Episode.score``: EE on the energy
ids, the average rate on the others).

Before the episode, a policy that reads the observation by feature name (an
``observation_features`` attribute: the shipped policies of ``envs.policies`` and
``benchmark.multi_policies``) is checked against the layout the env publishes
(``env.unwrapped.observation_names``) and bound to it (:func:`bind_policy`): a missing feature
raises ``ValueError`` naming it and the env argument that provides it, before any step.

>>> import gymnasium as gym
>>> import ios_uav_env
>>> from ios_uav_env.envs.policies import HoverAt
>>> env = gym.make("ios_uav_env/IOSUAV-v0", T=60, peak_hint=True)
>>> episode = run_episode(env, HoverAt("peak"), seed=0)
>>> episode.steps, episode.feasible
(59, True)

"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ios_uav_env.envs.observation_layout import require_features
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.score import score_plan

Policy = Callable[[np.ndarray], Any]


@dataclass(frozen=True)
class Episode:
    """One finished episode, scored by the model."""

    config: ScenarioConfig  # the episode's scenario (env.unwrapped.config)
    trajectory: np.ndarray = field(repr=False)  # (n, 2) m, the way-points q[1..n]
    average_rate: float  # bps/Hz, the score: eq. (9) (average_rate); K > 1 nodes: the agent's own min_k R_k
    feasible: bool  # eq. (10) within FEASIBILITY_TOL
    terminal_miss: float  # m, |q[n] - qF|
    max_step: float  # m, longest move
    worst_violation: float  # m, worst breach of eq. (10)
    episode_return: float  # sum of the rewards
    mean_faded_rate: float  # bps/Hz, mean of the per-slot rate terms (= average_rate for "expected", K > 1)
    steps: int  # env steps taken
    seconds: float  # wall time from the reset to the last step (policy and env)
    energy: float = float("nan")  # J, propulsion energy E of the flight (PlanScore.energy)
    energy_efficiency: float = float("nan")  # bits/J, B T R / E (PlanScore.energy_efficiency)
    objective_value: float = float("nan")  # the score of config.objective: average_rate or energy_efficiency

    @property
    def score(self) -> float:
        """The episode's score: the value of its scenario's objective (``objective_value``)."""
        return self.objective_value


def run_episode(
    env: Any,
    policy: Policy,
    *,
    seed: int | None = None,
    options: Mapping[str, Any] | None = None,
    max_steps: int = 100_000,
) -> Episode:
    """Roll ``policy`` out for one episode of ``env`` (reset with ``seed`` and ``options``).

    The episode ends when the env says so (terminated or truncated); ``max_steps`` guards
    against an env that never does (``RuntimeError``). The trajectory must be complete
    (N way-points) to be scored: a truncated episode raises ``ValueError`` from the scorer.
    """
    policy = checked_policy(policy, env)
    repeat = decision_interval(policy)
    start = time.perf_counter()
    obs, info = env.reset(seed=seed, options=None if options is None else dict(options))
    total, steps, done = 0.0, 0, False
    while not done:
        if steps >= max_steps:
            raise RuntimeError(f"the episode did not end within max_steps={max_steps} steps")
        if steps % repeat == 0:
            action = policy(obs)
        obs, reward, terminated, truncated, info = env.step(action)
        total += float(reward)
        steps += 1
        done = bool(terminated or truncated)
    seconds = time.perf_counter() - start
    base = env.unwrapped
    shares = base.shares if base.config.K > 1 else None
    mean_faded = info.get("mean_faded_rate")
    return score_episode(base.config, base.trajectory, shares, total, mean_faded, steps, seconds)


def score_episode(
    config: ScenarioConfig,
    trajectory: np.ndarray,
    shares: np.ndarray | None,
    episode_return: float,
    mean_faded_rate: float | None,
    steps: int,
    seconds: float,
) -> Episode:
    """The :class:`Episode` of a finished flight, scored by the model: eq. (9) (``average_rate``;
    several nodes: ``scheduled_rates`` of the agent's own ``shares``, its min_k R_k) and
    eq. (10) (``check_trajectory``), as every planner's plan is."""
    scored = score_plan(config, trajectory, shares if config.K > 1 else None, best_schedule=False)
    report, score = scored.report, scored.rate
    return Episode(
        config=config,
        trajectory=trajectory,
        average_rate=score,
        feasible=report.feasible,
        terminal_miss=report.end_error,
        max_step=report.max_step,
        worst_violation=report.worst_violation,
        episode_return=float(episode_return),
        mean_faded_rate=score if mean_faded_rate is None else float(mean_faded_rate),
        steps=int(steps),
        seconds=float(seconds),
        energy=float(scored.energy),
        energy_efficiency=float(scored.energy_efficiency),
        objective_value=float(scored.objective_value),
    )


def decision_interval(policy: Policy) -> int:
    """How many slots ``policy`` holds each action: its (or its bound method's object's)
    ``repeat`` attribute, 1 if it has none (an agent trained with
    ``agents.wrappers.ActionRepeat`` decides every ``repeat`` slots)."""
    repeat = getattr(getattr(policy, "__self__", policy), "repeat", 1)
    if isinstance(repeat, bool) or not isinstance(repeat, (int, np.integer)) or repeat < 1:
        raise ValueError(f"a policy's repeat must be an integer >= 1, got {repeat!r}")
    return int(repeat)


def batch_policy(policy: Policy) -> Callable[[np.ndarray], np.ndarray]:
    """``policy`` as a function of a (B, obs_dim) batch: itself if it (or the object of a bound
    method) says ``batched = True`` (``HoverAt``, ``agents``' ``Agent`` and ``NumpyPolicy``),
    else one call per row."""
    if getattr(getattr(policy, "__self__", policy), "batched", False):
        return policy

    def per_row(obs: np.ndarray) -> np.ndarray:
        return np.stack([np.asarray(policy(o), dtype=np.float64) for o in obs])

    return per_row


def run_episodes(
    vec_env: Any,
    policy: Policy,
    *,
    seed: int | list[int] | None = None,
    options: Mapping[str, Any] | None = None,
    max_steps: int = 100_000,
) -> list[Episode]:
    """One episode per row of a natively batched env (``gym.make_vec(id, num_envs=B,
    vectorization_mode="vector_entry_point")``, next-step autoreset), each scored as
    :func:`run_episode` scores it; row i's episode is the single env's reset with ``seed + i``
    (a list: row i's seed; ``options={"configs": [...]}``: row i on scenario i). ``policy``
    maps the (B, obs_dim) observations to (B, act_dim) actions (:func:`batch_policy` adapts a
    one-observation policy). ``seconds`` is the batch's wall time from the reset to the end of
    its last episode divided by B: the time per plan when B are planned at once."""
    vec = getattr(vec_env, "unwrapped", vec_env)
    if getattr(vec, "same_step", True):
        raise ValueError("run_episodes needs a batched env with autoreset_mode='next_step' (the default)")
    policy = checked_policy(policy, vec_env)
    act, repeat = batch_policy(policy), decision_interval(policy)
    start = time.perf_counter()
    obs, _ = vec.reset(seed=seed, options=None if options is None else dict(options))
    b = vec.num_envs
    running, totals, steps = np.ones(b, dtype=np.bool_), np.zeros(b), np.zeros(b, dtype=np.int64)
    ends: dict[int, tuple[Any, ...]] = {}  # row -> (config, trajectory, shares, mean faded rate)
    for t in range(max_steps):
        if t % repeat == 0:  # every row started at t = 0: their decisions fall together
            actions = act(obs)
        obs, reward, terminated, truncated, info = vec.step(actions)
        totals += np.where(running, reward, 0.0)
        steps += running
        ended = np.flatnonzero(running & (terminated | truncated))
        if ended.size:  # before the next step resets them (next-step autoreset)
            configs, trajectories = vec.configs, vec.trajectories
            schedules = vec.schedules if hasattr(vec, "schedules") else [None] * b
            faded = info.get("mean_faded_rate", [None] * b)
            ends.update({int(i): (configs[i], trajectories[i], schedules[i], faded[i]) for i in ended})
            running[ended] = False
        if not running.any():
            break
    else:
        raise RuntimeError(f"the episodes did not all end within max_steps={max_steps} steps")
    seconds = (time.perf_counter() - start) / b
    return [score_episode(*ends[i][:3], totals[i], ends[i][3], steps[i], seconds) for i in range(b)]


def _reader(policy: Any) -> Any:
    """The object that says which features ``policy`` reads (itself, or a bound method's object)."""
    return getattr(policy, "__self__", policy)


def observation_layout(env: Any) -> tuple[str, ...] | None:
    """The names of ``env``'s observation components (``observation_names`` of its unwrapped
    env, single or batched), None if it publishes none. ``ValueError`` if the observation it
    returns is not of that length (a wrapper changed the observation: the names are not its)."""
    names = getattr(getattr(env, "unwrapped", env), "observation_names", None)
    if names is None:
        return None
    space = getattr(env, "single_observation_space", None) or getattr(env, "observation_space", None)
    shape = getattr(space, "shape", None)
    if shape is not None and tuple(shape) != (len(names),):
        raise ValueError(
            f"the env's observations have shape {tuple(shape)}, but its unwrapped env publishes a layout of "
            f"{len(names)} features: a wrapper changed the observation, so a policy that reads features by "
            "name cannot be checked against it"
        )
    return tuple(names)


def bind_policy(policy: Policy, names: Sequence[str] | None, env: str = "the env") -> Policy:
    """``policy`` bound to the layout ``names`` (an env's ``observation_names``) when it reads the
    observation by feature name (``observation_features``, on itself or a bound method's object):
    its ``bind(names)`` if it has one (a bound method stays a method of the bound copy), else
    itself once ``observation_layout.require_features`` passes. ``ValueError`` naming each missing
    feature and the env argument that provides it. A policy that declares no features is
    returned as it is."""
    reader = _reader(policy)
    needed = getattr(reader, "observation_features", None)
    if needed is None:
        return policy
    columns = require_features(tuple(needed), names, repr(reader), env)  # (raises: names None or missing)
    bind = getattr(reader, "bind", None)
    if not callable(bind) or names is None or not columns:
        return policy
    bound = bind(tuple(names))
    return bound if reader is policy else getattr(bound, policy.__name__)


def checked_policy(policy: Policy, env: Any) -> Policy:
    """:func:`bind_policy` of ``policy`` on the layout ``env`` publishes (:func:`observation_layout`),
    before any episode; a policy that declares no features is returned as it is (no check)."""
    if getattr(_reader(policy), "observation_features", None) is None:
        return policy
    spec = getattr(env, "spec", None)
    label = getattr(spec, "id", None) or type(getattr(env, "unwrapped", env)).__name__
    return bind_policy(policy, observation_layout(env), label)


def policy_for(policy: Any, env_id: str, env_kwargs: Mapping[str, Any]) -> Any:
    """:func:`checked_policy` on the env ``gym.make(env_id, **env_kwargs)`` (made and closed only
    when ``policy`` declares the features it reads): where a policy will run in envs made later
    (``ios_uav_env.benchmark.evaluate``), checked before the first of them."""
    if getattr(_reader(policy), "observation_features", None) is None:
        return policy
    import gymnasium as gym

    env = gym.make(env_id, **dict(env_kwargs))
    try:
        return checked_policy(policy, env)
    finally:
        env.close()
