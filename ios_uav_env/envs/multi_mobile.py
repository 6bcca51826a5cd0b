"""The moving, roughly known nodes of ``MultiNodeEnv`` (``ios_uav_env/IOSUAV-MultiNode-Mobile-v0``).

A mixin of the multi-node env, the multi-node counterpart of the single env's mobile methods: at
reset it draws the episode's node paths and puts each node's kernel of the slot in the env's
rows (``knowledge.start_nodes_track``); before every step it swaps in the kernels of the slot
flown to (so the compiled step's rates, served rates, reward and score are those at the true
positions); after it, it overwrites what the UAV is told (``knowledge.observe_nodes``): each node
block's position (the truth, a clipped report, the filter's estimate, or 0 for ``"rates"``) and,
unless the knowledge is exact, its served feature (the UAV's own tally, sum of share x measured
rate, over N) and its rate feature (the slot's measured rate, 0 for a node not served). The
batched env calls the same methods on each row's template env (Python per row and slot).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ios_uav_env.envs.knowledge import NodesTrack, observe_nodes, start_nodes_track
from ios_uav_env.model.motion import static_paths

if TYPE_CHECKING:
    from ios_uav_env.envs.multi_kernels import NodeRows
    from ios_uav_env.envs.options import EnvOptions
    from ios_uav_env.model.config import ScenarioConfig

#: The scenario-level features before the node blocks (``multi.BASE_FEATURES``).
N_BASE = 12


class MobileNodes:
    """The mobile part of ``MultiNodeEnv`` (module docstring); inactive for static, exactly known nodes."""

    config: ScenarioConfig
    options: EnvOptions
    node_features: tuple[str, ...]
    np_random: np.random.Generator
    mobile: bool
    _track: NodesTrack | None
    _rate_clip: float
    trajectory: np.ndarray

    def _start_track(self, rows: NodeRows, i: int) -> None:
        """Draw the episode's node paths from ``np_random`` (after the scenario's draws) and put
        slot 1's kernels in row ``i`` of ``rows`` (the batched env runs it on each row's env)."""
        width = rows.nodes.shape[3]
        track = start_nodes_track(self.config, self.np_random, self.options.report_sigma, width)
        if track.nodes.shape[3] > width:  # (path_kernels has rate_kernel's width: never)
            raise RuntimeError(f"a path kernel has {track.nodes.shape[3]} surface nodes, the row {width}")
        self._track = track
        self._put(rows, i, 0)

    def _slot_kernels(self, rows: NodeRows, i: int) -> None:
        """Row ``i``'s node kernels of the slot its next step flies to (the true positions)."""
        slot = int(rows.state[i, 2]) + 1
        if self._track is not None and slot < self.config.N:  # (a row at its end is left alone)
            self._put(rows, i, slot)

    def _put(self, rows: NodeRows, i: int, slot: int) -> None:
        """Copy the track's kernels of ``slot`` into row ``i``; the row's surface nodes beyond the
        track's (the rows grew for another row's wider surface) are padding of zero weight."""
        assert self._track is not None
        k, q = self.config.K, self._track.nodes.shape[3]
        rows.nodes[i, :k, :, :q] = self._track.nodes[:, slot]
        rows.nodes[i, :k, :, q:] = ((0.0,), (1.0,), (0.0,))
        rows.params[i, :k] = self._track.params[:, slot]

    def _observe(self, rows: NodeRows, i: int, obs: np.ndarray) -> None:
        """Write what the UAV is told of the nodes in row ``i``'s current slot into the observation
        row ``obs`` (each node block's position, served and rate features: ``observe_nodes``)."""
        assert self._track is not None
        slot, k_n, o = int(rows.state[i, 2]), self.config.K, self.options
        q, shares = rows.state[i, 0:2], rows.shares[i, :k_n]
        told, rates = observe_nodes(
            self._track, slot, q, shares, o.knowledge, o.report_sigma, self._rate_clip, self.np_random,
            o.filter_estimate,
        )  # fmt: skip
        width = len(self.node_features)
        for k in range(k_n):
            j = N_BASE + width * k
            obs[j + 1 : j + 3] = 0.0 if told is None else (told[k] - q) / o.length_scale
            if rates is not None:  # the UAV's own tally of measured rates, and this slot's (0: not served)
                obs[j + 4] = self._track.tally[k] / self.config.N
                obs[j + 5] = 0.0 if math.isnan(rates[k]) else rates[k]

    @property
    def truth(self) -> np.ndarray | None:
        """(N, K, 2) m: the episode's true node paths (None for static, exactly known nodes)."""
        return None if self._track is None else self._track.paths

    @property
    def paths(self) -> np.ndarray:
        """(N, K, 2) m: every node's true position w_k[n] in every slot of the episode (drawn at
        reset; the configured positions for static nodes): the paths the score is taken on."""
        if self._track is None:
            return static_paths(self.config)
        return self._track.paths.copy()

    @property
    def reports(self) -> np.ndarray:
        """(n, K, 2) m: the clipped position reports of the slots so far (knowledge "reports"; NaN else)."""
        n = len(self.trajectory)
        k = self.config.K
        return np.full((n, k, 2), np.nan) if self._track is None else self._track.reports[:n].copy()

    @property
    def measured_rates(self) -> np.ndarray:
        """(K, n) bps/Hz: each node's measured rate in the slots so far, unclipped (NaN where the
        node was not served, or the knowledge is exact)."""
        n = len(self.trajectory)
        if self._track is None:
            return np.full((self.config.K, n), np.nan)
        return self._track.measured[:, :n].copy()
