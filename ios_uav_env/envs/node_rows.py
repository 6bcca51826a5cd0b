"""The rows of the node-block view's batched env: B multi-node episodes as arrays, one compiled step.

``UAVVectorEnv`` (``ios_uav_env.envs.core.vector``) holds a :class:`NodeBlockRows` when its
template's view is ``"node_blocks"`` (the ids of ``MultiNodeVectorEnv``). Each step runs the
kernel of ``ios_uav_env.envs.multi_kernels`` that the multi-node stepper runs on a batch of one,
on B rows (compiled with numba when installed), so row i reproduces the single env reset with
seed ``seed + i`` (tested). The last step of an episode also reports ``best_schedule_rate``:
``maxmin_rate`` of the row's trajectory, the certified best schedule
(``ios_uav_env.model.schedule``; the ended static rows in one compiled call);
``best_schedule=False`` skips it (NaN at episode ends). The rows read their template envs through
the multi-node row protocol (``row_protocol.MultiNodeRow``: ``load_row``; moving nodes: each
slot's kernels and what the rows observe in compiled calls over the rows,
``ios_uav_env.envs.nodes_kernels``; with channel "expected" each slot's node kernels are computed
in the rows before the step, ``ios_uav_env.envs.node_weights``, the tracks building theirs only
when read; a randomised moving env's rows draw their episodes together in compiled calls,
``ios_uav_env.envs.node_draws``, their row envs building their scenarios only when read). With
the energy objective each row's lambda_ref is its
template env's; with channel "rician" each row draws its slots' fading from its template env's
``np_random`` (so row i is the single env of seed ``seed + i``, draw for draw).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ios_uav_env.envs.deferral import drawn_rows
from ios_uav_env.envs.knowledge import filter_report
from ios_uav_env.envs.knowledge_kernels import EpisodeDraws, row_list
from ios_uav_env.envs.mobile_draw_kernels import take_slot_normals
from ios_uav_env.envs.multi_kernels import NodeRows, episode_best_values, move_norms
from ios_uav_env.envs.multi_table import BEST, info_arrays, info_columns
from ios_uav_env.envs.node_draws import DrawnNodeEpisodes, takes_drawn_nodes
from ios_uav_env.envs.node_measure import measure_node_rates
from ios_uav_env.envs.node_weights import NodeWeights
from ios_uav_env.envs.nodes_kernels import (
    MODES,
    N_BASE,
    draws,
    gather_node_kernels,
    tell_nodes,
    tell_nodes_batched,
)
from ios_uav_env.envs.single_rows import Outputs
from ios_uav_env.jit import run_batched, threads_for

__all__ = ["NodeBlockRows"]


class NodeBlockRows:
    """B episodes of the node-block view as rows of arrays (module docstring): the rows of
    ``UAVVectorEnv`` (``template``: its template env; ``envs``: its row envs; ``num_threads``: the
    kernel's; ``best_schedule``: whether an episode's end computes the best schedule)."""

    def __init__(self, template: Any, envs: list[Any], num_threads: int | None, best_schedule: bool) -> None:
        self.num_envs, self.envs, self.num_threads = len(envs), envs, num_threads
        #: Whether an episode's end computes ``best_schedule_rate`` (else NaN there).
        self.best_schedule = best_schedule
        self.max_nodes = template.max_nodes
        self.action_width = 2 + self.max_nodes
        self._rows = NodeRows(
            self.num_envs, self.max_nodes, template.options, template.share_sharpness, template.softmin_beta,
            template.energy_objective, template.served_clip,
        )  # fmt: skip
        self.info_keys = template.info_keys  # (more with the energy objective, channel "rician")
        # Rician rows draw each slot's fading from their template env's np_random (Python per row)
        self._rician = template.options.channel == "rician"
        self._state = self._rows.state
        self.info_width = info_columns(self.max_nodes, template.energy_objective or self._rician)
        # moving or roughly known nodes: each row's tracks (its nodes' kernels per slot, the truth
        # and the records), drawn by its template env at reset, and what its UAV is told per slot,
        # for all rows in one compiled call (ios_uav_env.envs.nodes_kernels)
        self._mobile = template.mobile
        self._drawn: DrawnNodeEpisodes | None = None  # (a randomised moving env's: _init_tracks)
        if self._mobile:
            self._init_tracks(template)

    def _init_tracks(self, template: Any) -> None:
        """The arrays and the row lists of the rows' node tracks (moving or roughly known nodes)."""
        b, k, o = self.num_envs, self.max_nodes, template.options
        self._knowledge, self._kind = MODES[o.knowledge], o.knowledge  # (exact: nothing drawn)
        self._sigma, self._scale = float(o.report_sigma), float(o.length_scale)
        self._rate_high = float(template.rate_clip)
        self._estimate = o.knowledge == "reports" and o.filter_estimate
        self._width = len(template.node_features)
        self._k = np.zeros(b, dtype=np.int64)
        self._slot_normals, self._told = np.zeros((b, 4 * k)), np.zeros((b, k))
        self._raw, self._lo, self._hi = np.zeros((b, k, 2)), np.zeros((b, k, 2)), np.zeros((b, k, 2))
        self._track_paths = row_list(np.zeros((1, 1, 2)), b)
        self._track_reports = row_list(np.zeros((1, 1, 2)), b)
        self._track_measured = row_list(np.zeros((1, 1)), b)
        self._track_tally = row_list(np.zeros(1), b)
        self._track_nodes = row_list(np.zeros((1, 1, 3, 1)), b)
        self._track_params = row_list(np.zeros((1, 1, self._rows.params.shape[2])), b)
        # each row's draw of the slot's normals: its generator's standard_normal and the row's slice
        # of _slot_normals (set at each episode: a seeded reset makes a new generator, K changes)
        self._draw: list[Any] = [None] * b
        self._draw_out: list[Any] = [None] * b
        # channel "expected": every slot's normals at the episode's start, in one call per row
        # (drawn rows: as long as the longest episode at once, not grown row after row at a first reset)
        slots = template.stepper.ranges.slot_range[1] if takes_drawn_nodes(template) else 1
        self._episode_draws = None if self._rician else EpisodeDraws(b, slots, 4 * k)
        # channel "expected": each row's node kernels of the slot it flies to computed in the row
        # before the step (node_weights; a row the compiled weights do not take: its track's, gathered)
        self._weights = None if self._rician else NodeWeights(b, k, self._rows.params.shape[2])
        # rows whose envs draw from the ranges: drawn together in compiled calls (envs.node_draws);
        # the rows whose tracks are the batch's buffers (their measured list entries set once, then
        # reused; their paths, reports and tally entries only when the lists are read: _records)
        self._drawn = (
            DrawnNodeEpisodes(template, b, self._rows, self._weights) if takes_drawn_nodes(template) else None
        )
        self._buffered = np.zeros(b, dtype=np.bool_)
        self._listed = np.zeros(b, dtype=np.bool_)  # (a buffered row's paths, reports, tally entries set)

    @property
    def kernel_rows(self) -> NodeRows:
        """The kernels' row arrays and calls (``multi_kernels.NodeRows``)."""
        return self._rows

    @property
    def state(self) -> np.ndarray:
        """(B, S): each row's kernel state (the UAV's x, y and moves made in columns 0-2)."""
        return self._rows.state

    @property
    def path(self) -> np.ndarray:
        """(B, N_max, 2) m: each row's way-points (grows with the longest episode loaded)."""
        return self._rows.path

    def load(self, i: int, env: Any) -> None:
        """Put the episode just begun by row ``i``'s env (``begin_episode``) in row ``i`` (the row
        protocol's names read on the env's stepper, ``UAVEnv.stepper``, whose calls the env forwards)."""
        row = env.stepper
        # the scenario, node paths, lambda_ref, the first slot's fading: as the single env's reset
        weights = self._weights if self._mobile else None
        if weights is not None and hasattr(row, "load_row_bare"):  # (each slot's kernels computed)
            row.load_row_bare(self._rows, i, weights)
        else:
            if weights is not None:
                weights.slots[i] = 0
            row.load_row(self._rows, i)
        track = row.track if self._mobile else None
        if track is not None:
            k = self._k[i] = row.config.K
            self._buffered[i] = self._listed[i] = False
            self._track_paths[i], self._track_reports[i] = track.paths, track.reports
            self._track_measured[i], self._track_tally[i] = track.measured, track.tally
            if weights is None or weights.slots[i] == 0:  # (the track's kernels: built)
                self._track_nodes[i], self._track_params[i] = track.nodes, track.params
            self._lo[i, :k], self._hi[i, :k] = track.lo, track.hi
            self._draw[i] = env.np_random.standard_normal
            self._draw_out[i] = self._slot_normals[i, : draws(self._kind, k)]
            if self._episode_draws is not None and self._knowledge != 0:
                self._episode_draws.draw(i, env.np_random, row.config.N, draws(self._kind, k))

    def draw(self, rows: np.ndarray, seeds: list[int | None], options: list[Any]) -> np.ndarray:
        """New episodes on ``rows`` (``BatchedEnv._reset_rows``, after ``end``) whose row envs draw
        them from their ranges (no options): drawn for all of them at once
        (``node_draws.DrawnNodeEpisodes``: the row's generator draws what its env's reset draws, the
        rest is compiled), each row env deferring its episode to it (``defer_episode``). The mask of
        ``rows`` left to reset through their row envs (all, for the other envs)."""
        drawn = self._drawn
        if drawn is None:
            return np.ones(rows.size, dtype=np.bool_)
        rest, mine = drawn_rows(self.envs, rows, seeds, options)
        if not mine.size:
            return rest
        envs, draws_, kind = self.envs, self._episode_draws, self._kind
        observed = self._knowledge != 0 and draws_ is not None
        for i in mine.tolist():
            env = envs[i]
            rng = env.np_random
            env.stepper.defer_episode(drawn, i)  # (before the draw rewrites the buffers a read track views)
            n, k = drawn.draw(i, rng)
            if observed:
                draws_.draw(i, rng, n, draws(kind, k))
        unfit = drawn.make(mine, self._lo, self._hi)
        self._k[mine] = drawn.counts[mine]
        for i in unfit.tolist():  # (a surface the compiled weights do not take: the track's kernels)
            row = envs[i].stepper
            self._rows.load(i, row.config, kernels=False)
            row.put_first_kernels(self._rows, i)
            self._track_nodes[i], self._track_params[i] = row.track.nodes, row.track.params
        measured = drawn.measured
        for i in np.flatnonzero(~self._buffered[mine]).tolist():
            self._track_measured[int(mine[i])] = measured[mine[i]]
        self._buffered[mine] = True
        return rest

    def start(self, rows: np.ndarray, obs: np.ndarray, info: np.ndarray) -> None:
        """Start the episodes of ``rows`` (loaded): their first observations and ``info`` rows."""
        if self._mobile and self._weights is not None:  # the first slot's node kernels
            rows = np.asarray(rows, dtype=np.int64)
            kernels = self._rows.nodes, self._rows.params
            self._weights.put(rows, self._rows.state, -1, *kernels, self.num_threads)
        self._rows.start(rows, obs, info)
        if self._mobile:
            self._observe_rows(rows, obs)

    def end(self, rows: np.ndarray, seeds: Any) -> None:
        """Before ``rows`` begin new episodes with ``seeds`` (``BatchedEnv._end_rows``): a moving
        row's generator as its slots left it (``EpisodeDraws.rewind``)."""
        if self._mobile and self._episode_draws is not None:
            self._episode_draws.rewind(rows, seeds)

    def restart(self, rows: np.ndarray, obs: np.ndarray, info: np.ndarray) -> np.ndarray:
        """The rows of an autoreset or ``restart`` left to reset through their template envs: all."""
        return rows

    def _records(self, rows: np.ndarray) -> tuple[Any, Any, Any]:
        """The tracks' paths, reports and tally of ``rows`` as ``tell_nodes`` indexes them by row:
        the batch's drawn buffers themselves where every one of ``rows`` holds them (a row's entry
        of a list is its buffers' row: the same arrays, read without the typed lists' per-row
        cost), else the lists. (The measured rates stay the tracks' lists, which
        ``node_measure.measure_node_rates`` writes for rows of both kinds.)"""
        drawn = self._drawn
        if drawn is not None:
            buffered = self._buffered[rows]
            if buffered.all():
                return drawn.paths, drawn.reports, drawn.tally
            for i in rows[buffered & ~self._listed[rows]].tolist():  # (their entries, now read)
                self._track_paths[i], self._track_reports[i] = drawn.paths[i], drawn.reports[i]
                self._track_tally[i] = drawn.tally[i]
                self._listed[i] = True
        return self._track_paths, self._track_reports, self._track_tally

    def _observe_rows(self, rows: np.ndarray, obs: np.ndarray) -> None:
        """What each row's UAV is told of its nodes in its current slot, as the single env's
        ``observe_slot`` (``knowledge.observe_nodes``; bit for bit but the measured rates, equal
        to the rounding of the step's rates, ``node_measure``): per row, the slot's normals
        (from the episode's draw, ``knowledge_kernels.EpisodeDraws``; channel "rician": one draw of
        its generator per slot), then compiled calls for all ``rows``
        (``node_measure.measure_node_rates`` and ``tell_nodes``); the Kalman filter (``filter_estimate``)
        per row."""
        rows = np.asarray(rows, dtype=np.int64)
        normals, envs, counts, draw, out = self._slot_normals, self.envs, self._k, self._draw, self._draw_out
        state, shares = self._rows.state, self._rows.shares
        if self._knowledge != 0 and self._episode_draws is not None:
            draws_ = self._episode_draws  # (EpisodeDraws.take's gather, compiled)
            take_slot_normals(rows, state, draws_.normals, draws_.taken, normals)
        elif self._knowledge != 0:
            for i in rows.tolist():
                draw[i](out=out[i])
        if self._knowledge != 0:
            measure_node_rates(rows, state, shares, counts, self._track_measured, self._rows.rates,
                               self._rows.params, normals, self._knowledge == 1, self._rate_high,
                               self._told)  # fmt: skip
        args = (rows, state, shares, *self._records(rows), self._lo, self._hi, normals, self._knowledge,
                self._sigma, self._scale, not self._estimate, self._width, self._told, obs, self._raw,
                self._rows.sizes)  # fmt: skip
        if threads_for(self.num_threads, rows.size) == 1:  # (IEEE either way: one thread, the plain loop)
            tell_nodes(*args)
        else:
            run_batched(tell_nodes_batched, tell_nodes, self.num_threads, *args)
        if self._estimate:
            for i in rows.tolist():
                k = int(counts[i])
                told = filter_report(envs[i].stepper.track, self._raw[i, :k].copy(), self._sigma)
                for node in range(k):
                    at = N_BASE + self._width * node
                    obs[i, at + 1 : at + 3] = (told[node] - state[i, 0:2]) / self._scale

    def info_arrays(self, table: np.ndarray) -> dict[str, Any]:
        return info_arrays(table, self.max_nodes, self.info_keys)

    def check_actions(self, actions: Any) -> np.ndarray:
        """``actions`` as the kernel's array type, checked (shape, finite; ``ValueError`` naming them)."""
        a = np.require(actions, dtype=np.float64, requirements=["C", "W"])  # one kernel signature
        shape = (self.num_envs, self.action_width)
        if a.shape != shape:
            raise ValueError(
                f"actions must have shape {shape} (the move, then {self.max_nodes} node scores), "
                f"got {a.shape}"
            )
        finite = np.isfinite(a)
        if not finite.all():
            rows = np.flatnonzero(~finite.all(axis=1))
            names = ["move_x", "move_y", *(f"score_{k}" for k in range(self.max_nodes))]
            bad = [names[c] for c in np.flatnonzero(~finite.all(axis=0))]
            raise ValueError(
                f"actions must be finite (no NaN or inf); rows {rows.tolist()[:10]} are not (fields {bad})"
            )
        return a

    def step(self, actions: np.ndarray, active: np.ndarray, outputs: Outputs) -> None:
        """One slot of the ``active`` rows into ``outputs``, then the best schedule of each flight
        that ended."""
        obs, _, terminated, info = outputs
        stepping = np.flatnonzero(active)
        if self._rician:  # each row's node kernels and fading of the slot it flies to (its draws)
            for i in stepping:
                self.envs[i].stepper.prepare_slot(self._rows, i)
        elif self._mobile:  # each row's node kernels of the slot it flies to, in one call
            rows, weights = self._rows, self._weights
            assert weights is not None
            weights.put(
                stepping, rows.state, 1, rows.nodes, rows.params, self.num_threads
            )  # (computed in the row)
            kept = stepping[weights.slots[stepping] == 0]  # (the others: their tracks')
            if kept.size:
                gather_node_kernels(kept, rows.state, self._track_nodes, self._track_params, rows.nodes,
                                    rows.params)  # fmt: skip
        self._rows.step(actions, active, outputs, move_norms(actions), self.num_threads)
        if self._mobile:
            self._observe_rows(stepping, obs)
        ended = np.flatnonzero(terminated)
        if ended.size:
            info[ended, BEST] = (
                episode_best_values(self._rows, ended, [self.envs[i] for i in ended], self.num_threads)
                if self.best_schedule
                else np.nan
            )

    def fly(
        self, rows: np.ndarray, targets: np.ndarray, moves: np.ndarray, obs: np.ndarray, info: np.ndarray
    ) -> bool:
        """``BatchedEnv.fly`` in one compiled call, with equal shares (not for mobile or Rician
        rows: the compiled flight keeps each row's kernels and draws no fading, so they step slot
        by slot)."""
        if self._mobile or self._rician:
            return False
        self._rows.fly(rows, targets, moves, obs, info)
        return True

    @property
    def schedules(self) -> list[np.ndarray]:
        """Each row's shares so far, (K, n + 1) arrays (the single env's ``shares``)."""
        return [self._rows.schedule(i, env.config.K) for i, env in enumerate(self.envs)]
