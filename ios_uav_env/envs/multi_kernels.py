"""The multi-node envs' rows: :class:`NodeRows` holds the arrays of B multi-node episodes (row i =
episode i), loads each row's scenario and calls the compiled kernels of
``ios_uav_env.envs.multi_step`` on them (re-exported here: ``reset_rows``, ``step_rows``,
``step_rows_batched``, ``fly_rows``, ``soft_minimum``), one implementation for ``MultiNodeEnv`` (a
batch of one) and ``MultiNodeVectorEnv`` (B rows); :func:`episode_best_values` scores the rows
whose episodes end, :func:`move_norms` the moves' lengths the kernels take. The arrays' layout
and the kernels' contract: ``multi_step``'s docstring.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ios_uav_env.envs.core.kernel import flags_of
from ios_uav_env.envs.multi_step import (  # noqa: F401 (the kernels, re-exported)
    fly_rows,
    keep_rates,
    reset_rows,
    soft_minimum,
    step_rows,
    step_rows_batched,
)
from ios_uav_env.envs.multi_table import (
    ACT_MOVE_X,
    ACT_MOVE_Y,
    ACT_SCORES,
    EPISODE,
    MST_MOVES_MADE,
    MST_X,
    MST_Y,
    POINT,
    STATE,
    episode_row,
    node_peaks,
    node_points,
    set_reference,
)
from ios_uav_env.envs.options import EnvOptions
from ios_uav_env.jit import run_batched
from ios_uav_env.model.channel import PARAMS
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.maxmin_paths import SIZE_K, SIZE_N, path_values
from ios_uav_env.model.node_kernels import kernel_width, node_kernels

if TYPE_CHECKING:
    from ios_uav_env.envs.knowledge import NodesTrack


def move_norms(actions: np.ndarray) -> np.ndarray:
    """The ``norms`` of :func:`step_rows_batched`: ``math.hypot`` of the move of each row of ``actions``
    whose squared move exceeds 1 - 1e-6 (the rows it may project), 0 for the others (whose
    norm is below 1: the kernel does not read it)."""
    norms = np.zeros(actions.shape[0])
    rows = np.flatnonzero(actions[:, ACT_MOVE_X] ** 2 + actions[:, ACT_MOVE_Y] ** 2 > 1.0 - 1e-6)
    if rows.size:
        norms[rows] = list(
            map(math.hypot, actions[rows, ACT_MOVE_X].tolist(), actions[rows, ACT_MOVE_Y].tolist())
        )
    return norms


class NodeRows:
    """The arrays of B multi-node episodes (row i = episode i; the layout of the module's
    docstring), the scenario loaded in each row, and the kernel calls on them. ``options``,
    ``sharpness`` and ``softmin_beta`` are the env's (``EnvOptions``, ``share_sharpness``,
    ``softmin_beta``); ``energy``: the objective is ``"energy_efficiency"``. ``path`` and
    ``share_path`` hold each row's way-points and shares; ``normals`` (B, K_max, 2) the draws of
    the slot's fading (channel "rician": the env writes them before each kernel call)."""

    def __init__(
        self, num_rows: int, max_nodes: int, options: EnvOptions, sharpness: float, softmin_beta: float,
        energy: bool = False, served_clip: float = math.inf,
    ) -> None:  # fmt: skip
        b, k = num_rows, max_nodes
        self.flags = flags_of(options, energy)
        self.settings = (options.length_scale, sharpness, softmin_beta, options.peak_hint, served_clip)
        self.state, self.episode = np.zeros((b, len(STATE))), np.zeros((b, len(EPISODE)))
        self.points, self.served = np.zeros((b, k, len(POINT))), np.zeros((b, k))
        self.shares, self.rates = np.zeros((b, k)), np.zeros((b, k))
        self.expected, self.normals = np.zeros((b, k)), np.zeros((b, k, 2))
        self.nodes, self.params = np.zeros((b, k, 3, 1)), np.zeros((b, k, len(PARAMS)))
        self.path, self.share_path = np.zeros((b, 1, 2)), np.zeros((b, 1, k))
        # each slot's node rates as the kernels computed them (rate_path), while `stored` (a row
        # not flown by fly(), which skips slots): the episode's best schedule needs no new rates
        self.rate_path, self.stored = np.zeros((b, 1, k)), np.zeros(b, dtype=np.bool_)
        self.loaded: list[ScenarioConfig | None] = [None] * b
        # each row's (K, N): its scenario's, or those of a row drawn in compiled code (no config)
        self.sizes = np.zeros((b, 2), dtype=np.int64)
        # the rows whose scenario was loaded without its static node kernels (load(kernels=False))
        self.bare = np.zeros(b, dtype=np.bool_)
        # the arrays of the scenario loaded last (_scenario_arrays): rows that load the same
        # scenario object (a fixed id's, a batch reset on one pinned scenario) copy them
        self._held_config: ScenarioConfig | None = None
        self._held_width: int | None = None
        self._held_kernels: tuple[np.ndarray, np.ndarray] | None = None
        self._held_rows: tuple[np.ndarray, np.ndarray] = (np.zeros(0), np.zeros(0))

    def _grow(self, name: str, axis: int, size: int, fill: tuple[float, ...] = (0.0,)) -> None:
        """Grow array ``self.<name>`` along ``axis`` to ``size``; new entries 0, or ``fill`` over the
        array's second-to-last axis (``nodes``: padded surface nodes (0, 1, 0) have zero weight)."""
        old = getattr(self, name)
        shape = list(old.shape)
        shape[axis] = size
        grown = np.zeros(shape)
        if len(fill) > 1:
            grown[...] = np.asarray(fill).reshape(-1, 1)
        grown[tuple(slice(0, n) for n in old.shape)] = old
        setattr(self, name, grown)

    def fit(self, width: int, slots: int) -> None:
        """Grow the arrays to hold node kernels of ``width`` surface nodes (the new ones padding of
        zero weight in every row) and episodes of ``slots`` slots."""
        if width > self.nodes.shape[3]:
            self._grow("nodes", 3, width, fill=(0.0, 1.0, 0.0))  # padded nodes: zero weight
        if slots > self.path.shape[1]:
            for name in ("path", "share_path", "rate_path"):
                self._grow(name, 1, slots)

    def load(self, i: int, cfg: ScenarioConfig, kernels: bool = True, width: int | None = None) -> None:
        """Copy the scenario ``cfg`` into row ``i`` (unless it is already there) and put the UAV at q0
        (the energy reward's lambda_ref: :meth:`set_reference`). ``kernels=False`` leaves the row's
        node kernels to the caller, who puts its own at once (moving nodes: the track's of slot 1):
        the arrays still grow to the scenario's surface width, but no surface is projected;
        ``width``: that width (``kernel_width(cfg)``) where the caller knows it."""
        if self.loaded[i] is not cfg or (kernels and self.bare[i]):
            width, held_kernels, points, episode = self._scenario_arrays(cfg, kernels, width)
            self.fit(width, cfg.N)
            if kernels:
                nodes, params = held_kernels  # each node's rate kernel, no config per node
                self.nodes[i, : cfg.K, :, :width] = nodes
                self.nodes[i, : cfg.K, :, width:] = ((0.0,), (1.0,), (0.0,))
                self.params[i, : cfg.K] = params
            self.bare[i] = not kernels
            self.points[i, : cfg.K] = points
            self.episode[i] = episode
            self.loaded[i] = cfg
        self.sizes[i, SIZE_K], self.sizes[i, SIZE_N] = cfg.K, cfg.N
        self.state[i, MST_X], self.state[i, MST_Y] = self.path[i, 0] = cfg.q0

    def _scenario_arrays(
        self, cfg: ScenarioConfig, kernels: bool, width: int | None = None
    ) -> tuple[Any, ...]:
        """(Q, (nodes, params) or None, points, episode row) of ``cfg`` as :meth:`load` writes them
        (``kernels``: with the node kernels): those of the scenario object loaded last when
        ``cfg`` is it (the same numbers: each is a function of the scenario and the settings),
        else computed and held. Q is the kernels' width (``kernel_width``'s, which the moving
        nodes' loads ask for without the kernels)."""
        if self._held_config is not cfg:
            length_scale, sharpness, softmin_beta, peak_hint, clip = self.settings
            points = node_points(cfg, node_peaks(cfg) if peak_hint else None)
            episode = episode_row(cfg, length_scale, sharpness, softmin_beta, peak_hint, 0.0, clip)
            self._held_config, self._held_rows = cfg, (points, episode)
            self._held_width = self._held_kernels = None
        if kernels and self._held_kernels is None:
            nodes, params = node_kernels(cfg)
            self._held_width, self._held_kernels = int(nodes.shape[2]), (nodes, params)
        elif self._held_width is None:
            self._held_width = kernel_width(cfg) if width is None else width
        return (self._held_width, self._held_kernels, *self._held_rows)

    def set_reference(self, i: int, reference: float, observed: float | None = None) -> None:
        """lambda_ref (bits/J) of row ``i``'s episode, and the one its observation shows
        (``multi_table.set_reference`` on its loaded scenario)."""
        cfg = self.loaded[i]
        assert cfg is not None
        set_reference(self.episode[i], cfg, reference, observed)

    def start(self, rows: np.ndarray, obs: np.ndarray, info: np.ndarray) -> None:
        """:func:`reset_rows` on ``rows`` (int64), writing ``obs`` and the ``info`` table."""
        reset_rows(rows, self.state, self.episode, self.points, self.nodes, self.params, self.served,
                   self.shares, self.rates, obs, info, self.share_path, self.expected, self.normals,
                   self.flags)  # fmt: skip
        keep_rates(rows, self.state, self.rates, self.rate_path)
        self.stored[rows] = True

    def step(self, actions: np.ndarray, active: np.ndarray, outputs: tuple[np.ndarray, ...],
             norms: np.ndarray, num_threads: int | None = None, serial: bool = False) -> None:  # fmt: skip
        """One slot of the ``active`` rows: :func:`step_rows_batched` (``run_batched`` on
        ``num_threads``), or with ``serial`` :func:`step_rows`. ``outputs``: the arrays it writes,
        (obs, reward, terminated, info); ``norms``: the moves' ``math.hypot`` where it may exceed 1
        (:func:`move_norms`)."""
        obs, reward, terminated, info = outputs
        args: tuple[Any, ...] = (actions, self.state, self.episode, self.points, self.nodes, self.params,
                                 self.served, self.shares, self.rates, self.flags, obs, reward, terminated,
                                 info, self.path, self.share_path, active, norms, self.expected,
                                 self.normals, self.rate_path)  # fmt: skip
        if serial:
            step_rows(*args)
        else:
            run_batched(step_rows_batched, step_rows, num_threads, *args)

    def fly(self, rows: np.ndarray, targets: np.ndarray, moves: np.ndarray, obs: np.ndarray,
            info: np.ndarray) -> None:  # fmt: skip
        """:func:`fly_rows` (checked arguments: ``ValueError`` if the kernel still refuses an
        entry, having flown nothing), writing ``obs`` and the ``info`` table."""
        b, width = self.state.shape[0], ACT_SCORES + self.shares.shape[1]
        self.stored[rows[(rows >= 0) & (rows < b)]] = False  # (its slots' rates are not kept)
        bad = fly_rows(rows, targets, moves, np.zeros((b, width)), self.state, self.episode, self.points,
                       self.nodes, self.params, self.served, self.shares, self.rates, self.flags, obs,
                       np.zeros(b), np.zeros(b, dtype=np.bool_), info, self.path, self.share_path,
                       np.zeros(b), self.expected, self.normals, self.rate_path)  # fmt: skip
        if bad >= 0:
            raise ValueError(
                f"fly entry {bad} (row {rows[bad] if bad < rows.size else '?'}) is out of range: rows must "
                f"be 0..{b - 1}, moves >= 0 and, summed per row, leave each row's episode unfinished"
            )

    def best_values(self, rows: np.ndarray, num_threads: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(values, certified): the best-schedule value of each of ``rows`` (ended episodes) on its
        scenario's static nodes, all rows in one compiled call (``maxmin_paths.path_values``)."""
        return path_values(rows, self.sizes[rows], self.path, self.nodes, self.params, num_threads,
                           self.rate_path, self.stored)  # fmt: skip

    def schedule(self, i: int, k: int) -> np.ndarray:
        """Row ``i``'s shares of its ``k`` nodes so far, (k, n + 1): slot 1's, then one column per step."""
        return self.share_path[i, : int(self.state[i, MST_MOVES_MADE]) + 1, :k].T.copy()


def episode_best_values(rows: NodeRows, ended: np.ndarray, envs: Sequence[Any],
                        num_threads: int | None = None) -> np.ndarray:  # fmt: skip
    """``info["best_schedule_rate"]`` of the rows ``ended`` (their episodes just ended; ``envs[j]``
    the env of row ``ended[j]``): by :meth:`NodeRows.best_values` (compiled, all rows at once, no
    scipy) the static nodes, and the moving nodes of a row whose slots' rates were kept
    (``stored``: every slot stepped by the kernels, whose rate of node k in slot n is r_k(q[n];
    w_k[n]) on the slot's kernel at the true position, the rate ``schedule.node_rates`` takes on
    the paths); a row without kept rates and a row whose certificate failed by
    ``schedule.reported_maxmin_rate`` of the env's flight on its true paths, with the kernels its
    node track holds (:func:`track_kernels`; ``maxmin_rate``: NaN where that falls back to HiGHS
    without scipy, ``schedule.scipy_or_warn``). Both take the same certified column generation:
    the same value to rounding."""
    from ios_uav_env.model.schedule import reported_maxmin_rate

    values = np.full(len(ended), np.nan)
    compiled = rows.stored[ended]
    if not compiled.all():  # (each env asked only where a row's rates were not kept)
        compiled = compiled | np.array([not env.mobile for env in envs], dtype=bool)
    ok = np.zeros(len(ended), dtype=bool)
    if compiled.any():
        values[compiled], ok[compiled] = rows.best_values(ended[compiled], num_threads)
    for j in np.flatnonzero(~ok):
        i, env = ended[j], envs[j]
        path = rows.path[i, : env.config.N]
        values[j] = reported_maxmin_rate(env.config, path, env.truth, track_kernels(env.track))
    return values


def track_kernels(track: NodesTrack | None) -> list[tuple[np.ndarray, np.ndarray]] | None:
    """Each node's rate kernels along its true path as ``track`` holds them (``NodesTrack.held``:
    views of its arrays, each node's own surface width), for ``schedule.node_rates``' ``kernels``;
    None without a track or held kernels (the score then builds them)."""
    if track is None or not track.held:
        return None
    return [(held.nodes, held.params) for held in track.held]
