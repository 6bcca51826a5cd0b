"""B fleets of U UAVs at once, each agent a row: the fleet's batched form, for shared-parameter
learners (IPPO, and MAPPO with the fleet's ``state``) on array-based trainers.

Row ``b U + u`` is agent ``uav_u`` of fleet b. Each UAV's rows are a batched multi-node env
(``MultiNodeVectorEnv`` on its scenario, B rows), and every fleet is coupled by the rules the
parallel env applies (``envs.fleet_rules``), so fleet b is ``FleetParallelEnv`` seeded ``seed +
b`` step for step (tested bit for bit).
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ios_uav_env.envs.fleet import FleetParallelEnv
from ios_uav_env.envs.fleet_rules import agent_observations, guarded_moves, slots_of, surface_shares
from ios_uav_env.envs.multi_vector import MultiNodeVectorEnv
from ios_uav_env.model.config import SCENARIO_FIELDS, ScenarioConfig

__all__ = ["FleetVectorEnv"]

#: The keys of ``info`` (arrays over the rows; ``final_obs`` / ``final_info`` at an episode's end).
INFO_KEYS = (
    "position", "shares", "node_rates", "min_rate", "reward_rate", "reward_reach", "reward_terminal",
    "surface_share", "separation_fraction", "feasible", "terminal_miss", "active",
)  # fmt: skip


class FleetVectorEnv(gym.vector.VectorEnv):
    """``num_fleets`` fleets of ``ios_uav_env.parallel_env`` (same arguments) as one vector env of
    ``num_fleets`` x U rows, agent ``uav_u`` of fleet b in row ``b U + u``: its observation, its
    action, the team reward of its fleet. Autoreset is Gymnasium's ``SAME_STEP`` (what SB3 and
    array trainers expect): every fleet ends at the last UAV horizon together (slot N when every
    horizon is T) and starts its next episode in the same step, ``info["final_obs"]`` /
    ``info["final_info"]`` holding the last ones. Fleets of several UAVs (U >= 2; one UAV is
    ``MultiNodeVectorEnv`` itself). ``num_threads``: the UAV rows' kernel threads (default 1: a
    few dozen fleets are faster on one thread than woken threads).

    **Horizons** (``horizons``, one per UAV): the row of a UAV whose horizon comes before its
    fleet's end reports ``terminated`` True at the step it reaches its final point (its last
    observation and info under ``final_obs`` / ``final_info``, masked by ``_final_obs`` /
    ``_final_info``, beside the step's own keys), then idles until its fleet ends: its last
    observation (the team's served rates and the others' positions updated), reward 0,
    ``terminated`` False, ``info["active"]`` False (its action is ignored, it serves nothing and
    is not guarded). When the fleet ends every row terminates, an idle row's zero-return stretch
    included, and every row starts the next episode in the same step, as with equal horizons."""

    metadata = {
        "autoreset_mode": getattr(getattr(gym.vector, "AutoresetMode", None), "SAME_STEP", "same_step")
    }

    def __init__(
        self,
        num_fleets: int = 1,
        config: ScenarioConfig | Mapping[str, Any] | None = None,
        *,
        num_threads: int | None = 1,
        **kwargs: Any,
    ) -> None:
        if isinstance(num_fleets, bool) or not isinstance(num_fleets, (int, np.integer)) or num_fleets < 1:
            raise ValueError(f"num_fleets must be an integer >= 1, got {num_fleets!r}")
        kwargs.setdefault("best_schedule", False)
        if kwargs["best_schedule"]:
            raise ValueError(
                "best_schedule=True: the batched fleets skip the episode-end schedule (score the flights "
                "with model.fleet.fleet_maxmin)"
            )
        self.template = FleetParallelEnv(config, **kwargs)  # the arguments' checks, the spaces and the rules
        t = self.template
        if len(t.uav_envs) < 2:
            raise ValueError("FleetVectorEnv takes uavs >= 2 (one UAV: MultiNodeVectorEnv on its scenario)")
        self.num_fleets, self.uavs = int(num_fleets), len(t.uav_envs)
        self.num_envs = self.num_fleets * self.uavs
        self.config = t.config
        inner = {k: v for k, v in kwargs.items() if k not in _FLEET_KEYWORDS and k not in SCENARIO_FIELDS}
        self.rows = [
            MultiNodeVectorEnv(
                self.num_fleets,
                env.config,
                autoreset_mode="same_step",
                best_schedule=False,
                arrival_guard=False,
                **inner,
            )  # fmt: skip
            for env in t.uav_envs
        ]
        boxes = [t.observation_space(a) for a in t.possible_agents]
        low = np.min([b.low for b in boxes], axis=0)
        high = np.max([b.high for b in boxes], axis=0)
        self.single_observation_space = spaces.Box(low, high, dtype=np.float32)
        self.single_action_space = t.action_space(t.possible_agents[0])
        self.observation_space = gym.vector.utils.batch_space(self.single_observation_space, self.num_envs)
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, self.num_envs)
        k = t.max_nodes
        self._served = np.zeros((self.num_fleets, k))
        self._previous = np.zeros(self.num_fleets)
        self._q = np.zeros((self.num_fleets, self.uavs, 2))
        self._moves = 0
        #: Each UAV's rows' last observations (a row past its horizon: its last, held).
        self._rows_obs: list[np.ndarray] = []
        #: Each UAV's rows' first observations of the next episode (its rows restart at its horizon).
        self._first: list[np.ndarray] = [np.empty(0)] * self.uavs
        #: Each UAV's rows' ``feasible`` and ``terminal_miss`` as last reported (held past its horizon).
        self._held: list[dict[str, np.ndarray]] = [{} for _ in range(self.uavs)]

    # --- the fleets' state --------------------------------------------------------------------
    def _start(self, obs: list[np.ndarray], positions: np.ndarray) -> np.ndarray:
        """Every fleet at its starts (slot 1: equal shares, the surface shared equally)."""
        t, k_n = self.template, self.config.K
        self._q = positions
        self._moves, self._previous = 0, np.zeros(self.num_fleets)
        self._rows_obs = list(obs)
        self._served[:] = 0.0
        shares = np.full((self.uavs, k_n), 1.0 / k_n)
        beta = np.full(self.uavs, 1.0 / self.uavs)
        many = (self.num_fleets, self.uavs)
        self._served[:, :k_n] += slots_of(
            self.config,
            t.access,
            positions,
            np.broadcast_to(shares, (*many, k_n)),
            np.broadcast_to(beta, many),
        )
        return self._observe(obs, positions)

    def _observe(self, obs: list[np.ndarray], positions: np.ndarray) -> np.ndarray:
        t = self.template
        scale = t.uav_envs[0].options.length_scale
        rows = [
            agent_observations(
                np.stack([o[b] for o in obs]),
                self._served[b] / self.config.N,
                positions[b],
                t.served_at,
                scale,
            )  # fmt: skip
            for b in range(self.num_fleets)
        ]
        return np.concatenate(rows)

    # --- API ------------------------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict]:
        if options:
            raise ValueError(f"options: the batched fleets take none, got {options!r}")
        obs = []
        for u, rows in enumerate(self.rows):
            seeds = None if seed is None else [seed + b + u for b in range(self.num_fleets)]
            obs.append(rows.reset(seed=seeds)[0])
        starts = np.broadcast_to(self.template.starts, (self.num_fleets, self.uavs, 2)).copy()
        return self._start(obs, starts), {}

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        t, cfg, k_n = self.template, self.config, self.config.K
        a = np.asarray(actions, dtype=np.float64)
        if a.shape != self.action_space.shape or not np.isfinite(a).all():
            raise ValueError(
                f"actions must be a finite array of shape {self.action_space.shape}, got shape {a.shape}"
            )
        a = a.reshape(self.num_fleets, self.uavs, -1)
        slots = t.horizon_slots
        live = np.flatnonzero(slots > self._moves + 1)  # the UAVs flying the move into the next slot
        ends = slots[live] == self._moves + 2  # ... of which those whose horizon this slot is
        left = slots[live] - self._moves - 2  # each one's moves left after this one
        b_n, u_n = self.num_fleets, self.uavs
        moves, fractions = np.zeros((b_n, u_n, 2)), np.ones((b_n, u_n))
        beta = np.zeros((b_n, u_n))  # a UAV past its horizon takes no share of the surface
        for b in range(b_n):
            moves[b, live], fractions[b, live] = guarded_moves(
                self._q[b, live], a[b, live, :2], t.finals[live], t.moves_per_slot[live], left, t.guard
            )
            beta[b, live] = surface_shares(a[b, live, -1], t.surface_sharpness)
        infos = {}
        for u, ended in zip(live, ends, strict=True):
            act = a[:, u, : 2 + t.max_nodes].copy()
            act[:, :2] = moves[:, u]
            row_obs, _, done, _, row_info = self.rows[u].step(act)
            if ended != bool(done.all()):  # (the rows end at their own N_u, as the fleet counts)
                raise RuntimeError(f"uav_{u}'s rows and the fleet disagree on its horizon")
            if ended:  # its rows restarted (same step): their next episode's first observations
                self._first[u], row_obs, row_info = row_obs, row_info["final_obs"], row_info["final_info"]
            self._rows_obs[u], infos[u] = row_obs, row_info
            self._q[:, u] = row_info["position"]
        positions = self._q.copy()
        shares = np.stack([infos[u]["shares"] for u in live], axis=1)[:, :, :k_n]
        self._served[:, :k_n] += slots_of(cfg, t.access, positions[:, live], shares, beta[:, live])
        low = self._served[:, :k_n].min(axis=1) / cfg.N
        r_rate = cfg.N * (low - self._previous)
        self._previous = low
        penalty = sum(infos[u]["reward_reach"] + infos[u]["reward_terminal"] for u in live)
        active = np.zeros((b_n, u_n), dtype=np.bool_)
        active[:, live] = True
        reward = np.where(active, (r_rate + penalty)[:, None], 0.0).reshape(-1)
        obs = self._observe(self._rows_obs, positions)
        info = self._info(infos, positions, active, low, r_rate, beta, fractions)
        self._moves += 1
        ended_rows = np.zeros((b_n, u_n), dtype=np.bool_)
        ended_rows[:, live[ends]] = True
        truncated = np.zeros(self.num_envs, dtype=np.bool_)
        if self._moves == slots.max() - 1:  # every UAV's horizon is over: the next episodes start now
            terminated = np.ones(self.num_envs, dtype=np.bool_)  # (an idle row's zero-return stretch too)
            starts = np.broadcast_to(t.starts, (b_n, u_n, 2)).copy()
            final_obs, final_info = obs, info
            obs = self._start(list(self._first), starts)
            info = {"final_obs": final_obs, "_final_obs": terminated.copy(), "final_info": final_info,
                    "_final_info": terminated.copy()}  # fmt: skip
        else:
            terminated = ended_rows.reshape(-1)
            if terminated.any():  # agents leaving at their horizon: their rows idle from now on
                info.update(final_obs=obs.copy(), _final_obs=terminated.copy(), final_info=dict(info),
                            _final_info=terminated.copy())  # fmt: skip
        return obs, reward, terminated, truncated, info

    def _info(
        self,
        infos: dict[int, dict[str, Any]],
        positions: np.ndarray,
        active: np.ndarray,
        low: np.ndarray,
        r_rate: np.ndarray,
        beta: np.ndarray,
        fractions: np.ndarray,
    ) -> dict[str, Any]:
        """The step's ``info`` arrays over the rows: the UAVs' own from their rows' ``infos`` (a row
        past its horizon: its final point, no shares, no reward terms, its feasibility and miss as
        at its end), the team's repeated over its fleet's rows."""
        b_n, u_n, width = self.num_fleets, self.uavs, self.template.max_nodes
        for u, row_info in infos.items():
            self._held[u] = {key: row_info[key] for key in ("feasible", "terminal_miss")}

        def own(key: str, idle: Any) -> np.ndarray:
            return np.stack(
                [infos[u][key] if u in infos else np.full(b_n, idle) for u in range(u_n)], axis=1
            ).reshape(-1)

        idle_shares = np.zeros((b_n, width))
        shares = np.stack([infos[u]["shares"] if u in infos else idle_shares for u in range(u_n)], axis=1)
        return {
            "position": positions.reshape(-1, 2), "shares": shares.reshape(self.num_envs, -1),
            "node_rates": np.repeat(self._served / self.config.N, u_n, axis=0),
            "min_rate": np.repeat(low, u_n), "reward_rate": np.repeat(r_rate, u_n),
            "reward_reach": own("reward_reach", 0.0), "reward_terminal": own("reward_terminal", 0.0),
            "surface_share": beta.reshape(-1), "separation_fraction": fractions.reshape(-1),
            "feasible": np.stack([self._held[u]["feasible"] for u in range(u_n)], 1).reshape(-1),
            "terminal_miss": np.stack([self._held[u]["terminal_miss"] for u in range(u_n)], 1).reshape(-1),
            "active": active.reshape(-1),
        }  # fmt: skip

    def close(self, **kwargs: Any) -> None:
        for rows in self.rows:
            rows.close()
        self.template.close()


#: The fleet's own keywords (``FleetParallelEnv``'s named parameters, not the UAV rows'); the
#: arrival guard is the fleet's too.
_OWN = frozenset(inspect.signature(FleetParallelEnv.__init__).parameters) - {"self", "config", "kwargs"}
_FLEET_KEYWORDS = _OWN | {"arrival_guard"}
