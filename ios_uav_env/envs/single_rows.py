"""The rows of the v0 view's batched env: B single-node episodes as arrays, one compiled step.

``UAVVectorEnv`` (``ios_uav_env.envs.core.vector``) holds a :class:`SingleNodeRows` when its
template's view is ``"v0"`` (the ids of ``IOSUAVVectorEnv`` and ``RandomIOSUAVVectorEnv``). It
runs the kernels of ``ios_uav_env.envs.single_kernels``, the ones the single-node stepper runs on
a batch of one, on B rows: the same physics, arrival guard and reward. Row i is the single env
reset with seed ``seed + i``: the same scenarios, and with channel "rician" the same fading
draws, so a batch reproduces B single envs exactly (tested). The rows read their template envs
through the single-node row protocol (``row_protocol.SingleNodeRow``); a moving or roughly known
node's observations are made for all rows in compiled calls on their ``track`` arrays
(``knowledge_kernels``). The vector env passes the output arrays of each call (``Outputs``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ios_uav_env.envs.deferral import drawn_rows
from ios_uav_env.envs.knowledge import filter_report
from ios_uav_env.envs.knowledge_kernels import (
    DRAWS,
    MODES,
    EpisodeDraws,
    observe_rows,
    row_list,
)
from ios_uav_env.envs.mobile_draws import DrawnEpisodes, take_slot_normals, takes_drawn_episodes
from ios_uav_env.envs.single_kernels import INFO, STATE, fly_rows, reset_rows, step_rows, step_rows_batched
from ios_uav_env.envs.single_node import INFO_KEYS
from ios_uav_env.envs.slot_weights import SlotWeights
from ios_uav_env.jit import HAVE_NUMBA, run_batched

__all__ = ["Outputs", "SingleNodeRows"]

#: One call's output arrays: observations, rewards, terminated, the info table.
Outputs = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]

#: ``info``'s keys in ``INFO_KEYS`` order, each with its column of the info array
_INFO_COLUMNS = [(key, INFO.index("position_x" if key == "position" else key)) for key in INFO_KEYS]


class SingleNodeRows:
    """B episodes of the v0 view as rows of arrays (module docstring): the rows of ``UAVVectorEnv``
    (``template``: its template env; ``envs``: its row envs; ``num_threads``: the kernel's)."""

    info_keys = INFO_KEYS

    def __init__(self, template: Any, envs: list[Any], num_threads: int | None) -> None:
        b = self.num_envs = len(envs)
        self.envs, self.num_threads = envs, num_threads
        self._flags = template.flags
        self._rician = template.options.channel == "rician"
        self._state = np.zeros((b, len(STATE)))
        self._episode = np.zeros((b, template.episode_row.size))
        self._nodes = np.zeros((b, 3, template.kernel.nodes.shape[1]))
        self._params = np.zeros((b, template.kernel.params.size))
        self._normals = np.zeros((b, 2))
        self.info_width = len(INFO)
        self._path = np.zeros((b, template.max_slots, 2))
        # rows whose scenario is the env's own (not pinned, not drawn): see _load_row
        self._plain = np.zeros(b, dtype=np.bool_)
        self._q0 = np.asarray(template.base_config.q0, dtype=np.float64)
        # a moving or roughly known node: each row's track (its kernels per slot, its truth and
        # records) and what its UAV is told per slot, for all rows in one compiled call
        # (ios_uav_env.envs.knowledge_kernels; the draws from each row's template env)
        self._mobile = template.mobile
        self._drawn: DrawnEpisodes | None = None
        self._drawn_stand: tuple[np.ndarray, np.ndarray] | None = None
        if self._mobile:
            options = template.options
            self._knowledge = MODES[options.knowledge]
            self._draws = DRAWS[options.knowledge]
            self._sigma = float(options.report_sigma)
            self._rate_high = float(template.rate_clip)
            self._scale = float(options.length_scale)
            self._estimate = options.knowledge == "reports" and options.filter_estimate
            self._slot_normals = np.zeros((b, 4))
            self._raw = np.zeros((b, 2))
            self._lo = np.zeros((b, 2))
            self._hi = np.zeros((b, 2))
            self._track_paths = row_list(np.zeros((1, 1, 2)), b)
            self._track_reports = row_list(np.zeros((1, 1, 2)), b)
            self._track_measured = row_list(np.zeros(1), b)
            self._track_nodes = row_list(np.zeros((1, 3, 1)), b)
            self._track_params = row_list(np.zeros((1, template.kernel.params.size)), b)
            # each row's kernels of every slot (envs.slot_weights), where the compiled weights apply;
            # such a row's track entries are these stand-ins of the rows' width (never read)
            width, size = template.kernel.nodes.shape[1], template.kernel.params.size
            self._slot_weights = SlotWeights(b, template.max_slots, width, size)
            self._stand_in = (np.zeros((1, 3, width)), np.zeros((1, size)))
            self._stands_in = np.zeros(b, dtype=np.bool_)  # the row's track entries are the stand-ins
            # each row's draw of the slot's normals: its generator's standard_normal and the row's
            # slice of _slot_normals (set at each episode: a seeded reset makes a new generator);
            # channel "expected": every slot's at the episode's start, in one call per row
            self._draw: list[Any] = [None] * b
            self._draw_out = [self._slot_normals[i, : self._draws] for i in range(b)]
            self._episode_draws = None if self._rician else EpisodeDraws(b, template.max_slots, 4)
            # a randomised moving env's rows draw their episodes together (envs.mobile_draws); the
            # rows whose track lists hold the batch's buffers (set once, then reused)
            self._drawn = DrawnEpisodes(template, b) if takes_drawn_episodes(template) else None
            self._buffered = np.zeros(b, dtype=np.bool_)

    @property
    def state(self) -> np.ndarray:
        """(B, S): each row's kernel state (the UAV's x, y and moves made in columns 0-2)."""
        return self._state

    @property
    def path(self) -> np.ndarray:
        """(B, N_max, 2) m: each row's way-points."""
        return self._path

    def draw(self, rows: np.ndarray, seeds: list[int | None], options: list[Any]) -> np.ndarray:
        """New episodes on ``rows`` (``BatchedEnv._reset_rows``, after ``end``) whose row envs draw
        them from their ranges (a randomised moving env, no options): drawn for all of them at
        once (``mobile_draws.DrawnEpisodes``: the row's generator draws what its env's reset draws,
        the rest is compiled), each row env deferring its episode to it (``defer_episode``). The
        mask of ``rows`` left to reset through their row envs (all, for the other envs)."""
        drawn = self._drawn
        if drawn is None:
            return np.ones(rows.size, dtype=np.bool_)
        rest, mine = drawn_rows(self.envs, rows, seeds, options)
        if not mine.size:
            return rest
        envs, draws, width = self.envs, self._episode_draws, self._draws
        for i in mine.tolist():
            env = envs[i]
            rng = env.np_random
            env.stepper.defer_episode(drawn, i)  # (before the draw rewrites the buffers a read track views)
            n = drawn.draw(i, rng)
            if width:
                draws.draw(i, rng, n, width)
        drawn.make(mine, self._state, self._path, self._episode, self._lo, self._hi)
        slot_weights = self._slot_weights
        drawn.windowed[mine] = False
        while True:  # (a row loaded here may widen the rows' kernels: the others are looked at again)
            width = self._nodes.shape[2]
            geometry = drawn.geometries_of(mine, width)
            unfit = geometry < 0
            for i in mine[
                unfit
            ].tolist():  # (the row reads its track: as load makes it, on the drawn episode)
                self._load_drawn(i, envs[i])
            mine, geometry = mine[~unfit], geometry[~unfit]
            if self._nodes.shape[2] == width:
                break
        if mine.size:
            drawn.start(mine, geometry, self._nodes, self._params, self._episode)
            slot_weights.slots[mine] = 0  # (the drawn rows' own windows hold their weights)
        stand_in, paths, reports, measured = self._stand_in, drawn.paths, drawn.reports, drawn.measured
        for i in mine.tolist():
            if not self._buffered[i]:
                self._track_paths[i], self._track_reports[i] = paths[i], reports[i]
                self._track_measured[i] = measured[i]
                self._buffered[i] = True
            if not self._stands_in[i]:
                self._track_nodes[i], self._track_params[i] = stand_in
                self._stands_in[i] = True
        self._plain[rows[~rest]] = False
        return rest

    def _load_drawn(self, i: int, env: Any) -> None:
        """Row ``i`` from its row env's (deferred) drawn episode, as :meth:`load` after its draws."""
        row = env.stepper
        k = self._fit(i, row)
        self._set_track(i, row, k)
        self._episode[i] = row.episode_row
        self._state[i, 0:2] = self._path[i, 0] = row.config.q0

    def _fit(self, i: int, row: Any) -> int:
        """Row ``i``'s scenario kernel (of ``row``) in the row, growing the node arrays if needed;
        its width."""
        nodes = row.kernel.nodes
        k = nodes.shape[1]
        if k > self._nodes.shape[2]:
            grown = np.zeros((self.num_envs, 3, k))
            grown[:, 1, :] = 1.0
            grown[:, :, : self._nodes.shape[2]] = self._nodes
            self._nodes = grown
            if self._mobile:  # the buffered rows' kernels are now padded: they read their tracks
                self._read_tracks()
        self._nodes[i, :, :k] = nodes
        self._nodes[i, :, k:] = ((0.0,), (1.0,), (0.0,))  # padded nodes: zero weight
        self._params[i] = row.kernel.params
        return k

    def _set_track(self, i: int, row: Any, k: int) -> None:
        """Row ``i``'s track (of ``row``, drawn) in the track lists, its kernels and report clip."""
        track = row.track
        self._track_paths[i], self._track_reports[i] = track.paths, track.reports
        self._track_measured[i] = track.measured
        self._buffered[i] = False
        self._load_kernels(i, row, k)
        self._lo[i], self._hi[i] = track.lo, track.hi

    def load(self, i: int, env: Any) -> None:
        """Copy the current scenario of ``env`` into row ``i`` (growing the node arrays if needed).
        The row protocol's names are read on the env's stepper (``UAVEnv.stepper``, whose calls the
        env forwards), once per row reset."""
        row = env.stepper
        k = self._fit(i, row)
        # a mobile row: its node path (drawn as the single env's reset does), slot 1's kernel and, with
        # the energy objective, the episode's lambda_ref in the row's episode_row (copied below)
        if self._mobile:
            row.start_track(row.config)
            self._set_track(i, row, k)
            self._draw[i] = env.np_random.standard_normal
            if self._episode_draws is not None and self._draws:
                self._episode_draws.draw(i, env.np_random, row.config.N, self._draws)
        self._episode[i] = row.episode_row
        self._state[i, 0:2] = self._path[i, 0] = row.config.q0
        # the env's own scenario object (a fixed id's): a plain reset keeps it. A pinned
        # scenario, or a random env's draw (always a new object), is another object. A mobile
        # row draws a new path at every episode: never plain.
        self._plain[i] = row.config is row.base_config and not self._mobile
        if self._rician:
            self._normals[i] = env.np_random.standard_normal(2)

    def _load_kernels(self, i: int, row: Any, k: int) -> None:
        """Row ``i``'s kernels of every slot of the episode just drawn (its track's path, ``k``
        surface nodes), its slot-1 kernel in the row: from :class:`SlotWeights` where they apply
        (the surface fills the rows' kernel width), else its track's."""
        buffered = k == self._nodes.shape[2] == self._slot_weights.weights.shape[
            2
        ] and self._slot_weights.load(i, row.config, row.track.paths, row.kernel.params)
        if buffered:  # (the node coordinates, the geometry's, are in the row: the scenario's kernel)
            self._slot_weights.first(i, self._nodes, self._params)
            if not self._stands_in[i]:
                self._track_nodes[i], self._track_params[i] = self._stand_in
                self._stands_in[i] = True
            return
        track = row.track
        self._nodes[i, :, :k], self._params[i] = track.nodes[0], track.params[0]
        self._track_nodes[i], self._track_params[i] = track.nodes, track.params
        self._stands_in[i] = False

    def _read_tracks(self) -> None:
        """Every buffered row reads its track's kernels from now on (the rows' kernels grew wider)."""
        windowed = np.zeros(self.num_envs, dtype=np.bool_) if self._drawn is None else self._drawn.windowed
        for i in np.flatnonzero((self._slot_weights.slots > 0) | windowed).tolist():
            track = self.envs[i].stepper.track
            self._track_nodes[i], self._track_params[i] = track.nodes, track.params
            self._slot_weights.slots[i], self._stands_in[i], windowed[i] = 0, False, False

    def start(self, rows: np.ndarray, obs: np.ndarray, info: np.ndarray) -> None:
        """Start the episodes of ``rows`` (loaded): their first observations and ``info`` rows."""
        reset_rows(rows, self._state, self._episode, self._nodes, self._params, self._normals, self._flags,
                   obs, info)  # fmt: skip
        if self._mobile:
            self._observe_rows(rows, obs)

    def _observe_rows(self, rows: np.ndarray, obs: np.ndarray) -> None:
        """What each row's UAV is told of its node in its current slot, as the single env's
        ``observe_slot`` (``knowledge.observe_slot``), bit for bit: per row, the slot's normals
        (from the episode's draw, ``knowledge_kernels.EpisodeDraws``; channel "rician": one draw
        of its generator per slot), then one compiled call for all ``rows``
        (``knowledge_kernels.observe_rows``); the Kalman filter (``filter_estimate``) per row."""
        rows = np.asarray(rows, dtype=np.int64)
        normals, envs, draw, out = self._slot_normals, self.envs, self._draw, self._draw_out
        if self._draws and self._episode_draws is not None:
            draws = self._episode_draws
            if HAVE_NUMBA:  # (EpisodeDraws.take, compiled)
                take_slot_normals(rows, self._state, draws.normals, draws.taken, normals)
            else:
                draws.take(rows, self._state[rows, 2].astype(np.int64), normals)
        elif self._draws:
            for i in rows.tolist():
                draw[i](out=out[i])
        tracks = (self._track_paths, self._track_reports, self._track_measured, self._track_nodes,
                  self._track_params)  # fmt: skip
        if self._drawn is not None and self._buffered[rows].all() and self._stands_in[rows].all():
            tracks = self._drawn_tracks()  # (the same arrays as one (B, ...) array each: no list to read)
        observe_rows(rows, self._state, *tracks, self._lo, self._hi, self._nodes, self._params, normals,
                     self._knowledge, self._sigma, self._rate_high, self._scale, not self._estimate, obs,
                     self._raw)  # fmt: skip
        if self._estimate:
            for i in rows.tolist():
                told = filter_report(envs[i].stepper.track, self._raw[i : i + 1].copy(), self._sigma)
                obs[i, 4:6] = (told[0] - self._state[i, 0:2]) / self._scale

    def _drawn_tracks(self) -> tuple[np.ndarray, ...]:
        """The drawn rows' tracks as ``observe_rows`` takes them (each row's entry of a list of arrays,
        or of one array): the batch's paths, reports and measured rates (``DrawnEpisodes``), and
        stand-in kernels of the rows' width (the rows' own kernels are read: ``measure_rates``)."""
        drawn = self._drawn
        assert drawn is not None
        width, size = self._nodes.shape[2], self._params.shape[1]
        if self._drawn_stand is None or self._drawn_stand[0].shape[3] != width:
            self._drawn_stand = (np.zeros((self.num_envs, 1, 3, width)), np.zeros((self.num_envs, 1, size)))
        return (drawn.paths, drawn.reports, drawn.measured, *self._drawn_stand)

    def end(self, rows: np.ndarray, seeds: Any) -> None:
        """Before ``rows`` begin new episodes with ``seeds`` (``BatchedEnv._end_rows``): a moving
        row's generator as its slots left it (``EpisodeDraws.rewind``)."""
        if self._mobile and self._episode_draws is not None:
            self._episode_draws.rewind(rows, seeds)

    def restart(self, rows: np.ndarray, obs: np.ndarray, info: np.ndarray) -> np.ndarray:
        """New episodes on ``rows`` without a seed or options (autoreset, ``restart``): a row that
        keeps its scenario (the fixed ids' own) only goes back to q0, without the Python reset of
        its template env (the same episode, at no per-row Python cost). The rows left to reset
        through their template envs (the others)."""
        plain = self._plain[rows]
        quick, rest = rows[plain], rows[~plain]
        if quick.size:
            self._state[quick, 0:2] = self._path[quick, 0] = self._q0
            if self._rician:
                for i in quick:
                    self._normals[i] = self.envs[i].np_random.standard_normal(2)
            self.start(quick, obs, info)
        return rest

    def info_arrays(self, table: np.ndarray) -> dict[str, Any]:
        """``info`` as column views of the info array (``INFO_KEYS``)."""
        columns = table.T
        out: dict[str, Any] = {}
        for key, column in _INFO_COLUMNS:
            out[key] = table[:, 2:4] if key == "position" else columns[column]
        out["slot"] = out["slot"].astype(np.int64)
        out["feasible"] = out["feasible"] != 0.0
        return out

    def fly(
        self, rows: np.ndarray, targets: np.ndarray, moves: np.ndarray, obs: np.ndarray, info: np.ndarray
    ) -> bool:
        """``BatchedEnv.fly`` in one call of ``single_kernels.fly_rows`` (not for mobile or
        rician rows: each slot's track or fading draw steps slot by slot)."""
        if self._mobile or self._rician:
            return False
        actions = np.zeros((self.num_envs, 2))
        bad = fly_rows(rows, targets, moves, actions, self._state, self._episode, self._nodes, self._params,
                       self._normals, self._flags, obs, np.zeros(self.num_envs),
                       np.zeros(self.num_envs, dtype=np.bool_), info, self._path)  # fmt: skip
        if bad >= 0:  # (the arguments were checked by fly: a kernel refusal is a bug)
            raise RuntimeError(f"fly_rows refused entry {bad} of checked arguments")
        return True

    def check_actions(self, actions: Any) -> np.ndarray:
        # one array type for the compiled kernel (C order, writeable float64): a view, a float32 or
        # a read-only batch would each compile another version of it
        actions = np.require(actions, dtype=np.float64, requirements=["C", "W"])
        if actions.shape != (self.num_envs, 2):
            raise ValueError(f"actions must have shape ({self.num_envs}, 2), got {actions.shape}")
        return actions

    def step(self, actions: np.ndarray, active: np.ndarray, outputs: Outputs) -> None:
        """One slot of the ``active`` rows into ``outputs`` (the kernel checks that their actions
        are finite)."""
        obs, reward, terminated, info = outputs
        stepping = np.flatnonzero(active)
        if self._mobile:  # each row's kernel of the slot it flies to (a row at its end is refused below)
            tracks, drawn = (self._track_nodes, self._track_params), self._drawn
            if drawn is None or not drawn.windowed[stepping].all():  # (the rows not drawn together)
                self._slot_weights.put(stepping, self._state, 1, *tracks, self._nodes, self._params)
            if drawn is not None:  # (the drawn rows: from their windows)
                drawn.put(stepping, self._state, self._nodes, self._params)
        if self._rician:
            for i in stepping:
                self._normals[i] = self.envs[i].np_random.standard_normal(2)
        bad = run_batched(step_rows_batched, step_rows, self.num_threads, actions, self._state, self._episode,
                          self._nodes, self._params, self._normals, self._flags, obs, reward,
                          terminated, info, self._path, active)  # fmt: skip
        if bad >= self.num_envs:  # nothing stepped (the autoreset restarts ended rows first)
            raise RuntimeError(f"row {bad - self.num_envs}'s episode is over: it cannot step")
        if bad >= 0:  # nothing stepped
            rows = np.flatnonzero(~np.isfinite(actions).all(axis=1))
            raise ValueError(f"actions must be finite (no NaN or inf); rows {rows.tolist()[:10]} are not")
        if self._mobile:
            self._observe_rows(stepping, obs)
