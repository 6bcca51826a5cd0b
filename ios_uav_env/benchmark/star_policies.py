"""A heuristic policy for the STAR-control suites, and the settings of their references.

:class:`ChannelPhases` acts on the observation alone (bound to each scenario's
:class:`~ios_uav_env.benchmark.star_suite.StarTask`): each group's phases are its observed channel
phases (``star_phase_r_<k>``, ``star_phase_t_<k>``: with continuous phases and TDMA these are the
optimum's), rounded by the env to its grid. Under TDMA user r's share is 1 - the observed rate
share (``star_rate_share_r`` = c_r / (c_r + c_t), so tau = c_t / (c_r + c_t), the TDMA optimum's
share of the aligned sides); under NOMA every element splits its energy equally (ES: g = pi / 4)
or every other element transmits (MS: even elements reflect, odd ones transmit), and user r's
power fraction is that same 1 - share (the weaker user gets the larger part). It needs the
channel phases in the observation (``channel_phases=True``, the suite's).

The reference settings read the env's channels (what a controller that knows them sets; not a
policy of the observation): :func:`optimum_setting` (``star_slot.slot_optimum`` of the env's own
surface), :func:`continuous_setting` (the continuous-phase optimum, which the env's action then
rounds to its grid: the ``quantised`` reference) and :func:`aligned_setting` (the ``aligned``
closed form: each side's phases aligned with its channel on the grid, the surface split equally
between the sides as :class:`ChannelPhases` splits it, the TDMA share or NOMA power split then
best, ``star.tdma_maxmin`` / ``star.noma_maxmin``). :func:`setting_policy` plays any of them.

>>> import gymnasium as gym
>>> import ios_uav_env
>>> from ios_uav_env.benchmark.star_policies import ChannelPhases
>>> from ios_uav_env.benchmark.star_suite import StarTask
>>> keywords = dict(elements=[4, 4], bits=None, group=1, protocol="es", access="tdma", direct_link=False)
>>> env = gym.make("ios_uav_env/STARControl-v0", elements=(4, 4))
>>> policy = ChannelPhases().bind(StarTask.of(keywords, env))
>>> obs, _ = env.reset(seed=0)
>>> for _ in range(16):
...     obs, reward, terminated, truncated, info = env.step(policy(obs))
>>> terminated, round(info["pct_of_optimum"], 4)  # the TDMA optimum but for the float32 observation
(True, 100.0)
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ios_uav_env.benchmark.star_suite import StarTask
from ios_uav_env.model.star import StarSurface, noma_maxmin, quantise, side_amplitude, tdma_maxmin
from ios_uav_env.model.star_slot import slot_optimum

__all__ = ["ChannelPhases", "aligned_setting", "continuous_setting", "optimum_setting", "setting_policy"]


class ChannelPhases:
    """The observed channel phases, equal splits (module docstring); ``bind`` it to a scenario."""

    name = "the observed channel phases, equal splits (heuristic, ChannelPhases)"

    def __init__(self) -> None:
        self.task: StarTask | None = None

    def bind(self, task: StarTask) -> ChannelPhases:
        """A copy that acts on ``task``'s scenario (``ValueError`` if its observation has no channel
        phases: the env must be made with ``channel_phases=True``)."""
        names = list(task.observation_names)
        needed = [f"star_phase_{s}_{k}" for s in ("r", "t") for k in range(task.G)] + ["star_rate_share_r"]
        missing = [n for n in needed if n not in names]
        if missing:
            raise ValueError(
                f"ChannelPhases reads the channel phases: the observation lacks {missing[:3]}... (make the "
                "env with channel_phases=True, the suite's)"
            )
        bound = copy.copy(self)
        bound.task = task
        bound._phases = np.array([names.index(n) for n in needed[:-1]])
        bound._share = names.index("star_rate_share_r")
        return bound

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        task = self.task
        if task is None:
            raise ValueError("ChannelPhases is unbound: bind it to the scenario (policy.bind(task))")
        o = np.asarray(obs, dtype=np.float64)
        split = [1.0 - 2.0 * o[self._share]]  # a = 2 (1 - share_r) - 1
        if task.access == "tdma":
            return np.concatenate([o[self._phases], split])
        modes = np.zeros(task.G) if task.protocol == "es" else np.where(np.arange(task.G) % 2, 1.0, -1.0)
        return np.concatenate([o[self._phases], modes, split])

    def __repr__(self) -> str:
        return "ChannelPhases()"


def optimum_setting(env: Any) -> dict[str, Any]:
    """``slot_optimum``'s setting of the env's current slot (its own surface and access)."""
    return slot_optimum(env.channels[env.slot], env.surface, env.access).setting


def continuous_setting(env: Any) -> dict[str, Any]:
    """The continuous-phase optimum's setting of the env's current slot (the same protocol)."""
    surface = StarSurface(env.surface.protocol, env.surface.phases, None)
    return slot_optimum(env.channels[env.slot], surface, env.access).setting


def aligned_setting(env: Any) -> dict[str, Any]:
    """The aligned closed form of the env's current slot (module docstring)."""
    ch, bits, m = env.channels[env.slot], env.surface.bits, env.M
    theta_r, theta_t = quantise(ch.phi_r, bits), quantise(ch.phi_t, bits)
    if env.access == "tdma":
        u_r = u_t = np.ones(m)
    elif env.surface.protocol == "es":
        u_r = u_t = np.full(m, math.sqrt(0.5))
    else:
        u_t = (np.arange(m) % 2).astype(np.float64)
        u_r = 1.0 - u_t
    amp_r = side_amplitude(u_r * ch.a_r, ch.phi_r, ch.direct_r, theta_r)
    amp_t = side_amplitude(u_t * ch.a_t, ch.phi_t, ch.direct_t, theta_t)
    g_r, g_t = ch.eta * amp_r**2, ch.eta * amp_t**2
    setting = dict(u_r=u_r, u_t=u_t, theta_r=theta_r, theta_t=theta_t)
    if env.access == "tdma":
        return {**setting, "share": tdma_maxmin(math.log2(1 + g_r), math.log2(1 + g_t))[1]}
    return {**setting, "split": float(noma_maxmin(g_r, g_t)[1])}


def setting_policy(env: Any, setting_of: Callable[[Any], Any]) -> Callable[[np.ndarray], np.ndarray]:
    """An action function that plays ``setting_of(env)`` of every slot (``env.action_of``; a tuple
    setting, as MISOControl-v0's (phases, beams), is its arguments)."""
    base = env.unwrapped

    def act(obs: np.ndarray) -> np.ndarray:
        setting = setting_of(base)
        return base.action_of(*setting) if isinstance(setting, tuple) else base.action_of(setting)

    return act
