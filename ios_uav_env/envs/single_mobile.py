"""The moving, roughly known node of ``IOSUAVEnv`` (``ios_uav_env/IOSUAV-Mobile-v0``).

A mixin of the single-node env, the counterpart of ``multi_mobile.MobileNodes``: it refuses what
a moving or roughly known node does not support, draws the episode's node path at reset
(:meth:`MobileNode.start_track`), writes what the UAV is told of the node after each slot
(:meth:`MobileNode.observe_slot`) and holds the episode's truth and observations (``track``,
``paths``, ``reports``, ``measured_rates``). These are the single-node row protocol's mobile calls
(``ios_uav_env.envs.row_protocol.SingleNodeRow``): the batched env makes ``start_track`` on each
row's template env and observes all its rows in compiled calls on their ``track`` arrays
(``ios_uav_env.envs.knowledge_kernels``). A randomised moving env's batch draws its rows' episodes
together instead (``ios_uav_env.envs.mobile_draws``) and each row env defers its episode to it
(:meth:`MobileNode.defer_episode`: its scenario, kernel and track built when first read). Inactive
(``track`` None) for a static, exactly known node.

It also holds lambda_ref, the reference EE of the energy reward (objective
``"energy_efficiency"``; ``IOSUAVEnv``'s "Energy"): :meth:`MobileNode._scenario_reference` per
scenario (the value the energy ids have always used, and what the ``energy_weight`` feature
shows), and, for a mobile env, :meth:`MobileNode._episode_reference` per episode: the same
reference flights scored on the node path just drawn, which only the reward uses.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ios_uav_env.envs.deferral import defer
from ios_uav_env.envs.knowledge import NodeTrack, observe_slot, start_track
from ios_uav_env.envs.observation import (
    flights_efficiency,
    loiter_efficiency,
    reference_efficiency,
    reference_flights,
)
from ios_uav_env.envs.single_kernels import EP_ENERGY_COST
from ios_uav_env.model.motion import static_paths

if TYPE_CHECKING:
    from ios_uav_env.envs.options import EnvOptions
    from ios_uav_env.model.config import ScenarioConfig
    from ios_uav_env.model.peak import Peak


class MobileNode:
    """The mobile part of ``IOSUAVEnv`` (module docstring)."""

    config: ScenarioConfig
    options: EnvOptions
    energy_objective: bool
    mobile: bool
    np_random: np.random.Generator
    reference_efficiency: float
    _episode: np.ndarray
    _fixed_reference: float | None
    _track: NodeTrack | None
    _rate_clip: float
    trajectory: np.ndarray
    _reference_flights: tuple[ScenarioConfig, list[np.ndarray]] | None = None

    def _check_mobile(self) -> None:
        """Refuse what a moving or roughly known node does not support (yet), naming the field."""
        if self.options.peak_hint:
            raise ValueError(
                "peak_hint is the static node's rate peak: it needs a static, exactly known node "
                "(motion=None and knowledge='exact')"
            )

    def _scenario_reference(self, cfg: ScenarioConfig, peak: Peak | None) -> float:
        """lambda_ref (bits/J) of the scenario ``cfg`` (energy objective; ``peak``: its reachable
        rate peak, None with a fixed ``energy_reference``): the fixed ``energy_reference``, else
        the EE of its hover flight (with ``"loiter"``, the better of its loiter and hover flights')
        with the node at its configured position. A mobile env keeps those flights: each episode
        scores them on its node path (:meth:`_episode_reference`)."""
        fixed, loiter = self._fixed_reference, self.options.energy_reference == "loiter"
        if fixed is not None:
            return fixed
        if not self.mobile:
            return loiter_efficiency(cfg, peak) if loiter else reference_efficiency(cfg, peak)
        flights = reference_flights(cfg, peak, loiter)
        self._reference_flights = (cfg, flights)
        return flights_efficiency(cfg, flights)

    def _episode_reference(self, cfg: ScenarioConfig) -> None:
        """Set the reward's lambda_ref of the episode just drawn on ``cfg`` (energy objective, a
        mobile env, after :meth:`start_track`): the fixed ``energy_reference``, else the scenario's
        reference flights scored on the drawn node path (``observation.flights_efficiency``), the
        EE of feasible plans on the episode's truth, so at most the best EE on it. It enters the
        ``episode`` row's energy cost (the reward), never the observation: the ``energy_weight``
        feature stays the scenario's (:meth:`_scenario_reference`). Held in ``reference_efficiency``."""
        reference = self._fixed_reference
        if reference is None:
            flights = self._reference_flights
            if flights is None or flights[0] is not cfg:  # (the scenario's, set by _set_config)
                raise RuntimeError("the reference flights are not those of the episode's scenario")
            reference = flights_efficiency(cfg, flights[1], self._track.paths)
        self.reference_efficiency = reference
        self._episode[0, EP_ENERGY_COST] = reference / cfg.bandwidth_hz

    def start_track(self, cfg: ScenarioConfig) -> None:
        """Draw the episode's node path on ``cfg`` (the scenario just begun) from ``np_random``
        (``knowledge.start_track``; after the scenario's draws, before the first slot's) into
        :attr:`track`; with the energy objective, set the episode's lambda_ref on it
        (:meth:`_episode_reference`, in ``reference_efficiency`` and ``episode_row``). A mobile
        env only (row protocol)."""
        self._track = start_track(cfg, self.np_random, self.options.report_sigma)
        if self.energy_objective:
            self._episode_reference(cfg)

    def defer_episode(self, source: Any, i: int) -> None:
        """Take the episode a batched env drew for this row env (row ``i`` of ``source``, a
        ``mobile_draws.DrawnEpisodes``; after its generator drew it, instead of ``begin_episode``
        and :meth:`start_track`): the scenario, its rate kernel, the episode row and the track are
        built from ``source`` when first read (:meth:`_resume_episode`), the same as
        ``begin_episode`` and :meth:`start_track` would have made them. A mobile env of the rate
        objective only (row protocol, ``DrawnEpisodes``)."""
        defer(self, source, i, DEFERRED, ("paths", "reports", "measured"))

    def _resume_episode(self) -> None:
        """Build the deferred episode (:meth:`defer_episode`): ``_set_config`` on the row's
        scenario, then its track on the batch's arrays (views: the batched env records in them)."""
        source, i = self.__dict__.pop("_deferral")
        cfg = source.config(i)
        self._set_config(cfg)
        self._track = source.track(i, cfg)
        self.__dict__["_track_views"] = True

    def observe_slot(self, slot: int, q: np.ndarray, obs: np.ndarray) -> None:
        """Write what the UAV at ``q`` is told of the node in ``slot`` (0-based: 0 at reset, n after
        the n-th step) into the observation row ``obs`` in place (the node features 4-5 and,
        unless knowledge is exact, the rate feature 10: ``knowledge.observe_slot``; draws the
        slot's report and measured rate from ``np_random``). A mobile env only (row protocol)."""
        position, rate = observe_slot(
            self._track, slot, q, self.options.knowledge, self.options.report_sigma, self._rate_clip,
            self.np_random, self.options.filter_estimate,
        )  # fmt: skip
        obs[4:6] = 0.0 if position is None else (position - q) / self.options.length_scale
        if rate is not None:
            obs[10] = rate

    @property
    def rate_clip(self) -> float:
        """bps/Hz, where a measured rate is clipped in the observation (the space's rate bound;
        inf for a static, exactly known node)."""
        return self._rate_clip

    @property
    def track(self) -> NodeTrack | None:
        """The episode's node track (``knowledge.NodeTrack``: the true path, each slot's rate kernel
        in ``nodes`` / ``params``, the reports and measured rates), drawn by :meth:`start_track`;
        None for a static, exactly known node. Read-only: the env's own, not a copy."""
        return self._track

    @property
    def paths(self) -> np.ndarray:
        """(N, 1, 2) m: the node's true position w[n] in every slot of the episode (drawn at reset;
        the truth an evaluator scores on, ``score_plan(config, trajectory, paths=paths)``, not an
        observation). Static nodes: the configured position in every slot."""
        if self._track is None:
            return static_paths(self.config)
        return self._track.paths.copy()

    @property
    def reports(self) -> np.ndarray:
        """(n, 1, 2) m: the position reports of the slots so far (knowledge "reports"; else NaN)."""
        n = len(self.trajectory)
        return np.full((n, 1, 2), np.nan) if self._track is None else self._track.reports[:n].copy()

    @property
    def measured_rates(self) -> np.ndarray:
        """(n,) bps/Hz: the measured rates of the slots so far, unclipped (knowledge "reports" or
        "rates"; else NaN)."""
        n = len(self.trajectory)
        return np.full(n, np.nan) if self._track is None else self._track.measured[:n].copy()


#: The attributes of a row env's episode that :meth:`MobileNode.defer_episode` builds when first read.
DEFERRED = ("config", "kernel", "reference_efficiency", "_episode", "_nodes", "_params", "_track")
