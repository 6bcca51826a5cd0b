"""The STAR control's batched form: B episodes of ``STARControlEnv`` as rows of arrays.

Each row's env chooses its episode (``begin_episode``: its line, its slots' channels, from its
own generator), and every step evaluates the B rows' settings at once
(``star_control_rows.ControlMap``, ``star_slot.evaluate_rows``) with their per-slot optima
(``star_slot.slot_optima``: the TDMA closed form over the rows at once; NOMA's searches row by
row). The calls are the single env's on B rows, so row i is ``STARControlEnv`` seeded
``seed + i`` bit for bit, across autoresets (tested).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ios_uav_env.envs.batched import BatchedEnv
from ios_uav_env.envs.star_control import INFO_KEYS, LENGTH_SCALE, N_SLOTS, USERS_FEATURES, STARControlEnv
from ios_uav_env.model.star_rows import StarRows
from ios_uav_env.model.star_slot import evaluate_rows, slot_optima

__all__ = ["STARControlVectorEnv"]

_COLUMN = {key: j for j, key in enumerate(INFO_KEYS)}
_FIELDS = ("a_r", "a_t", "phi_r", "phi_t", "direct_r", "direct_t", "eta", "fixed_r", "fixed_t")


class STARControlVectorEnv(BatchedEnv):
    """``num_envs`` episodes of ``STARControlEnv`` (same keywords) as rows (``BatchedEnv``: seeding
    ``seed + i``, both autoreset modes, ``info`` as arrays with ``_key`` masks, ``advance``,
    ``restart``). ``info`` has ``STARControlEnv``'s keys, each a (B,) array (``slot`` int64).
    ``num_threads`` is checked and kept for the batched envs' common signature; the rows are numpy
    arrays (no compiled kernel), so it changes nothing. :meth:`fly` is refused: the UAV's path is
    given. With ``optimum=False`` the per-slot optimum is not computed (its keys are NaN): under
    NOMA it is a search per row and slot (~0.1 s each with ES), under TDMA closed form and cheap.
    """

    env_class = STARControlEnv
    info_keys = INFO_KEYS

    def __init__(
        self,
        num_envs: int = 1,
        *,
        autoreset_mode: Any = "next_step",
        render_mode: None = None,
        num_threads: int | None = None,
        **kwargs: Any,
    ) -> None:
        super().__init__(
            num_envs, None, autoreset_mode=autoreset_mode, render_mode=render_mode, num_threads=num_threads,
            **kwargs,
        )  # fmt: skip

    def _make_template(self, config: Any, kwargs: dict[str, Any]) -> STARControlEnv:
        """The template from the keywords alone: this env takes no scenario (its line is drawn at
        every reset)."""
        return STARControlEnv(**kwargs)

    # --- the rows -------------------------------------------------------------------
    def _init_rows(self, template: STARControlEnv) -> None:
        b, m = self.num_envs, template.M
        self.map, self.surface, self.access = template.map, template.surface, template.access
        self.optimum = template.optimum
        self._state = np.zeros((b, 3))  # the UAV's x, y and the slots played
        self._path = np.zeros((b, N_SLOTS, 2))  # each row's way-points (its line)
        self._totals = np.zeros((b, 2))  # return, optimum return
        element = {name: np.zeros((b, N_SLOTS, m)) for name in _FIELDS[:4]}
        self._rows = StarRows(**element, **{name: np.zeros((b, N_SLOTS)) for name in _FIELDS[4:]})
        self._info_width = len(INFO_KEYS)

    def _load_row(self, i: int, env: STARControlEnv) -> None:
        for name in _FIELDS:
            getattr(self._rows, name)[i] = getattr(env.rows, name)
        self._path[i] = env.positions

    def _start_rows(self, rows: np.ndarray) -> None:
        self._state[rows, 2] = 0.0
        self._state[rows, :2] = self._path[rows, 0]
        self._totals[rows] = 0.0
        self._info[rows] = 0.0
        self._info[rows, _COLUMN["uav_x"]] = self._path[rows, 0, 0]
        self._info[rows, _COLUMN["uav_y"]] = self._path[rows, 0, 1]
        self._observe(rows)

    def _observe(self, rows: np.ndarray) -> None:
        """The observations of ``rows`` at their current slots (the last one once ended)."""
        n = np.minimum(self._state[rows, 2].astype(np.int64), N_SLOTS - 1)
        head = np.column_stack(
            [
                self._path[rows, n] / LENGTH_SCALE,
                np.broadcast_to(USERS_FEATURES, (rows.size, 4)),
                n / (N_SLOTS - 1),
            ]
        )
        self._obs[rows] = self.map.observations(self._rows.take((rows, n)), head)

    def _check_actions(self, actions: Any) -> np.ndarray:
        actions = np.asarray(actions, dtype=np.float64)
        shape = (self.num_envs, *self.single_action_space.shape)
        if actions.shape != shape or not np.all(np.isfinite(actions)):
            raise ValueError(f"actions must be a finite array of shape {shape}, got shape {actions.shape}")
        return actions

    def _step_kernel(self, actions: np.ndarray, active: np.ndarray) -> None:
        rows = np.flatnonzero(active)
        if not rows.size:
            return
        n = self._state[rows, 2].astype(np.int64)
        base = self._rows.take((rows, n))
        rate_r, rate_t = evaluate_rows(
            base, self.surface, self.access, self.map.settings(actions[rows], base)
        )
        if self.optimum:
            best, upper = slot_optima(base, self.surface, self.access)
        else:
            best = upper = np.full(rows.size, np.nan)
        value = np.minimum(rate_r, rate_t)
        self._totals[rows] += np.column_stack([value, best])
        ret, total = self._totals[rows, 0], self._totals[rows, 1]
        some = total > 0
        pct = np.where(np.isnan(total), np.nan, 0.0)
        pct[some] = 100.0 * ret[some] / total[some]
        q = self._path[rows, n]
        self._info[rows] = np.column_stack([n, q, rate_r, rate_t, value, best, upper, ret, total, pct])
        self._reward[rows] = value
        self._state[rows, 2] = n + 1
        self._state[rows, :2] = self._path[rows, np.minimum(n + 1, N_SLOTS - 1)]
        self._terminated[rows] = n + 1 == N_SLOTS
        self._observe(rows)

    def _info_arrays(self, table: np.ndarray) -> dict[str, Any]:
        """``info`` as column views of the info table (``INFO_KEYS``; ``slot`` as int64)."""
        out: dict[str, Any] = {key: table[:, j] for key, j in _COLUMN.items()}
        out["slot"] = out["slot"].astype(np.int64)
        return out

    def fly(self, rows: Any, targets: Any, moves: Any) -> np.ndarray:
        """Refused: the UAV flies a given line; no policy moves it."""
        raise NotImplementedError(
            "STARControlVectorEnv has no fly(): the UAV's path is given, not controlled"
        )
