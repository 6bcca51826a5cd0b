"""The world's components: surface, link, objective, motion and knowledge, each a small frozen,
validated object with a registry of names, and the :class:`World` that holds one of each.

A scenario (``ScenarioConfig``) and the env's options (``EnvOptions``) are where the components
live today (``World.config_fields`` / ``option_fields`` say which fields each sets, and
``World.of`` reads them back); a component at its default sets a field at its default, so
``ScenarioConfig.to_dict()``, suite hashes and cache keys do not change. ``World.check`` is the one
place that says which combinations the simulator runs. Adding a component kind:
``docs/development.md``, "Adding a component".

- ``base``: ``Component`` and ``Registry``;
- ``surface``, ``link``, ``objective``, ``motion``, ``knowledge``: the families and their kinds;
- ``world``: ``World``, its rules and the combination matrix.
"""

from ios_uav_env.components.base import Component, Registry
from ios_uav_env.components.knowledge import KNOWLEDGE, Exact, Filtered, Knowledge, MeasuredRates, Reports
from ios_uav_env.components.link import LINKS, Link, MultiAntennaLink, SingleAntennaLink
from ios_uav_env.components.motion import MOTIONS, GaussMarkovMotion, Motion, StaticMotion
from ios_uav_env.components.objective import OBJECTIVES, EnergyEfficiency, Objective, Rate
from ios_uav_env.components.surface import SURFACES, IOSSurface, NoSurface, RISSurface, STARSurface, Surface
from ios_uav_env.components.world import FAMILIES, UnsupportedWorld, World, combinations

__all__ = [
    "FAMILIES", "KNOWLEDGE", "LINKS", "MOTIONS", "OBJECTIVES", "SURFACES", "Component", "EnergyEfficiency",
    "Exact", "Filtered", "GaussMarkovMotion", "IOSSurface", "Knowledge", "Link", "MeasuredRates", "Motion",
    "MultiAntennaLink",
    "NoSurface", "Objective", "RISSurface", "Rate", "Registry", "Reports", "STARSurface", "SingleAntennaLink",
    "StaticMotion", "Surface", "UnsupportedWorld", "World", "combinations",
]  # fmt: skip
