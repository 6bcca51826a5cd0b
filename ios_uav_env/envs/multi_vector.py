"""The multi-node env batched: B episodes of ``MultiNodeEnv`` stepped as one array computation.

``gym.make_vec("ios_uav_env/IOSUAV-MultiNode-v0", num_envs=B,
vectorization_mode="vector_entry_point")`` (and the ``-Random-v0`` id) returns a
:class:`MultiNodeVectorEnv`. Each step runs the kernels of ``ios_uav_env.envs.multi_kernels``
on B rows (compiled with numba when installed): the single env's rate functions
(``channel.rate_point`` per node), arrival guard, softmax shares, reward terms and
observation, so row i reproduces the single env reset with seed ``seed + i`` (tested to
1e-9). Scenario choice at reset stays in Python, in one template ``MultiNodeEnv`` per row
(its ``np_random``, its draws, pinned configs and their checks). The last step of an episode
also reports ``best_schedule_rate``: ``multinode.maxmin_rate`` of the row's trajectory, an LP
(about 18 ms at N = 150, K = 3: far more than the episode's steps at large B);
``best_schedule=False`` skips it (the key then holds NaN at episode ends).

The conventions are ``IOSUAVVectorEnv``'s (``ios_uav_env.envs.single_vector``): autoreset
``NEXT_STEP`` by default, ``autoreset_mode="same_step"`` with ``final_obs`` / ``final_info``;
``info`` a dict of arrays (``MULTI_INFO_KEYS``; ``position`` (B, 2), ``shares`` and
``node_rates`` (B, K_max)) with Gymnasium's ``_key`` masks; ``reset(seed=s)`` seeds row i with
``s + i``, ``options={"config": cfg}`` / ``{"configs": [...]}`` pin the rows' scenarios.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from ios_uav_env.envs.multi import MULTI_INFO_KEYS, MultiNodeEnv, node_peaks
from ios_uav_env.envs.multi_kernels import (
    BEST,
    EPISODE,
    INFO,
    POINT,
    STATE,
    episode_row,
    fly_rows,
    info_columns,
    move_norms,
    node_points,
    reset_rows,
    step_rows,
    step_rows_batched,
)
from ios_uav_env.envs.single_kernels import flags_of
from ios_uav_env.envs.single_vector import _AUTORESET, IOSUAVVectorEnv, check_threads
from ios_uav_env.jit import run_batched
from ios_uav_env.model.channel import PARAMS, rate_kernel
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.schedule import reported_maxmin_rate


class MultiNodeVectorEnv(gym.vector.VectorEnv):
    """``num_envs`` episodes of :class:`~ios_uav_env.envs.multi.MultiNodeEnv` in one array
    computation.

    Arguments: the single env's (``config``, ``max_nodes``, ``share_sharpness``,
    ``random_nodes``, ``ranges``, ``EnvOptions`` and ``ScenarioConfig`` keywords) plus
    ``num_envs``, ``autoreset_mode`` and ``best_schedule`` (True: ``maxmin_rate`` at each
    episode end, as the single env; False: NaN there, no LP). Observations (B, 12 + 6 K_max)
    float32, actions (B, 2 + K_max), rewards (B,) float64. No rendering.
    """

    metadata = {"autoreset_mode": _AUTORESET, "render_modes": []}

    # the batch-level methods are IOSUAVVectorEnv's: they only use the row arrays' names
    reset = IOSUAVVectorEnv.reset
    restart = IOSUAVVectorEnv.restart
    _row_options = IOSUAVVectorEnv._row_options
    trajectories = IOSUAVVectorEnv.trajectories
    configs = IOSUAVVectorEnv.configs
    close = IOSUAVVectorEnv.close
    _begin_step = IOSUAVVectorEnv._begin_step
    _check_batch = IOSUAVVectorEnv._check_batch
    _copy_template = IOSUAVVectorEnv._copy_template
    _end_step = IOSUAVVectorEnv._end_step
    _fly_args = IOSUAVVectorEnv._fly_args

    def __init__(
        self,
        num_envs: int = 1,
        config: Any = None,
        *,
        autoreset_mode: Any = "next_step",
        best_schedule: bool = True,
        render_mode: None = None,
        num_threads: int | None = None,
        **kwargs: Any,
    ):
        self._check_batch(num_envs, autoreset_mode, render_mode)
        self.num_threads = check_threads(num_threads)
        self.best_schedule = bool(best_schedule)
        template = MultiNodeEnv(config, **kwargs)
        self._copy_template(template)
        b, k = self.num_envs, template.max_nodes
        self.max_nodes, self._flags = k, flags_of(template.options)
        self._length_scale, self._sharpness = template.options.length_scale, template.share_sharpness
        self._state, self._episode = np.zeros((b, len(STATE))), np.zeros((b, len(EPISODE)))
        self._points, self._served = np.zeros((b, k, len(POINT))), np.zeros((b, k))
        self._shares, self._rates = np.zeros((b, k)), np.zeros((b, k))
        self._nodes = np.zeros((b, k, 3, 1))
        self._params = np.zeros((b, k, len(PARAMS)))
        self._loaded: list[ScenarioConfig | None] = [None] * b
        self._path, self._share_path = np.zeros((b, 1, 2)), np.zeros((b, 1, k))
        self._outputs()
        self._autoreset = np.zeros(b, dtype=np.bool_)
        self._started = False
        self._masks = {f"_{key}": np.ones(b, dtype=np.bool_) for key in MULTI_INFO_KEYS}
        for mask in self._masks.values():
            mask.setflags(write=False)

    # --- rows -----------------------------------------------------------------------
    def _grow(self, name: str, axis: int, size: int, fill: tuple[float, ...] = (0.0,)) -> None:
        """Grow array ``self.<name>`` along ``axis`` to ``size``; new entries 0, or ``fill`` over the
        array's second-to-last axis (``_nodes``: padded surface nodes (0, 1, 0) have zero weight)."""
        old = getattr(self, name)
        shape = list(old.shape)
        shape[axis] = size
        grown = np.zeros(shape)
        if len(fill) > 1:
            grown[...] = np.asarray(fill).reshape(-1, 1)
        grown[tuple(slice(0, n) for n in old.shape)] = old
        setattr(self, name, grown)

    def _load_row(self, i: int, cfg: ScenarioConfig) -> None:
        """Copy the scenario ``cfg`` into row ``i`` (unless it is already there) and put the UAV at q0."""
        if self._loaded[i] is not cfg:
            kernels = [rate_kernel(cfg.node_config(k)) for k in range(cfg.K)]
            width = max(kn.nodes.shape[1] for kn in kernels)
            if width > self._nodes.shape[3]:
                self._grow("_nodes", 3, width, fill=(0.0, 1.0, 0.0))  # padded nodes: zero weight
            if cfg.N > self._path.shape[1]:
                self._grow("_path", 1, cfg.N)
                self._grow("_share_path", 1, cfg.N)
            for k, kn in enumerate(kernels):
                q = kn.nodes.shape[1]
                self._nodes[i, k, :, :q] = kn.nodes
                self._nodes[i, k, :, q:] = ((0.0,), (1.0,), (0.0,))
                self._params[i, k] = kn.params
            env = self.envs[i]
            peaks = node_peaks(cfg) if env.options.peak_hint else None
            self._points[i, : cfg.K] = node_points(cfg, peaks)
            self._episode[i] = episode_row(
                cfg, self._length_scale, self._sharpness, env.softmin_beta, env.options.peak_hint
            )
            self._loaded[i] = cfg
        self._state[i, 0:2] = self._path[i, 0] = cfg.q0

    def _outputs(self) -> None:
        """Fresh output arrays for the next call (returned to the caller, never reused)."""
        b = self.num_envs
        self._obs = np.empty((b, self.single_observation_space.shape[0]), dtype=np.float32)
        self._reward = np.zeros(b)
        self._terminated = np.zeros(b, dtype=np.bool_)
        self._info = np.zeros((b, info_columns(self.max_nodes)))

    def _reset_rows(self, rows: np.ndarray, seeds: Sequence[int | None], options: Sequence[Any]) -> None:
        for i, seed, row_options in zip(rows, seeds, options, strict=True):
            env = self.envs[i]
            if row_options is None:  # the single env's reset up to its scenario choice
                gym.Env.reset(env, seed=seed)
                env.config = env._episode_config(None)
            else:  # the single env's own reset: it checks the pinned scenario
                env.reset(seed=seed, options=row_options)
            self._load_row(int(i), env.config)
        reset_rows(rows.astype(np.int64), self._state, self._episode, self._points, self._nodes,
                   self._params, self._served, self._shares, self._rates, self._obs, self._info,
                   self._share_path)  # fmt: skip

    def _restart_rows(self, rows: np.ndarray) -> None:
        """New episodes on ``rows`` without a seed or options (autoreset, :meth:`restart`)."""
        self._reset_rows(rows, [None] * rows.size, [None] * rows.size)

    def _infos(self, table: np.ndarray | None = None) -> dict[str, Any]:
        """``info`` as views of the info table (``MULTI_INFO_KEYS``; ``_key`` masks)."""
        table = self._info if table is None else table
        k, columns = self.max_nodes, table.T
        out = {key: columns[i] for i, key in enumerate(INFO) if not key.startswith("position")}
        out["position"] = table[:, 0:2]
        out["slot"] = out["slot"].astype(np.int64)
        out["feasible"] = out["feasible"] != 0.0
        out["shares"], out["node_rates"] = table[:, len(INFO) : len(INFO) + k], table[:, len(INFO) + k :]
        out = {key: out[key] for key in MULTI_INFO_KEYS}
        out.update(self._masks)
        return out

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

    # --- API ------------------------------------------------------------------------
    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        return self.advance(actions)

    def advance(
        self, actions: Any, rows: Any = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """:meth:`step` for the rows of the mask ``rows`` only (``IOSUAVVectorEnv.advance``)."""
        if not self._started:
            raise RuntimeError("call reset() before step()")
        actions = self._check_actions(actions)
        active = self._begin_step(rows)
        run_batched(step_rows_batched, step_rows, self.num_threads, actions, self._state, self._episode,
                    self._points, self._nodes, self._params, self._served, self._shares, self._rates,
                    self._flags, self._obs, self._reward, self._terminated, self._info, self._path,
                    self._share_path, active, move_norms(actions))  # fmt: skip
        for i in np.flatnonzero(self._terminated):  # the best schedule of the flight: an LP per episode
            cfg = self.envs[i].config
            self._info[i, BEST] = (
                reported_maxmin_rate(cfg, self._path[i, : cfg.N]) if self.best_schedule else np.nan
            )
        return self._end_step()

    def fly(self, rows: Any, targets: Any, moves: Any) -> np.ndarray:
        """Hidden steps (``IOSUAVVectorEnv.fly``) in one compiled call: row ``rows[r]`` flies
        ``moves[r]`` slots towards ``targets[r]`` at full speed with equal shares."""
        rows, targets, moves = self._fly_args(rows, targets, moves)
        b, width = self.num_envs, self.single_action_space.shape[0]
        obs, info = self._obs.copy(), self._info.copy()  # fresh: the arrays returned last stay as they were
        fly_rows(rows, targets, moves, np.zeros((b, width)), self._state, self._episode, self._points,
                 self._nodes, self._params, self._served, self._shares, self._rates, self._flags, obs,
                 np.zeros(b), np.zeros(b, dtype=np.bool_), info, self._path, self._share_path,
                 np.zeros(b))  # fmt: skip
        self._obs, self._info = obs, info
        return obs

    @property
    def schedules(self) -> list[np.ndarray]:
        """Each row's shares so far, (K, n + 1) arrays (the single env's ``shares``)."""
        out = []
        for i, cfg in enumerate(self.configs):
            out.append(self._share_path[i, : int(self._state[i, 2]) + 1, : cfg.K].T.copy())
        return out
