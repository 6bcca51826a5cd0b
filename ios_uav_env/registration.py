"""Registration of the namespaced, versioned env ids (idempotent; called on import)."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
from gymnasium.envs.registration import WrapperSpec

from ios_uav_env.config import ScenarioConfig, scenario_option

_DEFAULT_STEPS = ScenarioConfig().N - 1  # one step per move: N - 1 = 149 at the paper's T = 150 s

#: id -> keyword arguments of ``IOSUAVEnv`` for that id.
ENV_IDS: dict[str, dict[str, Any]] = {
    "ios_uav_env/IOSUAV-v0": {"surface": "ios"},  # the paper's scenario (IA)
    "ios_uav_env/RISUAV-v0": {"surface": "ris"},  # the IOS replaced by a reflect-only RIS (RA)
    "ios_uav_env/UAV-v0": {"surface": "none"},  # no surface: direct link only (CUC)
}

#: The randomised id: every reset draws a scenario from ``random_env.DEFAULT_RANGES``.
RANDOM_ENV_ID = "ios_uav_env/IOSUAV-Random-v0"


class HorizonCheck(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Refuses, at reset, a ``TimeLimit`` below it that would end the episode before slot N
    (of the episode's scenario: the one of ``options={"config": cfg}`` if given).

    ``gym.make`` gives the env itself a spec without ``max_episode_steps`` (only the wrappers
    know it), so the check runs here, outermost, where ``self.env.spec`` has the limit.
    """

    def __init__(self, env: gym.Env) -> None:
        gym.utils.RecordConstructorArgs.__init__(self)
        gym.Wrapper.__init__(self, env)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> Any:
        self.env.unwrapped.check_time_limit(self.env.spec, scenario_option(options))
        return self.env.reset(seed=seed, options=options)


_WRAPPERS = (WrapperSpec("HorizonCheck", f"{__name__}:HorizonCheck", {}),)


def register_envs() -> None:
    """Register every id of :data:`ENV_IDS` that is not registered yet.

    ``max_episode_steps`` is N - 1 of the default horizon; the env itself ends every
    episode after its own N - 1 steps, and refuses (at reset, through the
    :class:`HorizonCheck` wrapper every id adds on top) a TimeLimit shorter than that, so a
    longer ``T`` needs ``gym.make(..., T=300, max_episode_steps=299)``. :data:`RANDOM_ENV_ID`
    (``random_env.RandomIOSUAVEnv``) has ``max_episode_steps`` = N - 1 of the longest horizon
    of its ranges (199 steps at T = 200 s).
    """
    for env_id, kwargs in ENV_IDS.items():
        if env_id in gym.registry:
            continue
        gym.register(
            id=env_id,
            entry_point="ios_uav_env.env:IOSUAVEnv",
            max_episode_steps=_DEFAULT_STEPS,
            kwargs=dict(kwargs),
            additional_wrappers=_WRAPPERS,
        )
    if RANDOM_ENV_ID not in gym.registry:
        from ios_uav_env.random_env import DEFAULT_RANGES

        gym.register(
            id=RANDOM_ENV_ID,
            entry_point="ios_uav_env.random_env:RandomIOSUAVEnv",
            max_episode_steps=DEFAULT_RANGES.max_moves,
            additional_wrappers=_WRAPPERS,
        )
