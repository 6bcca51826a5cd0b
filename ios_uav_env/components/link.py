r"""Link components: how the slot's rate follows from the UAV, the surface's control and the beam.

:class:`SingleAntennaLink` is today's link: a single-antenna UAV, one node served per slot,
rate log2(1 + eta E|h|^2) (bps/Hz). Its interface is the one every link keeps: the slot's rate
at UAV ``positions`` for the config's node, given the surface's ``phases`` (K, M) (None: the
surface's closed-form phases, eq. (13)) and the transmit ``beam`` (None: the UAV's only antenna
at full power). With ``phases`` given, the expected gain of the Rician channel of eqs. (4)-(8)
is E|h|^2 = kappa/(1+kappa) |h^LoS(psi)|^2 + 1/(1+kappa) (sum_m a_m + a_D)^2, which for the
closed-form phases is zeta^2 (``channel.slot_rates``): the link and the env's rate agree there.
``fading`` is what the env samples each slot: the expected-gain rate (the paper's objective) or
one Rician faded sample (the env option ``channel``). ``region_pricer`` is the link's per-slot
weighted-sum problem along a flight, from which the flight's max-min over several users is solved
(``ios_uav_env.model.regions``): TDMA here, equal to the frame's schedule; a link that serves
several users at once gives its own.

:class:`MultiAntennaLink` is an N_t-antenna UAV (``ios_uav_env.model.miso``; the scenario field
``antennas``): the env sets the surface's phases and the beam at their joint optimum for the node
served, the aligned phases and MRT, whose rate is log2(1 + G) in closed form
(``channel.aligned_gain``; the derivation is ``model.miso``'s module docstring). At N_t = 1 it is
:class:`SingleAntennaLink` exactly. Its region serves several users at once (SDMA with the per-slot
AO beams, ``model.miso_regions.miso_pricer``).
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import numpy as np

from ios_uav_env.components.base import Component, Registry
from ios_uav_env.model import channel
from ios_uav_env.model.array import scenario_array
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.config_checks import checked_antennas
from ios_uav_env.model.miso_regions import miso_pricer
from ios_uav_env.model.regions import Pricer, tdma_pricer
from ios_uav_env.model.schedule import node_rates

__all__ = ["FADINGS", "LINKS", "Link", "MultiAntennaLink", "SingleAntennaLink"]

#: What the env samples each slot (the env option ``channel``).
FADINGS: tuple[str, ...] = ("expected", "rician")


@dataclasses.dataclass(frozen=True)
class Link(Component):
    """A link: ``antennas`` at the UAV, ``fading`` sampled each slot."""

    family: ClassVar[str] = "link"
    antennas: ClassVar[int] = 1
    fading: str = "expected"

    def __post_init__(self) -> None:
        if self.fading not in FADINGS:
            raise ValueError(f"link.fading must be one of {FADINGS}, got {self.fading!r}")

    @classmethod
    def variants(cls) -> tuple[Link, ...]:
        """One link per ``fading``."""
        return tuple(cls(fading=f) for f in FADINGS)

    def option_fields(self) -> dict[str, Any]:
        """The env options this link sets."""
        return {"channel": self.fading}

    def config_fields(self) -> dict[str, Any]:
        """The ``ScenarioConfig`` fields this link sets (the UAV's ``antennas``)."""
        return {"antennas": self.antennas}

    def rates(
        self,
        config: ScenarioConfig,
        positions: np.ndarray,
        phases: np.ndarray | None = None,
        beam: np.ndarray | None = None,
    ) -> np.ndarray:
        """Expected-gain rate (bps/Hz) of ``config``'s node at each UAV position, shape (K,)."""
        raise NotImplementedError

    def region_pricer(
        self, config: ScenarioConfig, trajectory: np.ndarray, paths: np.ndarray | None = None
    ) -> Pricer:
        """The weighted-sum pricer of the slots' rate regions along ``trajectory`` (N, 2) m for
        ``config``'s K nodes (``paths`` (N, K, 2): moving nodes' true paths): what the flight's
        max-min over several users served at once is solved from
        (``ios_uav_env.model.regions.maxmin_regions``)."""
        raise NotImplementedError


#: The link registry.
LINKS: Registry[Link] = Registry("link")


@LINKS.register("single_antenna")
@dataclasses.dataclass(frozen=True)
class SingleAntennaLink(Link):
    """One antenna at the UAV, one node per slot (module docstring)."""

    kind: ClassVar[str] = "single_antenna"

    def rates(
        self,
        config: ScenarioConfig,
        positions: np.ndarray,
        phases: np.ndarray | None = None,
        beam: np.ndarray | None = None,
    ) -> np.ndarray:
        """Expected-gain rate log2(1 + eta E|h|^2) at each position (module docstring), (K,)."""
        config.require_single_node("SingleAntennaLink.rates")
        if beam is not None:
            raise ValueError(
                f"beam is the transmit beam of a multi-antenna UAV; link 'single_antenna' has "
                f"{self.antennas} antenna at full power: pass beam=None"
            )
        q = channel.as_positions(positions)
        if phases is None:
            return channel.slot_rates(config, q)
        return channel.phased_rates(config, q, phases)

    def region_pricer(
        self, config: ScenarioConfig, trajectory: np.ndarray, paths: np.ndarray | None = None
    ) -> Pricer:
        """TDMA: one node per slot at its expected-gain rate (``schedule.node_rates``), so the
        regions' max-min is the frame's schedule (``maxmin_rate``)."""
        return tdma_pricer(node_rates(config, channel.as_positions(trajectory, "trajectory"), paths))


#: The antennas of :class:`MultiAntennaLink` by default (the multi-antenna id's).
DEFAULT_ANTENNAS = 4


@LINKS.register("multi_antenna")
@dataclasses.dataclass(frozen=True)
class MultiAntennaLink(Link):
    """An N_t-antenna UAV (``antennas``, an integer in [1, ``array.MAX_ANTENNAS``]), the beam and the
    surface's phases at their closed-form joint optimum for the node served (module docstring)."""

    kind: ClassVar[str] = "multi_antenna"
    antennas: int = DEFAULT_ANTENNAS  # type: ignore[misc]  # (a field here, the base's class constant)

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "antennas", checked_antennas(self.antennas, "link.antennas"))

    def _config(self, config: ScenarioConfig) -> ScenarioConfig:
        """``config`` with this link's antennas."""
        return config if config.antennas == self.antennas else config.replace(antennas=self.antennas)

    def rates(
        self,
        config: ScenarioConfig,
        positions: np.ndarray,
        phases: np.ndarray | None = None,
        beam: np.ndarray | None = None,
    ) -> np.ndarray:
        """The closed-form rate log2(1 + G) at each position (``channel.slot_rates`` with this link's
        antennas: aligned phases and MRT), (K,). Other phases or beams are the per-slot control of
        ``ios_uav_env.model.miso`` (``SlotChannel``; the env ``MISOControl-v0``): refused here."""
        config.require_single_node("MultiAntennaLink.rates")
        if phases is not None or beam is not None:
            raise ValueError(
                "link 'multi_antenna' sets the phases and the beam at their closed-form optimum: pass "
                "phases=None and beam=None (any other setting: ios_uav_env.model.miso.SlotChannel)"
            )
        return channel.slot_rates(self._config(config), channel.as_positions(positions))

    def region_pricer(
        self, config: ScenarioConfig, trajectory: np.ndarray, paths: np.ndarray | None = None
    ) -> Pricer:
        """One node: its closed-form rate per slot (``tdma_pricer``, the mean rate). Several: served
        at once with the per-slot AO beams (``model.miso_regions.miso_pricer``; static nodes)."""
        cfg, q = self._config(config), channel.as_positions(trajectory, "trajectory")
        if cfg.K == 1:
            return tdma_pricer(node_rates(cfg, q, paths))
        if paths is not None:
            raise ValueError("paths: the multi-antenna link's region of several users is for static nodes")
        return miso_pricer(cfg, scenario_array(cfg), q)
