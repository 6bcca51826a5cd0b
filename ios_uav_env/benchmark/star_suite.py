"""Suites of the STAR surface as the agent's control (kind ``"star-control"``, ``star-v1``): what a
scenario holds, the task a policy is bound to, and the one scorer of an episode.

A scenario runs ``ios_uav_env/STARControl-v0`` (``ios_uav_env.envs.star_control``): a UAV flies a
drawn straight line past a small STAR surface and the policy sets the surface's coefficients in
every slot. It holds:

- ``star``: the env's keywords :data:`STAR_FIELDS` (``elements`` as [M_y, M_z], ``bits``,
  ``group``, ``protocol``, ``access``, ``direct_link``), checked at load by the env's own
  constructor; the suite's ``env_kwargs`` add what the policy is shown (``channel_phases``);
- ``seed``: the episode's ``reset(seed=...)``, whose only draw is the line's x;
- ``config``: the episode's scenario as the env builds it after that reset (``env.config``: the
  users as its nodes, the line as q0 -> qF). At load it must be the env's base scenario on the
  surface ``elements`` with the line the seed draws (a 16-element env reset with ``seed``: the
  line is the reset's only draw); at every rollout the env reset with ``seed`` must build
  exactly it, else the episode is refused by name (:func:`star_episode`): the env's draw
  changed, and scoring it would score another task.

**The one scorer** of an episode is the env's own reward sum: a policy's value on a scenario is
``info["return"] / N`` at the last slot (the mean slot value min(R_r, R_t) in bps/Hz of
``star_slot.evaluate``), and the references ``optimum`` and ``bound`` are the same episode's
``info["optimum_return"] / N`` and the mean of ``info["optimum_upper"]`` (``star_slot.slot_optimum``'s
value and certified upper bound of every slot; equal under TDMA). Scores are % of the optimum
and % of the bound.

**Binding a policy.** The observation has 8 + 2G features and the action 2G + 1 (TDMA) or 3G + 1
(NOMA) entries, G = M / group: the widths change with the scenario. A policy with a ``bind``
method is bound to every scenario before its episode, ``policy.bind(task)`` with the scenario's
:class:`StarTask` (its keywords, observation names and action width; nothing of the channels),
and the bound object (a callable ``obs -> action`` or an object with ``predict``, as an SB3 model)
plays the episode: one model per setting, a per-scenario factory, or one policy that reads the
widths, as :class:`~ios_uav_env.benchmark.star_policies.ChannelPhases` does. A policy without
``bind`` plays every scenario as it is, so it must give each scenario's action width (a policy of
one width fails on the first scenario of another, naming it).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ios_uav_env.model.config import ScenarioConfig

__all__ = [
    "STAR_FIELDS",
    "StarEpisode",
    "StarTask",
    "check_fields",
    "check_line",
    "check_star",
    "make_star_env",
    "star_episode",
    "star_kwargs",
]

#: A STAR-control scenario's env keywords (``STARControlEnv``'s arguments the scenario fixes).
STAR_FIELDS = ("elements", "bits", "group", "protocol", "access", "direct_link")


@dataclass(frozen=True)
class StarTask:
    """What a policy may know of a scenario before its episode (``bind``'s argument): the env's
    keywords, the observation's feature names and the action's width."""

    elements: tuple[int, int]
    bits: int | None
    group: int
    protocol: str
    access: str
    direct_link: bool
    observation_names: tuple[str, ...]
    action_dim: int

    @property
    def M(self) -> int:
        """Elements of the surface."""
        return self.elements[0] * self.elements[1]

    @property
    def G(self) -> int:
        """Groups (one phase per side each): M / group."""
        return self.M // self.group

    @classmethod
    def of(cls, star: Mapping[str, Any], env: Any) -> StarTask:
        """The task of the keywords ``star`` in ``env`` (made with them)."""
        kw = star_kwargs(star)
        base = env.unwrapped
        return cls(kw["elements"], kw["bits"], kw["group"], kw["protocol"], kw["access"], kw["direct_link"],
                   tuple(base.observation_names), int(base.action_space.shape[0]))  # fmt: skip


@dataclass(frozen=True)
class StarEpisode:
    """One scored episode: mean slot values (bps/Hz) and the policy's own time (s)."""

    value: float  # info["return"] / N: the env's reward sum, per slot
    optimum: float  # info["optimum_return"] / N
    bound: float  # the mean of info["optimum_upper"]
    seconds: float  # the policy's calls only (the env's per-slot optimum is the scorer's time)


def star_kwargs(star: Mapping[str, Any]) -> dict[str, Any]:
    """The env keywords of a stored ``star`` (``elements`` as a tuple)."""
    return {**{k: star[k] for k in STAR_FIELDS}, "elements": tuple(star["elements"])}


def _expected_config(star: Mapping[str, Any], x: float) -> ScenarioConfig:
    """The env's scenario on the surface ``star["elements"]`` with the line at x (``reset``'s)."""
    from ios_uav_env.envs.star_control import BASE_CONFIG, Y_SPAN

    shape = tuple(int(v) for v in star["elements"])
    return BASE_CONFIG.replace(ios_shape=shape, q0=(x, Y_SPAN[0]), qF=(x, Y_SPAN[1]))


def check_fields(value: Any, name: str, fields: tuple[str, ...], where: str) -> None:
    """A stored scenario's env keywords ``value`` (the field ``name``): an object of exactly the keys
    ``fields`` whose ``elements`` is a list [M_y, M_z] (``ValueError`` naming ``where`` otherwise)."""
    if not isinstance(value, Mapping):
        raise ValueError(f"{where}: {name} must be an object of {list(fields)}, got {value!r}")
    if set(value) != set(fields):
        raise ValueError(
            f"{where}: {name} must have exactly the fields {list(fields)}, got {sorted(map(str, value))}"
        )
    if not isinstance(value["elements"], list):
        raise ValueError(f"{where}: {name}.elements must be a list [M_y, M_z], got {value['elements']!r}")


def check_star(config: ScenarioConfig, star: Any, seed: Any, where: str) -> dict[str, Any]:
    """``star`` as stored, checked with its ``seed`` and ``config`` (``ValueError`` naming ``where``
    and the field): exactly the keys :data:`STAR_FIELDS`, accepted by the env's constructor; a seed
    >= 0; the config the env builds on that surface for a line of its range, the line the env's
    reset draws for ``seed`` (module docstring)."""
    from ios_uav_env.envs.star_control import STARControlEnv

    check_fields(star, "star", STAR_FIELDS, where)
    try:
        STARControlEnv(**star_kwargs(star))
    except (TypeError, ValueError) as err:
        raise ValueError(f"{where}: star: {err}") from None
    check_line(config, _expected_config(star, float(config.q0[0])), seed, STARControlEnv(elements=(4, 4)),
               where, "STARControl-v0", f"the surface {star['elements']}")  # fmt: skip
    return {k: star[k] for k in STAR_FIELDS}


def check_line(
    config: ScenarioConfig, expected: ScenarioConfig, seed: Any, probe: Any, where: str, env: str, what: str
) -> None:
    """A surface-control scenario's ``seed`` and ``config`` checked (``ValueError`` naming ``where``):
    a seed >= 0; ``config`` the env's episode scenario ``expected`` (``what``: its keywords) with a
    line x in the env's range; the line ``probe`` (an env whose reset's only draw is the line, as in
    every surface-control env) draws for ``seed``."""
    from ios_uav_env.envs.star_control import X_RANGE

    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"{where}: seed must be an integer >= 0 (the episode's reset seed), got {seed!r}")
    x = float(config.q0[0])
    if not X_RANGE[0] <= x <= X_RANGE[1] or config != expected:
        raise ValueError(
            f"{where}: config must be {env}'s episode scenario on {what} with a line x in {list(X_RANGE)} m "
            f"(q0 = (x, -150), qF = (x, 150)), got q0 = {config.q0}, ios_shape = {config.ios_shape}"
        )
    probe.reset(seed=seed)
    if probe.config.q0 != config.q0:
        raise ValueError(
            f"{where}: seed {seed} draws the line x = {probe.config.q0[0]!r} m in {env}, not the "
            f"config's x = {x!r} m: the pair was edited or the env's draw changed; either way it is not "
            "this suite's task"
        )


def make_star_env(star: Mapping[str, Any], env_kwargs: Mapping[str, Any]) -> Any:
    """``gym.make`` of the STAR-control id with the scenario's keywords and ``env_kwargs``."""
    import gymnasium as gym

    import ios_uav_env  # noqa: F401  (registers the ids)
    from ios_uav_env.benchmark.suite_registry import STAR_ENV_ID

    return gym.make(STAR_ENV_ID, **star_kwargs(star), **dict(env_kwargs))


def star_episode(
    env: Any,
    act: Callable[[np.ndarray], Any],
    seed: int,
    config: ScenarioConfig,
    where: str,
    upper: str = "optimum_upper",
) -> StarEpisode:
    """One episode of ``act`` in ``env`` reset with ``seed``, scored by the env's reward sum
    (``upper``: the ``info`` key of a slot's certified bound; ``"bound"`` in MISOControl-v0).

    ``RuntimeError`` naming ``where`` if the env's episode is not ``config`` (its draw for
    ``seed`` changed: another line, another task); ``ValueError`` naming ``where`` for an action
    the env refuses (another width, a NaN)."""
    obs, _ = env.reset(seed=seed)
    base = env.unwrapped
    if base.config != config:
        raise RuntimeError(
            f"{where}: the env reset with seed {seed} drew the line x = {base.config.q0[0]!r} m, not the "
            f"suite's {config.q0[0]!r} m (or another scenario): its draw changed, so this is not the "
            "suite's task; a changed env needs a new suite version"
        )
    seconds, total, info, done = 0.0, 0.0, {}, False
    while not done:
        start = time.perf_counter()
        action = act(obs)
        seconds += time.perf_counter() - start
        try:
            obs, _, terminated, truncated, info = env.step(action)
        except ValueError as err:
            raise ValueError(f"{where}: {err}") from None
        total += info[upper]
        done = terminated or truncated
    n = info["slot"] + 1
    return StarEpisode(info["return"] / n, info["optimum_return"] / n, total / n, seconds)
