"""The batch-level calls of a batched env besides its steps: hidden flights and restarts of rows.

:class:`RowCalls` is a mixin of ``batched.BatchedEnv`` holding :meth:`~RowCalls.fly` (rows fly
towards targets in steps that are not returned, e.g. to start episodes part-way) and
:meth:`~RowCalls.restart` (rows start new episodes now, as an autoreset would), with the checks
of their arguments. A flight steps the rows through the env's own step kernel (``_step_kernel``,
as :meth:`~ios_uav_env.envs.batched.BatchedEnv.advance` would), unless the subclass flies them in
one compiled call (``_fly_compiled``); a restart starts the rows' episodes as an autoreset does
(``_restart_rows``). The row arrays, outputs and hooks these calls use are ``BatchedEnv``'s
(its module docstring).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ios_uav_env.envs.policies import full_speed_move


def _whole_numbers(values: Any, name: str) -> np.ndarray:
    """``values`` as a flat int64 array (``ValueError`` naming ``name`` unless each is a whole number)."""
    array = np.asarray(values).reshape(-1)
    floats = np.issubdtype(array.dtype, np.floating)
    whole = floats and bool(np.all(np.abs(array) < 2**53) and np.all(array % 1 == 0))
    if array.dtype == np.bool_ or not (np.issubdtype(array.dtype, np.integer) or whole or array.size == 0):
        raise ValueError(f"{name} must be whole numbers, got {values!r}")
    return array.astype(np.int64)


def _occurrences(rows: np.ndarray) -> list[np.ndarray]:
    """The entries of ``rows`` by occurrence: the indices of each row's first entry, then of each
    row's second, ... (each group holds distinct rows)."""
    count: dict[int, int] = {}
    order = np.zeros(rows.size, dtype=np.int64)
    for r, i in enumerate(rows.tolist()):
        order[r] = count.get(i, 0)
        count[i] = int(order[r]) + 1
    return [np.flatnonzero(order == k) for k in range(int(order.max(initial=-1)) + 1)]


class RowCalls:
    """:meth:`fly` and :meth:`restart` of a batched env (module docstring); ``BatchedEnv`` holds
    the attributes and hooks annotated here."""

    num_envs: int
    envs: list[Any]
    single_action_space: Any
    _started: bool
    _state: np.ndarray
    _obs: np.ndarray
    _info: np.ndarray
    _reward: np.ndarray
    _terminated: np.ndarray
    _autoreset: np.ndarray
    _outputs: Callable[[], None]
    _restart_rows: Callable[[np.ndarray], None]
    _check_actions: Callable[[Any], np.ndarray]
    _step_kernel: Callable[[np.ndarray, np.ndarray], None]

    def fly(self, rows: Any, targets: Any, moves: Any) -> np.ndarray:
        """Hidden steps on ``rows``: row ``rows[r]`` flies ``moves[r]`` slots towards ``targets[r]``
        ((n, 2) m) at full speed, hovering once there (the arrival guard as always; the other
        action entries 0: the multi-node env serves every node equally), as :meth:`advance`
        would step it, and none of these steps is returned. A row given more than once flies
        its entries in order. The moves of a row, summed over its entries, must leave its
        episode unfinished. E.g. to start episodes part-way (``agents.vec_env.VecExploringStarts``).

        Afterwards each row is where those steps leave it, as if the policy had flown them: its
        episode, scenario and slot (``moves`` later), ``trajectories`` holding the flown
        way-points, its running score (``average_rate``, energy, ``feasible``, ...) over them, and
        its generator past their draws (fading, reports: a row draws exactly what its steps would;
        no seed is involved). Their rewards are dropped. Returns the batch's current observations
        (the flown rows' after the flight, the others' unchanged); the rows' ``info`` is not
        returned but moves with them: an :meth:`advance` that holds a row returns its info after
        the flight, and its next step reports from there. The arrays returned earlier are left
        as they were.

        A subclass whose kernel can fly rows in one call overrides :meth:`_fly_compiled`;
        otherwise (or when it returns False) the rows step slot by slot (:meth:`_fly_stepped`)."""
        rows, targets, moves = self._fly_args(rows, targets, moves)
        obs, info = self._obs.copy(), self._info.copy()  # fresh: the arrays returned last stay as they were
        if not self._fly_compiled(rows, targets, moves, obs, info):
            return self._fly_stepped(rows, targets, moves)
        self._obs, self._info = obs, info
        return obs

    def _fly_compiled(
        self, rows: np.ndarray, targets: np.ndarray, moves: np.ndarray, obs: np.ndarray, info: np.ndarray
    ) -> bool:
        """:meth:`fly` of checked arguments in one compiled call writing ``obs`` and ``info`` (copies
        of the current arrays), or False (nothing written) where this batch has no such kernel."""
        return False

    def _fly_stepped(self, rows: np.ndarray, targets: np.ndarray, moves: np.ndarray) -> np.ndarray:
        """:meth:`fly` of checked arguments by :meth:`advance`'s steps (the reference of every
        compiled flight)."""
        obs = self._obs
        for entries in _occurrences(rows):  # a row's first entry, then its second, ...
            obs = self._fly_once(rows[entries], targets[entries], moves[entries])
        return obs

    def _fly_once(self, rows: np.ndarray, targets: np.ndarray, moves: np.ndarray) -> np.ndarray:
        """:meth:`fly` of distinct ``rows`` (checked arguments): :meth:`advance`'s steps of those
        rows on fresh output arrays, without its per-step bookkeeping (no row ends during a flight,
        so no autoreset and no final observation; the rewards are dropped)."""
        previous_obs, previous_info = self._obs, self._info
        self._outputs()  # the arrays returned by the last call are left as they were
        self._obs[:], self._info[:] = previous_obs, previous_info
        width = self.single_action_space.shape[0]
        step = np.array([[self.envs[i].config.D] for i in rows])
        actions = self._check_actions(np.zeros((self.num_envs, width)))  # (the kernel's array type as it is)
        active = np.zeros(self.num_envs, dtype=np.bool_)
        for j in range(int(moves.max(initial=0))):
            live = moves > j
            flying = rows[live]
            active[:] = False
            active[flying] = True
            actions[flying, :2] = full_speed_move(targets[live] - self._state[flying, 0:2], step[live])
            self._step_kernel(actions, active)
        self._reward[:] = 0.0
        self._terminated[:] = False
        return self._obs

    def _fly_args(self, rows: Any, targets: Any, moves: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`fly`'s arguments checked (``ValueError`` naming the field and its limit)."""
        if not self._started:
            raise RuntimeError("call reset() before fly()")
        rows = _whole_numbers(rows, "fly rows")
        targets = np.require(np.asarray(targets, dtype=np.float64).reshape(-1, 2), requirements=["C"])
        moves = _whole_numbers(moves, "fly moves")
        if not (rows.size == len(targets) == moves.size) or np.any((rows < 0) | (rows >= self.num_envs)):
            raise ValueError(
                f"fly needs one target (x, y) and one move count per row of 0..{self.num_envs - 1}"
            )
        if not np.all(np.isfinite(targets)):
            raise ValueError("fly targets must be finite (m)")
        if np.any(moves < 0):
            raise ValueError(f"fly moves must be >= 0, got {moves.tolist()}")
        total = np.zeros(self.num_envs, dtype=np.int64)
        np.add.at(total, rows, moves)  # a row given twice flies both entries
        for i in np.unique(rows).tolist():
            if self._autoreset[i]:
                raise ValueError(
                    f"fly moves must leave each row's episode unfinished: row {i}'s episode has ended "
                    "(it restarts at its next step)"
                )
            left = self.envs[i].config.N - 1 - int(self._state[i, 2])
            if total[i] >= left:
                raise ValueError(
                    f"fly moves must leave each row's episode unfinished: row {i} is given {total[i]} "
                    f"moves (summed over its entries), at most {left - 1} (it has {left} moves left)"
                )
        return rows, targets, moves

    def restart(self, rows: Sequence[int]) -> np.ndarray:
        """Start new episodes on ``rows`` now, as an autoreset would: each row's next scenario from
        its own generator, without a new seed (a fixed id's scenario again, a random id's next
        draw; the row's ``begin_episode(None, None)``), the UAV at q0 in slot 1, ``trajectories``
        holding q0 only, and a pending NEXT_STEP autoreset of the row dropped (its next step is
        its new episode's first). Returns the batch's current observations: the array returned
        last, with those rows' first ones written in. The rows' ``info`` is their reset's, not
        returned: an :meth:`advance` that holds a row returns it. E.g. to spread the rows over
        the episode before training (``agents.vec_env.BatchedVecEnv(stagger=True)``)."""
        if not self._started:
            raise RuntimeError("call reset() before restart()")
        rows = _whole_numbers(rows, "restart rows")
        if np.any((rows < 0) | (rows >= self.num_envs)):
            raise ValueError(
                f"restart rows must be row indices in 0..{self.num_envs - 1}, got {rows.tolist()}"
            )
        self._restart_rows(rows)
        self._autoreset[rows] = False
        return self._obs
