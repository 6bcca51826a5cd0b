"""The episode of ``MultiNodeEnv`` as a row of the kernels, and its moving, roughly known nodes.

A mixin of the multi-node env holding the multi-node row protocol's per-row calls
(``ios_uav_env.envs.row_protocol.MultiNodeRow``), which the env makes on its one row:
:meth:`MobileNodes.load_row` puts the episode just begun in a row of ``multi_kernels.NodeRows``,
:meth:`MobileNodes.prepare_slot` readies the row's next slot, :meth:`MobileNodes.observe_slot`
writes what the UAV is told. The batched env makes ``load_row`` on each row's template env and
the other two, for all its moving rows at once, in compiled calls on the rows' ``track`` arrays
(``ios_uav_env.envs.nodes_kernels``: the same arithmetic and draws, tested equal bit for bit,
the measured rates to the rounding of the step's rates).

With moving or roughly known nodes (``ios_uav_env/IOSUAV-MultiNode-Mobile-v0``; the multi-node
counterpart of the single env's mobile methods) the row's episode draws its node paths and puts
each node's kernel of the slot in the row (``knowledge.start_nodes_track``); before every step it
swaps in the kernels of the slot flown to (so the compiled step's rates, served rates, reward and
score are those at the true positions); after it, it overwrites what the UAV is told
(``knowledge.observe_nodes``): each node block's position (the truth, a clipped report, the
filter's estimate, or 0 for ``"rates"``) and, unless the knowledge is exact, its served feature
(the UAV's own tally, sum of share x measured rate, over N) and its rate feature (the slot's
measured rate, 0 for a node not served).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from ios_uav_env.envs.deferral import defer
from ios_uav_env.envs.knowledge import NodesTrack, observe_nodes, start_nodes_track
from ios_uav_env.envs.node_weights import start_bare_track
from ios_uav_env.envs.nodes_kernels import N_BASE
from ios_uav_env.model.motion import static_paths

if TYPE_CHECKING:
    from ios_uav_env.envs.multi_kernels import NodeRows
    from ios_uav_env.envs.node_weights import NodeWeights
    from ios_uav_env.envs.options import EnvOptions
    from ios_uav_env.model.config import ScenarioConfig


class MobileNodes:
    """The row protocol's calls and the moving nodes of ``MultiNodeEnv`` (module docstring)."""

    config: ScenarioConfig
    options: EnvOptions
    node_features: tuple[str, ...]
    np_random: np.random.Generator
    mobile: bool
    _track: NodesTrack | None
    _rate_clip: float
    trajectory: np.ndarray
    _prepare: Callable[[NodeRows, int], None]  # (multi_energy.EnergyChannel's)
    _fade: Callable[[NodeRows, int], None]

    # --- the row protocol ----------------------------------------------------------------
    def load_row(self, rows: NodeRows, i: int) -> None:
        """Put the episode just begun (``begin_episode``) in row ``i`` of ``rows``: its scenario,
        the node paths and slot 1's kernels (moving or roughly known nodes: drawn from
        ``np_random``), the episode's lambda_ref (energy objective) and slot 1's fading (Rician).
        Moving or roughly known nodes: the row gets its track's kernels only (no static ones first)."""
        rows.load(i, self.config, kernels=not self.mobile)
        if self.mobile:
            self._start_track(rows, i)
        self._prepare(rows, i)

    def load_row_bare(self, rows: NodeRows, i: int, weights: NodeWeights) -> None:
        """:meth:`load_row` for a batched env that computes each slot's node kernels in the row
        (``node_weights.NodeWeights``: ``weights.load`` keeps the row's ground points; it puts slot
        1's kernels in the row itself, ``NodeWeights.put``): the same draws, the track's kernels
        built only when read (``node_weights.BareNodesTrack``). A row the compiled weights do not
        take gets its track's kernels of slot 1 here, as :meth:`load_row`."""
        rows.load(
            i, self.config, kernels=not self.mobile, width=weights.width(self.config) if self.mobile else None
        )
        if self.mobile:
            track = start_bare_track(
                self.config, self.np_random, self.options.report_sigma, rows.nodes.shape[3]
            )
            self._track = track
            if not weights.load(i, self.config, track.paths, rows.nodes):
                self._put(rows, i, 0)
        self._prepare(rows, i)

    def defer_episode(self, source: Any, i: int) -> None:
        """Take the episode a batched env drew for this row env (row ``i`` of ``source``, a
        ``node_draws.DrawnNodeEpisodes``; after its generator drew it, instead of ``begin_episode``
        and :meth:`load_row_bare`): the scenario and the track are built from ``source`` when first
        read (:meth:`_resume_episode`), the same as ``begin_episode`` and ``start_bare_track``
        would have made them. Moving nodes of the rate objective only (``DrawnNodeEpisodes``)."""
        defer(self, source, i, DEFERRED, ("paths", "reports", "measured", "tally"))

    def _resume_episode(self) -> None:
        """Build the deferred episode (:meth:`defer_episode`): the row's scenario, then its track on
        the batch's arrays (views: the batched env records in them)."""
        source, i = self.__dict__.pop("_deferral")
        cfg = source.config(i)
        self.config = cfg
        self._track = source.track(i, cfg)
        self.__dict__["_track_views"] = True

    def put_first_kernels(self, rows: NodeRows, i: int) -> None:
        """Put the track's node kernels of the episode's first slot in row ``i`` of ``rows`` (a row
        whose kernels the batch does not compute: ``NodeWeights``' ``slots[i]`` 0)."""
        self._put(rows, i, 0)

    def prepare_slot(self, rows: NodeRows, i: int) -> None:
        """Ready row ``i`` for its next step: the node kernels of the slot it flies to (moving or
        roughly known nodes) and the slot's fading (channel "rician", from ``np_random``)."""
        if self.mobile:
            self._slot_kernels(rows, i)
        self._fade(rows, i)

    def observe_slot(self, rows: NodeRows, i: int, obs: np.ndarray) -> None:
        """Write what the UAV is told of the nodes in row ``i``'s current slot into the observation
        row ``obs`` in place (each node block's position, served and rate features:
        ``observe_nodes``; reports drawn from ``np_random``). Nothing for static, exactly known
        nodes (the kernel's observation is then the truth)."""
        if self._track is None:
            return
        slot, k_n, o = int(rows.state[i, 2]), self.config.K, self.options
        q, shares = rows.state[i, 0:2], rows.shares[i, :k_n]
        told, rates = observe_nodes(
            self._track, slot, q, shares, o.knowledge, o.report_sigma, self._rate_clip, self.np_random,
            o.filter_estimate, expected=rows.rates[i, :k_n], params=rows.params[i, :k_n],
        )  # fmt: skip
        width = len(self.node_features)
        for k in range(k_n):
            j = N_BASE + width * k
            obs[j + 1 : j + 3] = 0.0 if told is None else (told[k] - q) / o.length_scale
            if rates is not None:  # the UAV's own tally of measured rates, and this slot's (0: not served)
                obs[j + 4] = self._track.tally[k] / self.config.N
                obs[j + 5] = 0.0 if math.isnan(rates[k]) else rates[k]

    @property
    def rate_clip(self) -> float:
        """bps/Hz, where a measured rate is clipped in the observation (the space's rate bound)."""
        return self._rate_clip

    @property
    def track(self) -> NodesTrack | None:
        """The episode's node tracks (``knowledge.NodesTrack``: the true paths, each slot's kernels,
        the reports and measured rates); None for static, exactly known nodes. The env's own."""
        return self._track

    # --- moving nodes ----------------------------------------------------------------------
    def _start_track(self, rows: NodeRows, i: int) -> None:
        """Draw the episode's node paths from ``np_random`` (after the scenario's draws) and put
        slot 1's kernels in row ``i`` of ``rows``."""
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


#: The attributes of a row env's episode that :meth:`MobileNodes.defer_episode` builds when first read.
DEFERRED = ("config", "_track")
