"""Suites of the multi-antenna UAV's beams and the surface's phases as the agent's control (kind
``"miso-control"``, ``miso-v1``): what a scenario holds and the task a policy is bound to.

A scenario runs ``ios_uav_env/MISOControl-v0`` (``ios_uav_env.envs.miso_control``): an N_t-antenna
UAV flies a drawn straight line past a small IOS and the policy sets the K beams and the M phases
in every slot. It holds:

- ``miso``: the env's keywords :data:`MISO_FIELDS` (``antennas``, ``users``, ``elements`` as
  [M_y, M_z], ``objective``), checked at load by the env's own constructor;
- ``seed``: the episode's ``reset(seed=...)``, whose only draw is the line's x;
- ``config``: the episode's scenario as the env builds it after that reset (the first K users as
  its nodes, the line as q0 -> qF), checked at load and at every rollout as a STAR-control
  suite's (:func:`ios_uav_env.benchmark.star_suite.check_line`, ``star_episode``).

**The one scorer** is the STAR-control suites' (``star_suite.star_episode``): a policy's value on a
scenario is the env's reward sum / N (the mean slot objective, bps/Hz: the sum rate or the
smallest rate), the references ``optimum`` and ``bound`` the same episode's
``info["optimum_return"] / N`` (``miso_slot.slot_optimum``'s AO value of every slot) and the mean
of ``info["bound"]`` (``miso.slot_bounds``, certified). Scores are % of the AO optimum and % of
the bound.

**Binding a policy.** The observation has 3 + 4K + 2 N_t (K + 1) + K M features and the action
2 N_t K + M entries: a policy with a ``bind`` method is bound to every scenario with its
:class:`MisoTask` (``star_scoring.bound_policy``), as on the STAR-control suites.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ios_uav_env.model.config import ScenarioConfig

__all__ = ["MISO_FIELDS", "MisoTask", "check_miso", "make_miso_env", "miso_kwargs"]

#: A MISO-control scenario's env keywords (``MISOControlEnv``'s arguments the scenario fixes).
MISO_FIELDS = ("antennas", "users", "elements", "objective")


@dataclass(frozen=True)
class MisoTask:
    """What a policy may know of a scenario before its episode (``bind``'s argument): the env's
    keywords, the observation's feature names and the action's width."""

    antennas: int
    users: int
    elements: tuple[int, int]
    objective: str
    observation_names: tuple[str, ...]
    action_dim: int

    @property
    def M(self) -> int:
        """Elements of the surface."""
        return self.elements[0] * self.elements[1]

    @classmethod
    def of(cls, miso: Mapping[str, Any], env: Any) -> MisoTask:
        """The task of the keywords ``miso`` in ``env`` (made with them)."""
        kw = miso_kwargs(miso)
        base = env.unwrapped
        return cls(kw["antennas"], kw["users"], kw["elements"], kw["objective"],
                   tuple(base.observation_names), int(base.action_space.shape[0]))  # fmt: skip


def miso_kwargs(miso: Mapping[str, Any]) -> dict[str, Any]:
    """The env keywords of a stored ``miso`` (``elements`` as a tuple)."""
    return {**{k: miso[k] for k in MISO_FIELDS}, "elements": tuple(miso["elements"])}


def check_miso(config: ScenarioConfig, miso: Any, seed: Any, where: str) -> dict[str, Any]:
    """``miso`` as stored, checked with its ``seed`` and ``config`` (``ValueError`` naming ``where``
    and the field): exactly the keys :data:`MISO_FIELDS`, accepted by the env's constructor; a seed
    >= 0; the config the env builds for those keywords and the line its reset draws for ``seed``."""
    from ios_uav_env.benchmark.star_suite import check_fields, check_line
    from ios_uav_env.envs.miso_control import USERS, MISOControlEnv
    from ios_uav_env.envs.star_control import BASE_CONFIG, Y_SPAN

    check_fields(miso, "miso", MISO_FIELDS, where)
    try:
        kw = miso_kwargs(miso)
        MISOControlEnv(**kw, optimum=False)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{where}: miso: {err}") from None
    x = float(config.q0[0])
    expected = BASE_CONFIG.replace(ios_shape=kw["elements"], ground_nodes=USERS[: kw["users"]],
                                   q0=(x, Y_SPAN[0]), qF=(x, Y_SPAN[1]))  # fmt: skip
    probe = MISOControlEnv(antennas=1, users=1, optimum=False)  # the reset's only draw is the line
    what = f"{miso['users']} users and the surface {miso['elements']}"
    check_line(config, expected, seed, probe, where, "MISOControl-v0", what)
    return {k: miso[k] for k in MISO_FIELDS}


def make_miso_env(miso: Mapping[str, Any], env_kwargs: Mapping[str, Any]) -> Any:
    """``gym.make`` of the MISO-control id with the scenario's keywords and ``env_kwargs``."""
    import gymnasium as gym

    import ios_uav_env  # noqa: F401  (registers the ids)
    from ios_uav_env.benchmark.suite_registry import MISO_ENV_ID

    return gym.make(MISO_ENV_ID, **miso_kwargs(miso), **dict(env_kwargs))
