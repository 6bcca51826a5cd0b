"""What the batched envs share: B episodes as rows of arrays, stepped by one kernel call.

:class:`BatchedEnv` is the base of ``core.vector.UAVVectorEnv``, the batched env of every single-
and multi-node id (its rows: ``single_rows.SingleNodeRows`` for one ground node,
``node_rows.NodeBlockRows`` for K nodes). It holds one template env per row (the single
env's own code chooses each row's scenario at reset: its ``np_random``, its draws, pinned
configs and their checks), the seeding, the reset and step skeleton, both autoreset modes,
``info`` as a dict of arrays with Gymnasium's ``_key`` masks, and the batch-level calls
:meth:`~BatchedEnv.advance`, :meth:`~BatchedEnv.fly` and :meth:`~BatchedEnv.restart` (the last
two from its mixin ``ios_uav_env.envs.batched_calls.RowCalls``).

The row protocol (``ios_uav_env.envs.row_protocol``): the batched envs use their row envs
through public calls only, the ones the single env's own ``reset`` and ``step`` make.
``BatchedEnv`` calls ``begin_episode(seed, options) -> ScenarioConfig`` (the scenario part of
``reset``: seed, choose, check, make current; no step) at every reset, autoreset and restart,
and ``check_scenario(cfg, field)`` (optional) on every pinned scenario before any row resets;
it reads ``config`` and gives each row its own ``np_random``. ``SingleNodeRows`` adds the
kernel row (``kernel``, ``episode_row``, ...) and, for moving nodes, ``start_track``, ``track``
and ``observe_slot``; ``NodeBlockRows`` calls ``load_row``, ``prepare_slot`` and
``observe_slot`` on its ``NodeRows``. No batched module touches a private name of another object
(tested). A subclass holds its rows' arrays and its kernels, and supplies:

- ``env_class``: the single env (a ``row_protocol.ScenarioRow``) and ``info_keys``: the keys of
  ``info``;
- ``_init_rows(template)``: the row arrays (with ``_state``: (B, S), the UAV's x, y and moves
  made in columns 0-2, and ``_path``: (B, N_max, 2), each row's way-points) and
  ``_info_width``, the columns of the info table;
- ``_load_row(i, env)``: copy the scenario of row ``i``'s env into the row arrays;
  ``_start_rows(rows)``: the kernel that starts those rows' episodes;
- ``_check_actions(actions)`` and ``_step_kernel(actions, active)``: the kernel of one slot;
- ``_info_arrays(table)``: ``info`` (``info_keys``) as views of the info table;
- optionally ``_end_rows(rows, seeds)``: called before rows begin new episodes (reset, autoreset,
  restart), e.g. to give back draws a row made ahead of its episode's slots.

Autoreset follows Gymnasium's default ``NEXT_STEP`` mode: the step after an episode ends
resets that row and returns its first observation with reward 0. With
``autoreset_mode="same_step"`` (Gymnasium's ``SAME_STEP``, what SB3 expects) a row that ends
is reset in the same step: its observation is the new episode's first, and
``info["final_obs"]`` / ``info["final_info"]`` (masked by ``_final_obs`` / ``_final_info``)
hold the episode's last observation and info.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector.utils import batch_space

from ios_uav_env.envs.batched_calls import RowCalls
from ios_uav_env.envs.row_protocol import row_seeds, rows_options
from ios_uav_env.model.config import ScenarioConfig

try:  # Gymnasium >= 1.1 names the autoreset modes
    from gymnasium.vector import AutoresetMode

    _AUTORESET: Any = AutoresetMode.NEXT_STEP
    _SAME_STEP: Any = AutoresetMode.SAME_STEP
except ImportError:  # pragma: no cover - Gymnasium 1.0: next-step is the only mode
    _AUTORESET, _SAME_STEP = "NextStep", None

#: Values of ``autoreset_mode`` (Gymnasium's ``AutoresetMode`` members are accepted too).
AUTORESET_MODES = ("next_step", "same_step")

#: What :meth:`BatchedEnv.step` returns: observations, rewards, terminated, truncated, info.
StepResult = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]


def check_threads(num_threads: Any) -> int | None:
    """``num_threads`` checked: None (numba's setting: every core) or an integer >= 1."""
    if num_threads is None:
        return None
    if isinstance(num_threads, bool) or not isinstance(num_threads, (int, np.integer)) or num_threads < 1:
        raise ValueError(f"num_threads must be None (every core) or an integer >= 1, got {num_threads!r}")
    return int(num_threads)


def check_batch(env: gym.vector.VectorEnv, num_envs: Any, autoreset_mode: Any, render_mode: Any) -> None:
    """Check ``num_envs`` (an integer >= 1), ``autoreset_mode`` (:data:`AUTORESET_MODES` or an
    ``AutoresetMode``) and ``render_mode`` (None) of a batched ``env`` and set its ``num_envs``,
    ``same_step``, ``render_mode`` and the ``metadata``'s autoreset mode (``ValueError`` naming
    the argument otherwise): every batched env of the package takes these three alike."""
    if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
        raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
    mode = str(getattr(autoreset_mode, "value", autoreset_mode)).lower().replace("step", "_step")
    mode = mode.replace("__", "_")  # "NextStep", "next_step", AutoresetMode.NEXT_STEP, ...
    if mode not in AUTORESET_MODES:
        raise ValueError(f"autoreset_mode must be one of {AUTORESET_MODES}, got {autoreset_mode!r}")
    env.same_step = mode == "same_step"
    if render_mode is not None:
        raise ValueError(f"render_mode must be None for the batched env, got {render_mode!r}")
    env.num_envs = int(num_envs)
    env.render_mode = None
    if env.same_step and _SAME_STEP is not None:
        env.metadata = {**env.metadata, "autoreset_mode": _SAME_STEP}


class BatchedEnv(RowCalls, gym.vector.VectorEnv):
    """``num_envs`` episodes of ``env_class`` as rows of arrays (see the module's docstring).

    Arguments: the single env's (``config`` and its keywords) plus ``num_envs``,
    ``autoreset_mode`` ("next_step" or "same_step") and ``num_threads`` (numba's threads for
    the batched kernel; None: every core). Rendering is not supported (``render_mode=None``).
    ``reset(seed=s)`` seeds row i with ``s + i`` (a list of B seeds works too);
    ``options={"config": cfg}`` pins every row's episode to ``cfg``, ``options={"configs":
    [cfg_0, ...]}`` row i's to ``cfg_i``. ``observation_names``: the names of a row's observation
    components, the single env's.
    """

    env_class: type[gym.Env]
    info_keys: tuple[str, ...] = ()
    metadata = {"autoreset_mode": _AUTORESET, "render_modes": []}
    _state: np.ndarray
    _path: np.ndarray
    _info_width: int

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
        check_batch(self, num_envs, autoreset_mode, render_mode)
        self.num_threads = check_threads(num_threads)
        template = self._make_template(config, kwargs)
        self._copy_template(template)
        self._init_rows(template)
        self._outputs()
        self._autoreset = np.zeros(self.num_envs, dtype=np.bool_)
        self._started = False
        self._masks = {f"_{key}": np.ones(self.num_envs, dtype=np.bool_) for key in self.info_keys}
        for mask in self._masks.values():
            mask.setflags(write=False)

    def _make_template(self, config: Any, kwargs: dict[str, Any]) -> gym.Env:
        """The template env of the rows: ``env_class(config, **kwargs)`` (a subclass whose env takes
        no scenario builds it from the keywords alone)."""
        return self.env_class(config, **kwargs)

    def _copy_template(self, template: gym.Env) -> None:
        """The spaces of ``template`` (single and batched) and one copy of it per row (``envs``:
        the rows' scenario managers, each with a generator of its own, seeded at reset)."""
        self.single_observation_space = template.observation_space
        self.single_action_space = template.action_space
        #: The names of one row's observation components (the single env's ``observation_names``).
        self.observation_names: tuple[str, ...] | None = getattr(template, "observation_names", None)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.envs = [copy.copy(template) for _ in range(self.num_envs)]
        for env in self.envs:  # (a shallow copy would share the template's, if it had one)
            env.np_random = seeding.np_random()[0]

    # --- the subclass's rows and kernels --------------------------------------------
    def _init_rows(self, template: gym.Env) -> None:
        raise NotImplementedError

    def _load_row(self, i: int, env: Any) -> None:
        raise NotImplementedError

    def _start_rows(self, rows: np.ndarray) -> None:
        raise NotImplementedError

    def _check_actions(self, actions: Any) -> np.ndarray:
        raise NotImplementedError

    def _step_kernel(self, actions: np.ndarray, active: np.ndarray) -> None:
        raise NotImplementedError

    def _info_arrays(self, table: np.ndarray) -> dict[str, Any]:
        raise NotImplementedError

    # --- rows -----------------------------------------------------------------------
    def _outputs(self) -> None:
        """Fresh output arrays for the next call (returned to the caller, never reused)."""
        b = self.num_envs
        self._obs = np.empty((b, self.single_observation_space.shape[0]), dtype=np.float32)
        self._reward = np.zeros(b)
        self._terminated = np.zeros(b, dtype=np.bool_)
        self._info = np.zeros((b, self._info_width))

    def _end_rows(self, rows: np.ndarray, seeds: Sequence[int | None]) -> None:
        """Before ``rows`` begin new episodes with ``seeds`` (None: none), at every reset, autoreset
        and restart: the rows' generators as the single envs' would be (e.g. draws made ahead
        of the episode's slots taken back). Nothing by default."""

    def _draw_rows(self, rows: np.ndarray, seeds: Sequence[int | None], options: Sequence[Any]) -> np.ndarray:
        """Before the row envs reset ``rows`` (after :meth:`_end_rows`): new episodes the subclass
        makes itself for some of them, as their envs would (e.g. all the drawn episodes at once);
        the mask of ``rows`` left to reset through their envs. None by default: all of them."""
        return np.ones(len(rows), dtype=np.bool_)

    def _reset_rows(self, rows: np.ndarray, seeds: Sequence[int | None], options: Sequence[Any]) -> None:
        """New episodes on ``rows``: each row's env chooses its scenario (with its seed and options)."""
        self._end_rows(rows, seeds)
        rest = self._draw_rows(rows, seeds, options)
        if not rest.all():
            keep = rest.tolist()
            rows_left = rows[rest]
            seeds = [s for s, k in zip(seeds, keep, strict=True) if k]
            options = [o for o, k in zip(options, keep, strict=True) if k]
        else:
            rows_left = rows
        for i, seed, row_options in zip(rows_left, seeds, options, strict=True):
            env = self.envs[i]
            env.begin_episode(seed, row_options)
            self._load_row(int(i), env)
        self._start_rows(rows.astype(np.int64))

    def _restart_rows(self, rows: np.ndarray) -> None:
        """New episodes on ``rows`` without a seed or options (autoreset, :meth:`restart`)."""
        self._reset_rows(rows, [None] * rows.size, [None] * rows.size)

    def _infos(self, table: np.ndarray | None = None) -> dict[str, Any]:
        """``info``: views of the info table (``info_keys``), then the ``_key`` masks."""
        out = self._info_arrays(self._info if table is None else table)
        out.update(self._masks)
        return out

    # --- API ------------------------------------------------------------------------
    def reset(
        self, *, seed: int | Sequence[int] | None = None, options: Mapping[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        seeds = row_seeds(seed, self.num_envs)  # both checked before any row resets
        row_options = rows_options(options, self.envs)
        self._outputs()
        try:
            self._reset_rows(np.arange(self.num_envs), seeds, row_options)
        except Exception:
            self._started = False  # no half-reset batch to step: the next call must be reset()
            raise
        self._autoreset[:] = False
        self._started = True
        return self._obs, self._infos()

    def step(self, actions: Any) -> StepResult:
        return self.advance(actions)

    def advance(self, actions: Any, rows: Any = None) -> StepResult:
        """:meth:`step` for the rows where the mask ``rows`` ((B,) bool; None: every row) is True.
        The other rows do not move: their state, observation and info are those returned last,
        their reward 0 and ``terminated`` False (a NEXT_STEP autoreset waits for their next
        step). E.g. an action repeat over rows whose episodes end at different slots
        (``agents.vec_env.VecActionRepeat``)."""
        if not self._started:
            raise RuntimeError("call reset() before step()")
        actions = self._check_actions(actions)
        active = self._begin_step(rows)
        self._step_kernel(actions, active)
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

    def _end_step(self) -> StepResult:
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
