"""The multi-node env batched: B episodes of ``MultiNodeEnv`` stepped as one array computation.

``gym.make_vec("ios_uav_env/IOSUAV-MultiNode-v0", num_envs=B,
vectorization_mode="vector_entry_point")`` (and the ``-Random-v0`` id) returns a
:class:`MultiNodeVectorEnv`. Each step runs the kernel of ``ios_uav_env.envs.multi_kernels``
that the single env runs on a batch of one, on B rows (compiled with numba when installed),
so row i reproduces the single env reset with seed ``seed + i`` (tested). The last step of
an episode also reports ``best_schedule_rate``: ``maxmin_rate`` of the row's trajectory, the
certified best schedule (``ios_uav_env.model.schedule``; the ended static rows in one compiled
call); ``best_schedule=False`` skips it (the key then holds NaN at episode ends).

The batch-level conventions are ``ios_uav_env.envs.batched.BatchedEnv``'s: scenario choice at
reset in one template ``MultiNodeEnv`` per row (``load_row`` of
``ios_uav_env.envs.row_protocol.MultiNodeRow``; moving nodes: each slot's kernels and what the
rows observe in compiled calls over the rows, ``ios_uav_env.envs.nodes_kernels``), autoreset
``NEXT_STEP`` by default or ``autoreset_mode="same_step"`` with ``final_obs`` / ``final_info``,
``reset(seed=s)`` seeding row i with ``s + i``, ``options={"config": cfg}`` / ``{"configs":
[...]}`` pinning the rows' scenarios. ``info`` is a dict of arrays (the single env's
``info_keys``: ``MULTI_INFO_KEYS``, and the energy objective's and the Rician channel's keys;
``position`` (B, 2), ``shares``, ``node_rates`` and ``expected_node_rates`` (B, K_max)) with
Gymnasium's ``_key`` masks. With the energy objective each row's lambda_ref is its template
env's; with channel "rician" each row draws its slots' fading from its template env's
``np_random`` (so row i is the single env of seed ``seed + i``, draw for draw).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ios_uav_env.envs.batched import BatchedEnv
from ios_uav_env.envs.knowledge import filter_report
from ios_uav_env.envs.knowledge_kernels import EpisodeDraws, row_list
from ios_uav_env.envs.multi import MultiNodeEnv
from ios_uav_env.envs.multi_kernels import NodeRows, episode_best_values, move_norms
from ios_uav_env.envs.multi_table import BEST, MULTI_INFO_KEYS, info_arrays, info_columns
from ios_uav_env.envs.nodes_kernels import (
    MODES,
    N_BASE,
    draws,
    gather_node_kernels,
    measure_nodes,
    tell_nodes,
)


class MultiNodeVectorEnv(BatchedEnv):
    """``num_envs`` episodes of :class:`~ios_uav_env.envs.multi.MultiNodeEnv` in one array
    computation.

    Arguments: the single env's (``config``, ``max_nodes``, ``share_sharpness``,
    ``random_nodes``, ``ranges``, ``EnvOptions`` and ``ScenarioConfig`` keywords) plus
    ``num_envs``, ``autoreset_mode``, ``num_threads`` and ``best_schedule`` (True:
    ``maxmin_rate`` at each episode end, as the single env; False: NaN there, no LP).
    Observations (B, 12 + 6 K_max) float32 (``observation_names``: a row's, the single env's),
    actions (B, 2 + K_max), rewards (B,) float64. No rendering.
    """

    env_class = MultiNodeEnv
    info_keys = MULTI_INFO_KEYS

    def __init__(self, num_envs: int = 1, config: Any = None, *, best_schedule: bool = True, **kwargs: Any):
        self.best_schedule = bool(best_schedule)
        super().__init__(num_envs, config, **kwargs)

    def _init_rows(self, template: MultiNodeEnv) -> None:
        self.max_nodes = template.max_nodes
        self._rows = NodeRows(
            self.num_envs, self.max_nodes, template.options, template.share_sharpness, template.softmin_beta,
            template.energy_objective, template.served_clip,
        )  # fmt: skip
        self.info_keys = template.info_keys  # (more with the energy objective, channel "rician")
        # Rician rows draw each slot's fading from their template env's np_random (Python per row)
        self._rician = template.options.channel == "rician"
        self._state = self._rows.state
        self._info_width = info_columns(self.max_nodes, template.energy_objective or self._rician)
        # moving or roughly known nodes: each row's tracks (its nodes' kernels per slot, the truth
        # and the records), drawn by its template env at reset, and what its UAV is told per slot,
        # for all rows in one compiled call (ios_uav_env.envs.nodes_kernels)
        self._mobile = template.mobile
        if self._mobile:
            self._init_tracks(template)

    def _init_tracks(self, template: MultiNodeEnv) -> None:
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
        self._episode_draws = None if self._rician else EpisodeDraws(b, 1, 4 * k)

    @property
    def _path(self) -> np.ndarray:
        return self._rows.path  # (grows with the longest episode loaded)

    # --- rows -----------------------------------------------------------------------
    def _load_row(self, i: int, env: MultiNodeEnv) -> None:
        # the scenario, node paths, lambda_ref, the first slot's fading: as the single env's reset
        env.load_row(self._rows, i)
        track = env.track if self._mobile else None
        if track is not None:
            k = self._k[i] = env.config.K
            self._track_paths[i], self._track_reports[i] = track.paths, track.reports
            self._track_measured[i], self._track_tally[i] = track.measured, track.tally
            self._track_nodes[i], self._track_params[i] = track.nodes, track.params
            self._lo[i, :k], self._hi[i, :k] = track.lo, track.hi
            self._draw[i] = env.np_random.standard_normal
            self._draw_out[i] = self._slot_normals[i, : draws(self._kind, k)]
            if self._episode_draws is not None and self._knowledge != 0:
                self._episode_draws.draw(i, env.np_random, env.config.N, draws(self._kind, k))

    def _end_rows(self, rows: np.ndarray, seeds: Any) -> None:
        if self._mobile and self._episode_draws is not None:  # (a row's generator as its slots left it)
            self._episode_draws.rewind(rows, seeds)

    def _start_rows(self, rows: np.ndarray) -> None:
        self._rows.start(rows, self._obs, self._info)
        if self._mobile:
            self._observe_rows(rows)

    def _observe_rows(self, rows: np.ndarray) -> None:
        """What each row's UAV is told of its nodes in its current slot, as the single env's
        ``observe_slot`` (``knowledge.observe_nodes``), bit for bit: per row, the slot's normals
        (from the episode's draw, ``knowledge_kernels.EpisodeDraws``; channel "rician": one draw of
        its generator per slot), then compiled calls for all ``rows``
        (``nodes_kernels.measure_nodes`` and ``tell_nodes``); the Kalman filter (``filter_estimate``)
        per row."""
        rows = np.asarray(rows, dtype=np.int64)
        normals, envs, counts, draw, out = self._slot_normals, self.envs, self._k, self._draw, self._draw_out
        state, shares = self._rows.state, self._rows.shares
        if self._knowledge != 0 and self._episode_draws is not None:
            self._episode_draws.take(rows, state[rows, 2].astype(np.int64), normals)
        elif self._knowledge != 0:
            for i in rows.tolist():
                draw[i](out=out[i])
        if self._knowledge != 0:
            measure_nodes(rows, state, shares, self._track_measured, self._track_nodes, self._track_params,
                          normals, self._knowledge == 1, self._rate_high, self._told)  # fmt: skip
        tell_nodes(rows, state, shares, self._track_paths, self._track_reports, self._track_tally, self._lo,
                   self._hi, normals, self._knowledge, self._sigma, self._scale, not self._estimate,
                   self._width, self._told, self._obs, self._raw)  # fmt: skip
        if self._estimate:
            for i in rows.tolist():
                k = int(counts[i])
                told = filter_report(envs[i].track, self._raw[i, :k].copy(), self._sigma)
                for node in range(k):
                    at = N_BASE + self._width * node
                    self._obs[i, at + 1 : at + 3] = (told[node] - state[i, 0:2]) / self._scale

    def _info_arrays(self, table: np.ndarray) -> dict[str, Any]:
        return info_arrays(table, self.max_nodes, self.info_keys)

    # --- the step -------------------------------------------------------------------
    def _check_actions(self, actions: Any) -> np.ndarray:
        a = np.require(actions, dtype=np.float64, requirements=["C", "W"])  # one kernel signature
        shape = (self.num_envs, *self.single_action_space.shape)
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

    def _step_kernel(self, actions: np.ndarray, active: np.ndarray) -> None:
        """One slot of the ``active`` rows, then the best schedule of each flight that ended."""
        outputs = (self._obs, self._reward, self._terminated, self._info)
        stepping = np.flatnonzero(active)
        if self._rician:  # each row's node kernels and fading of the slot it flies to (its draws)
            for i in stepping:
                self.envs[i].prepare_slot(self._rows, i)
        elif self._mobile:  # each row's node kernels of the slot it flies to, in one call
            rows = self._rows
            gather_node_kernels(stepping, rows.state, self._track_nodes, self._track_params, rows.nodes,
                                rows.params)  # fmt: skip
        self._rows.step(actions, active, outputs, move_norms(actions), self.num_threads)
        if self._mobile:
            self._observe_rows(stepping)
        ended = np.flatnonzero(self._terminated)
        if ended.size:
            self._info[ended, BEST] = (
                episode_best_values(self._rows, ended, [self.envs[i] for i in ended], self.num_threads)
                if self.best_schedule
                else np.nan
            )

    # --- API ------------------------------------------------------------------------
    def _fly_compiled(
        self, rows: np.ndarray, targets: np.ndarray, moves: np.ndarray, obs: np.ndarray, info: np.ndarray
    ) -> bool:
        """:meth:`BatchedEnv.fly` in one compiled call, with equal shares (not for mobile or Rician
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
