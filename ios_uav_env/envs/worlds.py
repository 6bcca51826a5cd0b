"""Envs from worlds: ``make_world`` builds the env (single or batched) that runs a
``ios_uav_env.components.World`` (a STAR surface under NOMA: ``ios_uav_env/STARUAV-NOMA-v0``; a
multi-antenna UAV serving several nodes: ``ios_uav_env/MISOUAV-SDMA-v0``).
Every env checks its own world at construction
(``settings.check_world``: ``World.check``, the one place that says which combinations of
components the simulator runs).

>>> from ios_uav_env.components import World
>>> env = make_world(World(surface="ris", motion="gauss_markov", knowledge="reports"))
>>> env.unwrapped.config.surface, env.unwrapped.options.knowledge
('ris', 'reports')
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from ios_uav_env.components import World
from ios_uav_env.envs.core.vector import UAVVectorEnv
from ios_uav_env.envs.miso_sdma import SDMA_CONFIGS
from ios_uav_env.envs.multi_features import DEFAULT_NODES
from ios_uav_env.envs.registration import MISO_SDMA_ID, STAR_NOMA_ID, presets
from ios_uav_env.envs.star_noma import NOMA_CONFIG
from ios_uav_env.model.config import ScenarioConfig, as_config

__all__ = ["default_scenario", "make_world"]

#: The id whose env runs a world of one node, and of several (its config given whole).
SINGLE_NODE_ID = "ios_uav_env/IOSUAV-v0"
MULTI_NODE_ID = "ios_uav_env/IOSUAV-MultiNode-v0"


def default_scenario(nodes: int, noma: bool = False, sdma: bool = False) -> ScenarioConfig:
    """The scenario a world of ``nodes`` nodes runs on when none is given: the paper's for one
    node, the multi-node id's three nodes (``multi.DEFAULT_NODES``) for three, the NOMA id's
    (``star_noma.NOMA_CONFIG``) for a STAR surface under NOMA (``noma``), the SDMA ids' of that
    many users (``miso_sdma.SDMA_CONFIGS``) for a multi-antenna UAV serving several nodes
    (``sdma``)."""
    if noma:
        return NOMA_CONFIG
    if sdma and nodes in SDMA_CONFIGS:
        return SDMA_CONFIGS[nodes]
    if nodes == 1:
        return ScenarioConfig()
    if nodes == len(DEFAULT_NODES):
        return ScenarioConfig(ground_nodes=DEFAULT_NODES)
    raise ValueError(
        f"a world of nodes={nodes} needs config=ScenarioConfig(ground_nodes=...) with {nodes} nodes (the "
        f"default scenarios have 1 or {len(DEFAULT_NODES)})"
    )


def make_world(
    world: World, config: ScenarioConfig | dict | None = None, *, num_envs: int | None = None, **kwargs: Any
) -> Any:
    """The env that runs ``world`` on ``config`` (its other fields; default:
    :func:`default_scenario`), single (``gym.make``: the registered id's wrappers) or, with
    ``num_envs``, batched (``UAVVectorEnv`` with the id's preset, B rows). ``kwargs``: more
    ``EnvOptions`` (the view: ``instance_features``, ``peak_hint``, ...) or the env's own arguments.
    An unsupported world raises ``UnsupportedWorld`` before anything is built."""
    if not isinstance(world, World):
        raise TypeError(f"world must be an ios_uav_env.components.World, got {world!r}")
    world.check()
    noma = world.surface.kind == "star" and world.surface.access == "noma"  # (two users: the NOMA id)
    sdma = world.link.kind == "multi_antenna" and world.nodes > 1  # (2 to 4 users: the SDMA id)
    base = default_scenario(world.nodes, noma, sdma) if config is None else as_config(config)
    if base.K != world.nodes:
        raise ValueError(f"config has K = {base.K} ground nodes, but the world has nodes={world.nodes}")
    clash = sorted(set(kwargs) & (set(world.config_fields()) | set(world.option_fields())))
    if clash:
        raise ValueError(f"{clash} are set by the world's components: change the world, not the keywords")
    cfg = base.replace(**world.config_fields())
    arguments = {"config": cfg, **world.option_fields(), **kwargs}
    env_id = SINGLE_NODE_ID if world.nodes == 1 else MULTI_NODE_ID
    env_id = STAR_NOMA_ID if noma else MISO_SDMA_ID if sdma else env_id
    if world.nodes == 1:  # the single-node id's own keyword (its surface) would replace the config's
        arguments["surface"] = cfg.surface
    if num_envs is None:
        return gym.make(env_id, **arguments)
    return UAVVectorEnv(num_envs=num_envs, **{**presets()[env_id], **arguments})
