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
reset in one template ``MultiNodeEnv`` per row (``load_row``, ``prepare_slot`` and
``observe_slot`` of ``ios_uav_env.envs.row_protocol.MultiNodeRow``), autoreset ``NEXT_STEP`` by default or
``autoreset_mode="same_step"`` with ``final_obs`` / ``final_info``, ``reset(seed=s)`` seeding
row i with ``s + i``, ``options={"config": cfg}`` / ``{"configs": [...]}`` pinning the rows'
scenarios. ``info`` is a dict of arrays (the single env's ``info_keys``: ``MULTI_INFO_KEYS``, and
the energy objective's and the Rician channel's keys; ``position`` (B, 2), ``shares``,
``node_rates`` and ``expected_node_rates`` (B, K_max)) with Gymnasium's ``_key`` masks. With the
energy objective each row's lambda_ref is its template env's; with channel "rician" each row
draws its slots' fading from its template env's ``np_random`` (so row i is the single env of seed
``seed + i``, draw for draw).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ios_uav_env.envs.batched import BatchedEnv
from ios_uav_env.envs.multi import MultiNodeEnv
from ios_uav_env.envs.multi_kernels import NodeRows, episode_best_values, move_norms
from ios_uav_env.envs.multi_table import BEST, MULTI_INFO_KEYS, info_arrays, info_columns


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
        # moving or roughly known nodes: per-row kernels per slot and observations by the rows'
        # template envs (Python per row and slot: ios_uav_env.envs.knowledge)
        self._mobile = template.mobile

    @property
    def _path(self) -> np.ndarray:
        return self._rows.path  # (grows with the longest episode loaded)

    # --- rows -----------------------------------------------------------------------
    def _load_row(self, i: int, env: MultiNodeEnv) -> None:
        # the scenario, node paths, lambda_ref, the first slot's fading: as the single env's reset
        env.load_row(self._rows, i)

    def _start_rows(self, rows: np.ndarray) -> None:
        self._rows.start(rows, self._obs, self._info)
        if self._mobile:
            for i in rows:
                self.envs[i].observe_slot(self._rows, i, self._obs[i])

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
        if self._mobile or self._rician:  # each row's node kernels and fading of the slot it flies to
            for i in stepping:
                self.envs[i].prepare_slot(self._rows, i)
        self._rows.step(actions, active, outputs, move_norms(actions), self.num_threads)
        if self._mobile:
            for i in stepping:
                self.envs[i].observe_slot(self._rows, i, self._obs[i])
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
