"""``UAVVectorEnv``: the one natively batched env of the single- and multi-node worlds.

``gym.make_vec(id, num_envs=B, vectorization_mode="vector_entry_point")`` returns it for every
single- and multi-node id. Its template env (a ``UAVEnv`` made with the id's keywords) chooses the
rows by its view: ``single_rows.SingleNodeRows`` (``"v0"``), ``node_rows.NodeBlockRows``
(``"node_blocks"``), which hold the row arrays and call the compiled step, or
``star_noma_rows.StarNomaRows`` (``"star_noma"``) or ``miso_sdma.MisoSdmaRows``
(``"miso_sdma"``): numpy, the rows the single env runs one of.
Everything else is
``ios_uav_env.envs.batched.BatchedEnv``'s, once: the scenario choice at reset in one template env
per row (the row protocol), seeding (row i is the single env reset with seed ``seed + i``, draw
for draw), autoreset ``NEXT_STEP`` by default or ``autoreset_mode="same_step"`` with
``final_obs`` / ``final_info``, ``advance``, ``fly`` and ``restart``, and ``info`` as a dict of
arrays with Gymnasium's ``_key`` masks.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ios_uav_env.envs.batched import BatchedEnv
from ios_uav_env.envs.core.env import UAVEnv
from ios_uav_env.envs.core.stepper import choose_view
from ios_uav_env.envs.node_rows import NodeBlockRows
from ios_uav_env.envs.single_rows import SingleNodeRows

__all__ = ["UAVVectorEnv"]


class UAVVectorEnv(BatchedEnv):
    """``num_envs`` episodes of :class:`~ios_uav_env.envs.core.env.UAVEnv` in one array computation.

    Arguments: the single env's (``config``, ``view``, ``draws``, the view's own keywords,
    ``EnvOptions`` and ``ScenarioConfig`` fields) plus ``num_envs``, ``autoreset_mode``,
    ``num_threads`` (numba's threads for the kernel; None: every core) and, for the node-block
    view, ``best_schedule`` (True: ``maxmin_rate`` at each episode end, as the single env; False:
    NaN there, no LP). Observations (B, obs_dim) float32, actions (B, action_dim), rewards (B,)
    float64, ``terminated`` (B,) bool, ``truncated`` all False; no rendering.
    ``reset(seed=s)`` seeds row i with ``s + i`` (a list of B seeds works too);
    ``options={"config": cfg}`` pins every row's episode to ``cfg``, ``options={"configs":
    [cfg_0, ...]}`` row i's to ``cfg_i``. ``observation_names``: a row's, the single env's;
    ``rows``: the view's rows (the node-block view's ``max_nodes`` and ``schedules`` are theirs).
    (No attribute forwarding: a class with ``__getattr__`` makes every attribute of its instances
    slower to read, and the step reads many.)
    """

    env_class = UAVEnv

    def __init__(self, num_envs: int = 1, config: Any = None, **kwargs: Any):
        view = choose_view(kwargs.get("view"))
        # the batch's own keyword of the node-block view (its template's stays at the default)
        self.best_schedule = bool(kwargs.pop("best_schedule", True)) if view == "node_blocks" else None
        super().__init__(num_envs, config, **kwargs)

    def _init_rows(self, template: UAVEnv) -> None:
        if template.view == "node_blocks":
            self.rows: Any = NodeBlockRows(template, self.envs, self.num_threads, self.best_schedule)
        elif template.view in ("star_noma", "miso_sdma"):
            own = template.rows  # (the single env's one row: its frontier angles, score, length scale, K)
            self.rows = type(own)(self.num_envs, own.points, own.score, own.length_scale, own.k)
        else:
            self.rows = SingleNodeRows(template, self.envs, self.num_threads)
        self.info_keys = self.rows.info_keys  # (the node blocks': more with the energy objective, Rician)
        self._info_width = self.rows.info_width

    @property
    def max_nodes(self) -> int:
        """K_max of the node-block view's spaces (its rows'; ``AttributeError`` for the v0 view)."""
        return self.rows.max_nodes

    @property
    def schedules(self) -> list[np.ndarray]:
        """Each row's shares so far, (K, n + 1) arrays (the node-block view's rows')."""
        return self.rows.schedules

    @property
    def _state(self) -> np.ndarray:
        return self.rows.state

    @property
    def _path(self) -> np.ndarray:
        return self.rows.path

    # --- the hooks of BatchedEnv: the rows' ------------------------------------------
    def _load_row(self, i: int, env: Any) -> None:
        self.rows.load(i, env)

    def _start_rows(self, rows: np.ndarray) -> None:
        self.rows.start(rows, self._obs, self._info)

    def _end_rows(self, rows: np.ndarray, seeds: Any) -> None:
        self.rows.end(rows, seeds)

    def _draw_rows(self, rows: np.ndarray, seeds: Any, options: Any) -> np.ndarray:
        draw = getattr(self.rows, "draw", None)  # (the single-node rows': a randomised moving env's)
        return np.ones(len(rows), dtype=np.bool_) if draw is None else draw(rows, seeds, options)

    def _restart_rows(self, rows: np.ndarray) -> None:
        """New episodes on ``rows`` without a seed or options (autoreset, :meth:`restart`): the rows
        restart those that keep their scenario themselves, the others reset through their envs."""
        rest = self.rows.restart(rows, self._obs, self._info)
        if rest.size:
            self._reset_rows(rest, [None] * rest.size, [None] * rest.size)

    def _check_actions(self, actions: Any) -> np.ndarray:
        return self.rows.check_actions(actions)

    def _step_kernel(self, actions: np.ndarray, active: np.ndarray) -> None:
        self.rows.step(actions, active, (self._obs, self._reward, self._terminated, self._info))

    def _info_arrays(self, table: np.ndarray) -> dict[str, Any]:
        return self.rows.info_arrays(table)

    def _fly_compiled(
        self, rows: np.ndarray, targets: np.ndarray, moves: np.ndarray, obs: np.ndarray, info: np.ndarray
    ) -> bool:
        return self.rows.fly(rows, targets, moves, obs, info)
