"""What each env supports, checked at construction: errors that name the id and what handles the rest.

The envs refuse a setting that would be accepted and then do nothing (a setting that needs
another one, as ``filter_estimate`` needs ``knowledge="reports"``), and a scenario they do not
model (several nodes in a single-node env, another objective than the env's), naming
the registered id the env is and, where one exists, the id that handles the request. The
options' own dependencies are checked by ``EnvOptions``; this module holds the env-level ones.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ios_uav_env.components import UnsupportedWorld, World
from ios_uav_env.envs.registration import (
    ENERGY_ID,
    ENERGY_RANDOM_ID,
    ENV_IDS,
    MISO_ID,
    MISO_SDMA_ID,
    MOBILE_ID,
    MULTINODE_IDS,
    MULTINODE_MOBILE_ID,
    RANDOM_ENV_ID,
    STAR_NOMA_ID,
    STAR_RANDOM_ID,
)
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.scenarios import RANGED_FIELDS

__all__ = [
    "check_world",
    "check_config_keywords",
    "check_ranges_surface",
    "check_multinode_arguments",
    "check_scenario_overrides",
    "multinode_id",
    "multinode_objective",
    "several_nodes_error",
    "single_node_id",
]

#: The static multi-node ids: one scenario, and a new one drawn at every reset.
_MULTI_ID = next(i for i, kw in MULTINODE_IDS.items() if not kw.get("random_nodes"))
_MULTI_RANDOM_ID = next(i for i, kw in MULTINODE_IDS.items() if kw.get("random_nodes"))


def single_node_id(config: ScenarioConfig, knowledge: str = "exact", random: bool = False) -> str:
    """The registered id of the single-node env on ``config`` (``random``: a ``RandomIOSUAVEnv``
    whose family's base is ``config``): the id whose env this is, for error messages."""
    mobile = config.motion is not None or knowledge != "exact"
    if random:
        if mobile:
            return MOBILE_ID
        if config.objective == "energy_efficiency":
            return ENERGY_RANDOM_ID
        return STAR_RANDOM_ID if config.surface == "star" else RANDOM_ENV_ID
    if config.objective == "energy_efficiency":
        return ENERGY_ID
    if config.antennas > 1:
        return MISO_ID
    return next((i for i, kw in ENV_IDS.items() if kw["surface"] == config.surface), "IOSUAVEnv")


def multinode_id(random_nodes: Any, mobile: bool) -> str:
    """The registered id of a ``MultiNodeEnv`` (drawing ``random_nodes`` or not; ``mobile`` nodes)."""
    if mobile:
        return MULTINODE_MOBILE_ID
    return _MULTI_RANDOM_ID if random_nodes else _MULTI_ID


def check_world(
    config: ScenarioConfig,
    options: Any,
    env_id: str,
    field: str = "config",
    noma: bool = False,
    sdma: bool = False,
) -> World:
    """The world of ``config`` (the env's scenario, or its family's base, named ``field``) and
    ``options`` (``EnvOptions``), checked (``ios_uav_env.components.World.check``, the one place
    that says which combinations of components the simulator runs): ``UnsupportedWorld`` (a
    ``ValueError``) naming ``env_id``, ``field``, the components and why. ``noma``: the env runs a
    STAR surface under NOMA (the view ``"star_noma"``); every other env refuses one, naming
    :data:`STAR_NOMA_ID`. ``sdma``: the env runs a multi-antenna UAV serving several nodes at once
    (the view ``"miso_sdma"``); every other env refuses one, naming :data:`MISO_SDMA_ID`."""
    world = World.of(
        config,
        channel=options.channel,
        knowledge=options.knowledge,
        report_sigma=options.report_sigma,
        filter_estimate=options.filter_estimate,
    )
    options_set = ", ".join(f"{name}={value!r}" for name, value in world.option_fields().items())
    try:
        world.check()
    except UnsupportedWorld as err:  # (naming the env's own fields too: the options that set the world)
        raise UnsupportedWorld(f"{env_id} ({field}; {options_set}): {err}") from None
    if world.surface.kind == "star" and world.surface.access == "noma" and not noma:
        named = ", ".join(f"{family} {kind}" for family, kind in world.names().items())
        raise UnsupportedWorld(
            f"{env_id} ({field}; {options_set}): surface star with access 'noma' (star_access='noma', "
            f"{named}) serves a node on each side in one slot; this env serves one node per slot share "
            f"(TDMA): use {STAR_NOMA_ID}, or access 'tdma'"
        )
    if world.link.kind == "multi_antenna" and world.nodes > 1 and not sdma:
        named = ", ".join(f"{family} {kind}" for family, kind in world.names().items())
        raise UnsupportedWorld(
            f"{env_id} ({field}; {options_set}): link multi_antenna with several nodes ({named}): the "
            f"multi-antenna UAV serves them at once (SDMA); this env serves one node per slot share "
            f"(TDMA): use {MISO_SDMA_ID}, or antennas=1"
        )
    return world


def check_config_keywords(
    env_id: str, config: ScenarioConfig, overrides: Mapping[str, Any], alternative: str | None = None
) -> None:
    """``ValueError`` when a scenario keyword (``overrides``: the user's or the id's, as
    ``surface="ris"`` of ``RISUAV-v0``) would replace a field that the ``config`` passed whole set
    to another value than ``ScenarioConfig``'s default: ``gym.make("ios_uav_env/IOSUAV-v0",
    config=ScenarioConfig(surface="ris"))`` would otherwise run the IOS in silence. A field left at
    its default is taken from the keyword (the id's setting wins over a config that did not choose).
    ``alternative``: the id whose setting the config's is, named in the message."""
    default = ScenarioConfig()
    clashes = [
        name
        for name, value in overrides.items()
        if getattr(config, name) != getattr(default, name)
        and getattr(config.replace(**{name: value}), name) != getattr(config, name)
    ]
    if clashes:
        said = ", ".join(
            f"config.{n}={getattr(config, n)!r} but the keyword {n}={overrides[n]!r}" for n in clashes
        )
        raise ValueError(
            f"{env_id}: {said} (the keyword wins, so the config's choice would be dropped). Pass the "
            f"value once, as the keyword (gym.make(id, config=..., {clashes[0]}=...))"
            + (f", or use {alternative}, whose setting the config's is" if alternative else "")
        )


def check_ranges_surface(env_id: str, ranges: Any, surface: str, default_surfaces: tuple[str, ...]) -> None:
    """``ValueError`` when the keyword ``surface`` (the user's or the id's, as ``surface="star"`` of
    ``STARUAV-Random-v0``) would replace the surfaces that ``ranges`` (a ``ScenarioRanges``) chose,
    i.e. set to another tuple than ``default_surfaces`` and than ``(surface,)``: the rule of
    :func:`check_config_keywords` for a family (ranges left at the default surfaces take the keyword's)."""
    chosen = tuple(ranges.surfaces)
    if chosen != tuple(default_surfaces) and chosen != (surface,):
        raise ValueError(
            f"{env_id}: ranges.surfaces={chosen!r} but the keyword surface={surface!r} (the keyword wins, "
            "so the ranges' choice would be dropped). Pass the surfaces once: the keyword (with ranges at "
            f"the default surfaces), or the ranges alone in {RANDOM_ENV_ID}, which draws from any surfaces"
        )


def several_nodes_error(env_id: str, config: ScenarioConfig, field: str = "config") -> ValueError:
    """The error of a single-node env given ``config`` with K > 1 nodes: it names ``env_id``, what
    it supports, and the id that handles several nodes (with the energy objective: the multi-node
    ids given ``objective="energy_efficiency"``)."""
    head = (
        f"{field} has K = {config.K} ground_nodes, but {env_id} is a single-node env (one ground node, "
        "K = 1: ground_node)"
    )
    mobile = config.motion is not None or env_id == MOBILE_ID
    several = MULTINODE_MOBILE_ID if mobile else f"{_MULTI_ID} or {_MULTI_RANDOM_ID}"
    if config.objective == "energy_efficiency":
        several += ' with objective="energy_efficiency" (the max-min rate per joule)'
    return ValueError(f"{head}; several nodes: MultiNodeEnv, {several}")


def multinode_objective(config: ScenarioConfig, field: str, env_id: str, energy: bool) -> None:
    """``ValueError`` unless ``config``'s objective is the multi-node env's: ``"energy_efficiency"``
    when ``energy`` (the env was made with it), else the max-min rate ``"rate"``. The objective
    fixes the observation's layout and the reward, so a pinned scenario cannot change it."""
    own = "energy_efficiency" if energy else "rate"
    if config.objective != own:
        raise ValueError(
            f"{field} has objective={config.objective!r}, but this {env_id} (MultiNodeEnv) was made with "
            f"objective {own!r}, whose observation and reward it has: make an env on the scenario instead "
            f"(gym.make({env_id!r}, objective={config.objective!r}) or MultiNodeEnv(cfg))"
        )


def check_multinode_arguments(
    config: Any, random_nodes: Any, ranges: Any, default_ranges: Any, overrides: Mapping[str, Any]
) -> None:
    """Refuse the ``MultiNodeEnv`` arguments that would do nothing: ``config`` or a drawn field
    (``RANGED_FIELDS``, ``ground_nodes``) with ``random_nodes`` (every reset draws its scenario
    from ``ranges``), and ``ranges`` without it (the env runs its one ``config``)."""
    if random_nodes is None:
        if ranges != default_ranges:
            raise ValueError(
                "ranges is the family that random_nodes draws from: it needs random_nodes=(low, high) "
                "(without it every episode runs config)"
            )
        return
    drawn = sorted(set(overrides) & (RANGED_FIELDS | {"ground_nodes"}))
    if config is not None or drawn:
        what = "config" if config is not None else f"{drawn}"
        raise ValueError(
            f"{what}: with random_nodes={tuple(random_nodes)!r} every reset draws its scenario (its nodes, "
            "T, surface, q0, qF) from ranges, so it would be unused: pass ranges=ScenarioRanges(...) to "
            "change the family, or drop random_nodes to run one scenario"
        )


#: Scenario fields of the surface's channel (not of its geometry, which a scenario without a
#: surface still validates: the UAV flies above the IOS's top edge): they do nothing without one.
SURFACE_CHANNEL_FIELDS = ("gamma", "g_element", "quadrature_nodes", "quadrature_tol")


def check_scenario_overrides(
    env_id: str,
    overrides: Mapping[str, Any],
    surfaces: tuple[str, ...],
    *,
    fades: bool,
    multinode: bool = False,
    budget: bool = False,
    energy: bool = False,
) -> None:
    """Refuse scenario fields given as env keywords (``overrides``) that would do nothing in the
    env ``env_id``, whose scenarios have the ``surfaces`` given: ``kappa`` unless the env samples
    faded rates (``fades``: channel "rician", or measured rates), ``epsilon`` without an IOS, the
    surface's channel fields without a surface (:data:`SURFACE_CHANNEL_FIELDS`), a STAR surface's
    protocol and phase model (one node per slot share: neither enters its rate), and in the
    multi-node env with the max-min rate objective (no energy in its reward, info or score; not
    with ``energy``, the objective ``"energy_efficiency"``) ``bandwidth_hz``, and ``propulsion``
    unless an energy budget (``budget``) makes the flight's energy count. (A field of a config
    passed whole is the scenario's own, as is: only the keywords are checked.)"""
    inert: dict[str, str] = {}
    if not fades:
        inert["kappa"] = (
            "the Rician factor of faded rates: it needs channel='rician' (or measured rates: "
            "knowledge='reports' or 'rates')"
        )
    if "ios" not in surfaces:
        inert["epsilon"] = f"the IOS's transmissive factor: it needs surface 'ios' (this env's: {surfaces})"
    if "star" in surfaces:
        for name, what in (("star_protocol", "protocol"), ("star_phases", "phase model")):
            inert[name] = (
                f"the STAR surface's {what}: an env serves one node per slot share, which gets the whole "
                f"surface on its side at its aligned phases (or its exact b-bit phases, star_bits) whatever "
                f"the {what} (ScenarioConfig.transmit_factor)"
            )
    if set(surfaces) == {"none"}:
        for name in SURFACE_CHANNEL_FIELDS:
            inert[name] = "a field of the surface's channel: it needs a surface (this env has surface 'none')"
    if multinode and not energy:
        inert["bandwidth_hz"] = (
            "the bandwidth of the energy efficiency, which MultiNodeEnv scores only with "
            "objective='energy_efficiency'"
        )
        if not budget:
            inert["propulsion"] = (
                "the propulsion power model: MultiNodeEnv counts the flight's energy only with "
                "objective='energy_efficiency' or against an energy_budget_j"
            )
    for name in overrides:
        if name in inert:
            value = overrides[name]
            raise ValueError(f"{name} is {inert[name]}; in {env_id} {name}={value!r} would do nothing")
