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
    "surface_share", "separation_fraction", "feasible", "terminal_miss",
)  # fmt: skip


class FleetVectorEnv(gym.vector.VectorEnv):
    """``num_fleets`` fleets of ``ios_uav_env.parallel_env`` (same arguments) as one vector env of
    ``num_fleets`` x U rows, agent ``uav_u`` of fleet b in row ``b U + u``: its observation, its
    action, the team reward of its fleet. Autoreset is Gymnasium's ``SAME_STEP`` (what SB3 and
    array trainers expect): every fleet ends at slot N together and starts its next episode in the
    same step, ``info["final_obs"]`` / ``info["final_info"]`` holding the last ones. Fleets of
    several UAVs (U >= 2; one UAV is ``MultiNodeVectorEnv`` itself). ``num_threads``: the UAV
    rows' kernel threads (default 1: a few dozen fleets are faster on one thread than woken
    threads)."""

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

    # --- the fleets' state --------------------------------------------------------------------
    def _start(self, obs: list[np.ndarray], positions: np.ndarray) -> np.ndarray:
        """Every fleet at its starts (slot 1: equal shares, the surface shared equally)."""
        t, k_n = self.template, self.config.K
        self._q = positions
        self._moves, self._previous = 0, np.zeros(self.num_fleets)
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
        left = cfg.N - self._moves - 2  # moves left after this one
        moves, fractions = np.empty((self.num_fleets, self.uavs, 2)), np.empty((self.num_fleets, self.uavs))
        beta = np.empty((self.num_fleets, self.uavs))
        for b in range(self.num_fleets):
            moves[b], fractions[b] = guarded_moves(
                self._q[b], a[b, :, :2], t.finals, t.moves_per_slot, left, t.guard
            )
            beta[b] = surface_shares(a[b, :, -1], t.surface_sharpness)
        outs = []
        for u, rows in enumerate(self.rows):
            act = a[:, u, : 2 + t.max_nodes].copy()
            act[:, :2] = moves[:, u]
            outs.append(rows.step(act))
        done = outs[0][2]
        infos = [o[4]["final_info"] if done.all() else o[4] for o in outs]
        positions = np.stack([i["position"] for i in infos], axis=1)
        shares = np.stack([i["shares"] for i in infos], axis=1)[:, :, :k_n]
        self._served[:, :k_n] += slots_of(cfg, t.access, positions, shares, beta)
        low = self._served[:, :k_n].min(axis=1) / cfg.N
        r_rate = cfg.N * (low - self._previous)
        self._previous = low
        penalty = sum(i["reward_reach"] + i["reward_terminal"] for i in infos)
        reward = np.repeat(r_rate + penalty, self.uavs)
        obs = self._observe([o[4]["final_obs"] if done.all() else o[0] for o in outs], positions)
        info = {
            "position": positions.reshape(-1, 2), "shares": np.stack([i["shares"] for i in infos], 1).reshape(
                self.num_envs, -1), "node_rates": np.repeat(self._served / cfg.N, self.uavs, axis=0),
            "min_rate": np.repeat(low, self.uavs), "reward_rate": np.repeat(r_rate, self.uavs),
            "reward_reach": np.stack([i["reward_reach"] for i in infos], 1).reshape(-1),
            "reward_terminal": np.stack([i["reward_terminal"] for i in infos], 1).reshape(-1),
            "surface_share": beta.reshape(-1), "separation_fraction": fractions.reshape(-1),
            "feasible": np.stack([i["feasible"] for i in infos], 1).reshape(-1),
            "terminal_miss": np.stack([i["terminal_miss"] for i in infos], 1).reshape(-1),
        }  # fmt: skip
        self._moves += 1
        terminated = np.repeat(done, self.uavs)
        truncated = np.zeros(self.num_envs, dtype=np.bool_)
        if done.all():  # every fleet ends at slot N: the next episodes start now (SAME_STEP)
            final_obs, final_info = obs, info
            starts = np.broadcast_to(t.starts, (self.num_fleets, self.uavs, 2)).copy()
            obs = self._start([o[0] for o in outs], starts)
            info = {"final_obs": final_obs, "_final_obs": terminated.copy(), "final_info": final_info,
                    "_final_info": terminated.copy()}  # fmt: skip
        else:
            self._q = positions
        return obs, reward, terminated, truncated, info

    def close(self, **kwargs: Any) -> None:
        for rows in self.rows:
            rows.close()
        self.template.close()


#: The fleet's own keywords (``FleetParallelEnv``'s named parameters, not the UAV rows'); the
#: arrival guard is the fleet's too.
_OWN = frozenset(inspect.signature(FleetParallelEnv.__init__).parameters) - {"self", "config", "kwargs"}
_FLEET_KEYWORDS = _OWN | {"arrival_guard"}
