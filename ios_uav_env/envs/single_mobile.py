"""The moving, roughly known node of ``IOSUAVEnv`` (``ios_uav_env/IOSUAV-Mobile-v0``).

A mixin of the single-node env, the counterpart of ``multi_mobile.MobileNodes``: it refuses what
a moving or roughly known node does not support, draws the episode's node path at reset
(``knowledge.start_track``), writes what the UAV is told of the node after each slot
(``knowledge.observe_slot``) and holds the episode's truth and observations (``paths``,
``reports``, ``measured_rates``). The batched env calls the same methods on each row's template
env (Python per row and slot). Inactive (``_track`` None) for a static, exactly known node.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ios_uav_env.envs.knowledge import NodeTrack, observe_slot, start_track
from ios_uav_env.model.motion import static_paths

if TYPE_CHECKING:
    from ios_uav_env.envs.options import EnvOptions
    from ios_uav_env.model.config import ScenarioConfig


class MobileNode:
    """The mobile part of ``IOSUAVEnv`` (module docstring)."""

    config: ScenarioConfig
    options: EnvOptions
    energy_objective: bool
    np_random: np.random.Generator
    _track: NodeTrack | None
    _rate_clip: float
    trajectory: np.ndarray

    def _check_mobile(self) -> None:
        """Refuse what a moving or roughly known node does not support (yet), naming the field."""
        if self.options.peak_hint:
            raise ValueError(
                "peak_hint is the static node's rate peak: it needs a static, exactly known node "
                "(motion=None and knowledge='exact')"
            )
        if self.energy_objective:
            raise ValueError(
                "the objective 'energy_efficiency' needs a static, exactly known node (motion=None and "
                "knowledge='exact'): its reference efficiency is a static plan's"
            )

    def _start_track(self, cfg: ScenarioConfig) -> None:
        """Draw the episode's node path on ``cfg`` from ``np_random`` (``knowledge.start_track``;
        after the scenario's draws, before the first slot's)."""
        self._track = start_track(cfg, self.np_random, self.options.report_sigma)

    def _observe(self, slot: int, q: np.ndarray, obs: np.ndarray) -> None:
        """Write what the UAV at ``q`` is told of the node in ``slot`` into the observation row
        ``obs`` (the node features 4-5 and, unless knowledge is exact, the rate feature 10:
        ``knowledge.observe_slot``; the batched env calls it on each row's template env)."""
        position, rate = observe_slot(
            self._track, slot, q, self.options.knowledge, self.options.report_sigma, self._rate_clip,
            self.np_random, self.options.filter_estimate,
        )  # fmt: skip
        obs[4:6] = 0.0 if position is None else (position - q) / self.options.length_scale
        if rate is not None:
            obs[10] = rate

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
