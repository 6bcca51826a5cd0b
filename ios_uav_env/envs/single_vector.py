"""Natively batched envs: B episodes stepped as one array computation, registered on every id.

``gym.make_vec(id, num_envs=B, vectorization_mode="vector_entry_point")`` returns an
:class:`IOSUAVVectorEnv` (the fixed ids) or a :class:`RandomIOSUAVVectorEnv` (the randomised
id). They run the kernels of ``ios_uav_env.envs.single_kernels``, the ones the single env runs on a batch
of one, on B rows: the same physics, the same arrival guard and the same reward. Row i is the
single env reset with seed ``seed + i``: the same scenarios, and with channel "rician" the
same fading draws, so a batch reproduces B single envs exactly (tested).

Scenario choice at reset stays in Python, in one template env per row (the single env's own
code: its ``np_random``, its scenario draws, pinned configs, the space check), and costs
nothing per step. Autoreset follows Gymnasium's default ``NEXT_STEP`` mode: the step after
an episode ends resets that row and returns its first observation with reward 0. With
``autoreset_mode="same_step"`` (Gymnasium's ``SAME_STEP``, what SB3 expects) a row that ends
is reset in the same step: its observation is the new episode's first, and
``info["final_obs"]`` / ``info["final_info"]`` (masked by ``_final_obs`` / ``_final_info``)
hold the episode's last observation and info.
``info`` is a dict of arrays (``INFO_KEYS``, ``position`` of shape (B, 2)) with Gymnasium's
``_key`` masks (all True: every row has every key). :attr:`trajectories` holds each row's
way-points so far.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector.utils import batch_space

from ios_uav_env.envs.policies import full_speed_move
from ios_uav_env.envs.random_env import RandomIOSUAVEnv
from ios_uav_env.envs.single import INFO_KEYS, IOSUAVEnv
from ios_uav_env.envs.single_kernels import INFO, STATE, reset_rows, step_rows, step_rows_batched
from ios_uav_env.jit import run_batched
from ios_uav_env.model.config import ScenarioConfig

try:  # Gymnasium >= 1.1 names the autoreset modes
    from gymnasium.vector import AutoresetMode

    _AUTORESET: Any = AutoresetMode.NEXT_STEP
    _SAME_STEP: Any = AutoresetMode.SAME_STEP
except ImportError:  # pragma: no cover - Gymnasium 1.0: next-step is the only mode
    _AUTORESET, _SAME_STEP = "NextStep", None

#: ``info``'s keys in ``INFO_KEYS`` order, each with its column of the info array
_INFO_COLUMNS = [(key, INFO.index("position_x" if key == "position" else key)) for key in INFO_KEYS]

#: Values of ``autoreset_mode`` (Gymnasium's ``AutoresetMode`` members are accepted too).
AUTORESET_MODES = ("next_step", "same_step")


def check_threads(num_threads: Any) -> int | None:
    """``num_threads`` checked: None (numba's setting: every core) or an integer >= 1."""
    if num_threads is None:
        return None
    if isinstance(num_threads, bool) or not isinstance(num_threads, (int, np.integer)) or num_threads < 1:
        raise ValueError(f"num_threads must be None (every core) or an integer >= 1, got {num_threads!r}")
    return int(num_threads)


class IOSUAVVectorEnv(gym.vector.VectorEnv):
    """``num_envs`` episodes of :class:`~ios_uav_env.envs.single.IOSUAVEnv` in one array computation.

    Arguments are the single env's (``config``, ``EnvOptions`` and ``ScenarioConfig`` keywords)
    plus ``num_envs``; rendering is not supported (``render_mode=None``). Observations are
    (B, obs_dim) float32, rewards (B,) float64, ``terminated`` (B,) bool, ``truncated`` all
    False. ``reset(seed=s)`` seeds row i with ``s + i`` (a list of B seeds works too);
    ``options={"config": cfg}`` pins every row's episode to ``cfg``, ``options={"configs":
    [cfg_0, ...]}`` row i's to ``cfg_i`` (a batch of different scenarios, e.g. a held-out suite).
    """

    env_class: type[IOSUAVEnv] = IOSUAVEnv
    metadata = {"autoreset_mode": _AUTORESET, "render_modes": []}

    def __init__(
        self,
        num_envs: int = 1,
        config: Any = None,
        *,
        autoreset_mode: Any = "next_step",
        render_mode: None = None,
        num_threads: int | None = None,
        **kwargs: Any,
    ):
        self._check_batch(num_envs, autoreset_mode, render_mode)
        self.num_threads = check_threads(num_threads)
        template = self.env_class(config, **kwargs)
        self._copy_template(template)
        b = self.num_envs
        self._flags = template._flags
        self._rician = template.options.channel == "rician"
        self._state = np.zeros((b, len(STATE)))
        self._episode = np.zeros((b, template._episode.shape[1]))
        self._nodes = np.zeros((b, 3, template._nodes.shape[2]))
        self._params = np.zeros((b, template._params.shape[1]))
        self._normals = np.zeros((b, 2))
        self._outputs()
        self._path = np.zeros((b, template._ranges().slot_range[1], 2))
        self._autoreset = np.zeros(b, dtype=np.bool_)
        # rows whose scenario is the env's own (not pinned, not drawn): see _load_row
        self._plain = np.zeros(b, dtype=np.bool_)
        self._q0 = np.asarray(template._base_config.q0, dtype=np.float64)
        self._started = False
        self._masks = {f"_{key}": np.ones(b, dtype=np.bool_) for key in INFO_KEYS}
        for mask in self._masks.values():
            mask.setflags(write=False)

    def _check_batch(self, num_envs: Any, autoreset_mode: Any, render_mode: Any) -> None:
        """Check and set ``num_envs``, the autoreset mode (``same_step``) and ``render_mode`` (None)."""
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        mode = str(getattr(autoreset_mode, "value", autoreset_mode)).lower().replace("step", "_step")
        mode = mode.replace("__", "_")  # "NextStep", "next_step", AutoresetMode.NEXT_STEP, ...
        if mode not in AUTORESET_MODES:
            raise ValueError(f"autoreset_mode must be one of {AUTORESET_MODES}, got {autoreset_mode!r}")
        self.same_step = mode == "same_step"
        if render_mode is not None:
            raise ValueError(f"render_mode must be None for the batched env, got {render_mode!r}")
        self.num_envs = int(num_envs)
        self.render_mode = None
        if self.same_step and _SAME_STEP is not None:
            self.metadata = {**self.metadata, "autoreset_mode": _SAME_STEP}

    def _copy_template(self, template: gym.Env) -> None:
        """The spaces of ``template`` (single and batched) and one copy of it per row (``envs``:
        the rows' scenario managers, each with its own generator, seeded at reset)."""
        self.single_observation_space = template.observation_space
        self.single_action_space = template.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.envs = [copy.copy(template) for _ in range(self.num_envs)]
        for env in self.envs:
            env._np_random = None

    # --- rows -----------------------------------------------------------------------
    def _load_row(self, i: int, env: IOSUAVEnv) -> None:
        """Copy the current scenario of ``env`` into row ``i`` (growing the node arrays if needed)."""
        nodes = env.kernel.nodes
        k = nodes.shape[1]
        if k > self._nodes.shape[2]:
            grown = np.zeros((self.num_envs, 3, k))
            grown[:, 1, :] = 1.0
            grown[:, :, : self._nodes.shape[2]] = self._nodes
            self._nodes = grown
        self._nodes[i, :, :k] = nodes
        self._nodes[i, :, k:] = ((0.0,), (1.0,), (0.0,))  # padded nodes: zero weight
        self._params[i] = env.kernel.params
        self._episode[i] = env._episode[0]
        self._state[i, 0:2] = self._path[i, 0] = env.config.q0
        # the env's own scenario object (a fixed id's): a plain reset keeps it. A pinned
        # scenario, or a random env's draw (always a new object), is another object.
        self._plain[i] = env.config is env._base_config
        if self._rician:
            self._normals[i] = env.np_random.standard_normal(2)

    def _outputs(self) -> None:
        """Fresh output arrays for the next call (returned to the caller, never reused)."""
        b = self.num_envs
        self._obs = np.empty((b, self.single_observation_space.shape[0]), dtype=np.float32)
        self._reward = np.zeros(b)
        self._terminated = np.zeros(b, dtype=np.bool_)
        self._info = np.empty((b, len(INFO)))

    def _reset_rows(self, rows: np.ndarray, seeds: Sequence[int | None], options: Sequence[Any]) -> None:
        for i, seed, row_options in zip(rows, seeds, options, strict=True):
            env = self.envs[i]
            env._begin(seed, row_options)
            self._load_row(int(i), env)
        reset_rows(rows.astype(np.int64), self._state, self._episode, self._nodes, self._params,
                   self._normals, self._flags, self._obs, self._info)  # fmt: skip

    def _restart_rows(self, rows: np.ndarray) -> None:
        """New episodes on ``rows`` without a seed or options (autoreset, :meth:`restart`). A row
        that keeps its scenario (the fixed ids' own) only goes back to q0, without the Python
        reset of its template env: the same episode, at no per-row Python cost."""
        plain = self._plain[rows]
        quick, rest = rows[plain], rows[~plain]
        if quick.size:
            self._state[quick, 0:2] = self._path[quick, 0] = self._q0
            if self._rician:
                for i in quick:
                    self._normals[i] = self.envs[i].np_random.standard_normal(2)
            reset_rows(quick, self._state, self._episode, self._nodes, self._params, self._normals,
                       self._flags, self._obs, self._info)  # fmt: skip
        if rest.size:
            self._reset_rows(rest, [None] * rest.size, [None] * rest.size)

    def _row_options(self, options: Mapping[str, Any] | None) -> list[Any]:
        """Each row's reset options: ``{"config": cfg}`` pins every row, ``{"configs": [cfg_0,
        ..., cfg_{B-1}]}`` one scenario per row (None for a row: its own draw)."""
        if options is None or "configs" not in options:
            return [None if options is None else dict(options)] * self.num_envs
        if set(options) != {"configs"}:
            raise ValueError(
                f'reset takes options={{"config": cfg}} or {{"configs": [...]}}, got {sorted(options)}'
            )
        configs = list(options["configs"])
        if len(configs) != self.num_envs:
            raise ValueError(
                f'options["configs"] must hold {self.num_envs} scenarios (one per row), got {len(configs)}'
            )
        return [None if c is None else {"config": c} for c in configs]

    def _infos(self, table: np.ndarray | None = None) -> dict[str, Any]:
        """``info`` as column views of the info array (``INFO_KEYS``; ``_key`` masks)."""
        table = self._info if table is None else table
        columns = table.T
        out: dict[str, Any] = {}
        for key, column in _INFO_COLUMNS:
            out[key] = table[:, 2:4] if key == "position" else columns[column]
        out["slot"] = out["slot"].astype(np.int64)
        out["feasible"] = out["feasible"] != 0.0
        out.update(self._masks)
        return out

    # --- API ------------------------------------------------------------------------
    def reset(
        self, *, seed: int | Sequence[int] | None = None, options: Mapping[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        if seed is None:
            seeds: list[int | None] = [None] * self.num_envs
        elif isinstance(seed, (int, np.integer)):
            seeds = [int(seed) + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(
                    f"seed must be an int or {self.num_envs} seeds (one per env), got {len(seeds)}"
                )
        self._outputs()
        self._reset_rows(np.arange(self.num_envs), seeds, self._row_options(options))
        self._autoreset[:] = False
        self._started = True
        return self._obs, self._infos()

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        return self.advance(actions)

    def advance(
        self, actions: Any, rows: Any = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """:meth:`step` for the rows where the mask ``rows`` ((B,) bool; None: every row) is True.
        The other rows do not move: their state, observation and info are those returned last,
        their reward 0 and ``terminated`` False (a NEXT_STEP autoreset waits for their next
        step). E.g. an action repeat over rows whose episodes end at different slots
        (``agents.vec_env.VecActionRepeat``)."""
        if not self._started:
            raise RuntimeError("call reset() before step()")
        # one array type for the compiled kernel (C order, writeable float64): a view, a float32 or
        # a read-only batch would each compile another version (~5 s each)
        actions = np.require(actions, dtype=np.float64, requirements=["C", "W"])
        if actions.shape != (self.num_envs, 2):
            raise ValueError(f"actions must have shape ({self.num_envs}, 2), got {actions.shape}")
        active = self._begin_step(rows)
        if self._rician:
            for i in np.flatnonzero(active):
                self._normals[i] = self.envs[i].np_random.standard_normal(2)
        bad = run_batched(step_rows_batched, step_rows, self.num_threads, actions, self._state, self._episode,
                          self._nodes, self._params, self._normals, self._flags, self._obs, self._reward,
                          self._terminated, self._info, self._path, active)  # fmt: skip
        if bad >= 0:  # nothing stepped
            rows = np.flatnonzero(~np.isfinite(actions).all(axis=1))
            raise ValueError(f"actions must be finite (no NaN or inf); rows {rows.tolist()[:10]} are not")
        return self._end_step()

    def _begin_step(self, rows: Any = None) -> np.ndarray:
        """Fresh outputs, and the NEXT_STEP autoreset: the rows that ended at the last step start a
        new episode instead of stepping. ``rows``: the mask of :meth:`advance` (the other rows
        keep their last observation and info). The mask of the rows that step."""
        previous = (self._obs, self._info)
        if rows is not None:
            rows = np.asarray(rows)
            if rows.shape != (self.num_envs,) or rows.dtype != np.bool_:
                raise ValueError(f"rows must be a boolean mask of shape ({self.num_envs},), got {rows!r}")
        self._held = None if rows is None else ~rows
        self._outputs()
        pending = self._autoreset if rows is None else self._autoreset & rows
        done = np.flatnonzero(pending)
        if done.size:  # NEXT_STEP autoreset: these rows start a new episode instead of stepping
            self._restart_rows(done)
        if rows is None:
            return ~self._autoreset
        held = np.flatnonzero(self._held)
        self._obs[held], self._info[held] = previous[0][held], previous[1][held]
        return rows & ~self._autoreset

    def _end_step(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """The step's return once the kernel has stepped the rows (SAME_STEP: the rows that ended
        start their next episode now, their last observation and info under ``final_*``)."""
        truncated = np.zeros(self.num_envs, dtype=np.bool_)
        if not self.same_step:  # held rows (advance) still wait for their autoreset
            held = self._autoreset & self._held if self._held is not None else False
            self._autoreset = self._terminated | held
            return self._obs, self._reward, self._terminated, truncated, self._infos()
        ended = np.flatnonzero(self._terminated)
        final_obs, final_info = self._obs.copy(), self._infos(self._info.copy())
        if ended.size:  # SAME_STEP: the rows that ended start their next episode now
            self._restart_rows(ended)
        info = self._infos()
        mask = self._terminated.copy()
        info.update(final_obs=final_obs, _final_obs=mask, final_info=final_info, _final_info=mask)
        return self._obs, self._reward, self._terminated, truncated, info

    def fly(self, rows: Any, targets: Any, moves: Any) -> np.ndarray:
        """Hidden steps on ``rows``: row ``rows[r]`` flies ``moves[r]`` slots towards ``targets[r]``
        ((n, 2) m) at full speed, hovering once there (the arrival guard as always; the
        multi-node env serves every node equally), as :meth:`advance` would step it, and none of
        these steps is returned. ``moves[r]`` must leave the row's episode unfinished. Returns
        the batch's current observations (those rows' after the flight). E.g. to start episodes
        part-way (``agents.vec_env.VecExploringStarts``)."""
        rows, targets, moves = self._fly_args(rows, targets, moves)
        obs = self._obs
        width = self.single_action_space.shape[0]
        for j in range(int(moves.max(initial=0))):
            live = moves > j
            mask = np.zeros(self.num_envs, dtype=np.bool_)
            mask[rows[live]] = True
            step = np.array([[self.envs[i].config.D] for i in rows[live]])
            actions = np.zeros((self.num_envs, width))
            actions[rows[live], :2] = full_speed_move(targets[live] - self._state[rows[live], 0:2], step)
            obs = self.advance(actions, mask)[0]
        return obs

    def _fly_args(self, rows: Any, targets: Any, moves: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`fly`'s arguments checked (``ValueError`` naming the field)."""
        if not self._started:
            raise RuntimeError("call reset() before fly()")
        rows = np.asarray(rows, dtype=np.int64).reshape(-1)
        targets = np.require(np.asarray(targets, dtype=np.float64).reshape(-1, 2), requirements=["C"])
        moves = np.asarray(moves, dtype=np.int64).reshape(-1)
        if not (rows.size == len(targets) == moves.size) or np.any((rows < 0) | (rows >= self.num_envs)):
            raise ValueError(
                f"fly needs one target (x, y) and one move count per row of 0..{self.num_envs - 1}"
            )
        if not np.all(np.isfinite(targets)):
            raise ValueError("fly targets must be finite (m)")
        left = np.array([self.envs[i].config.N - 1 for i in rows]) - self._state[rows, 2]
        if np.any(moves < 0) or np.any(moves >= left) or np.any(self._autoreset[rows]):
            raise ValueError(
                f"fly moves must be >= 0 and leave each row's episode unfinished (< {left.tolist()})"
            )
        return rows, targets, moves

    def restart(self, rows: Sequence[int]) -> np.ndarray:
        """Start new episodes on ``rows`` now (each row's next scenario, no new seed); return the
        batch's current observations (those rows' first ones). E.g. to spread the rows over the
        episode before training (``agents.vec_env.BatchedVecEnv(stagger=True)``)."""
        if not self._started:
            raise RuntimeError("call reset() before restart()")
        rows = np.asarray(rows, dtype=np.int64)
        self._restart_rows(rows)
        self._autoreset[rows] = False
        return self._obs

    @property
    def trajectories(self) -> list[np.ndarray]:
        """Each row's way-points so far, q[1] .. q[n+1] ((n + 1, 2) arrays in metres)."""
        return [self._path[i, : int(self._state[i, 2]) + 1].copy() for i in range(self.num_envs)]

    @property
    def configs(self) -> list[ScenarioConfig]:
        """Each row's current scenario."""
        return [env.config for env in self.envs]

    def close(self, **kwargs: Any) -> None:
        for env in self.envs:
            env.close()


class RandomIOSUAVVectorEnv(IOSUAVVectorEnv):
    """``num_envs`` episodes of :class:`~ios_uav_env.envs.random_env.RandomIOSUAVEnv`: every row
    draws its own scenarios (row i as the single env seeded ``seed + i``). Arguments: the
    single env's (``ranges``, ``focus``, ...) plus ``num_envs``."""

    env_class = RandomIOSUAVEnv

    def __init__(self, num_envs: int = 1, ranges: Any = None, **kwargs: Any):
        super().__init__(num_envs, ranges, **kwargs)
