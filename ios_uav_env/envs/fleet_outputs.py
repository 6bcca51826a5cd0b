"""What the parallel fleet reports: each agent's outputs of a slot, the team's state and the
flights so far, and its rendered frame.

:class:`FleetOutputs` is a base of ``ios_uav_env.envs.fleet.FleetParallelEnv``, which sets the
attributes it reads (annotated here) in its constructor and at each reset and step: the UAVs'
rows (``uav_envs``, each a ``MultiNodeEnv``), the fleet's scenario, access and horizons, the
team's served sums and the surface's and the separation guard's shares of the slot. Its
``_team_outputs`` assembles the agents' (obs, rewards, terminations, truncations, infos) of the
UAVs' own outputs: the team reward, each agent's :data:`OWN_KEYS` and the team's rates.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np

from ios_uav_env.envs.fleet_rules import agent_observations
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.fleet import fleet_maxmin
from ios_uav_env.model.fleet_horizons import hold_flights
from ios_uav_env.model.separation import min_distance

if TYPE_CHECKING:
    from ios_uav_env.envs.multi import MultiNodeEnv

#: The info keys that are each UAV's own (the rest are the team's: ``node_rates``, ``min_rate``,
#: ``reward_rate``, ``best_schedule_rate``).
OWN_KEYS = (
    "position", "slot", "distance_to_final", "shares", "reward_reach", "reward_terminal", "feasible",
    "worst_violation", "terminal_miss",
)  # fmt: skip


class FleetOutputs:
    """The outputs of a fleet of UAV rows (a base of ``FleetParallelEnv``, which sets these attributes)."""

    uav_envs: list[MultiNodeEnv]
    config: ScenarioConfig
    access: str
    best_schedule: bool
    horizon_slots: np.ndarray
    possible_agents: list[str]
    served_at: list[int]
    team_served: np.ndarray
    surface_shares: np.ndarray
    separation_fractions: np.ndarray
    starts: np.ndarray
    finals: np.ndarray
    render_mode: str | None
    _rows: np.ndarray
    _state: np.ndarray
    _min_rate: float

    def _team_outputs(
        self, live: np.ndarray, results: list[tuple], r_rate: float
    ) -> tuple[dict, dict, dict, dict, dict]:
        """The ``live`` agents' (obs, rewards, terminations, truncations, infos) of their UAVs'
        ``results`` (each UAV env's reset or step output) and the team's rate term ``r_rate``."""
        cfg = self.config
        infos = [r[-1] for r in results]
        penalty = sum(float(i["reward_reach"]) + float(i["reward_terminal"]) for i in infos)
        reward = r_rate + penalty
        stepped = len(results[0]) == 5
        done = stepped and all(r[2] for r in results)  # the last agents leave: the episode's end
        best = 0.0
        if done and self.best_schedule:
            best = fleet_maxmin(cfg, self.trajectories, access=self.access, slots=self.horizon_slots).value
        self._rows[live] = [r[0] for r in results]
        q_live = np.array([i["position"] for i in infos])
        q = np.array([env.trajectory[-1] for env in self.uav_envs])  # a finished UAV: its final point
        q[live] = q_live
        node_rates = self.team_served / cfg.N
        self._min_rate = float(node_rates[: cfg.K].min())
        scale = self.uav_envs[0].options.length_scale
        rows = agent_observations(self._rows, node_rates, q, self.served_at, scale)
        obs, rewards, terms, truncs, out = {}, {}, {}, {}, {}
        for i, u in enumerate(live):
            agent = self.possible_agents[u]
            obs[agent] = rows[u]
            rewards[agent] = reward
            terms[agent], truncs[agent] = stepped and bool(results[i][2]), False
            info = {key: infos[i][key] for key in OWN_KEYS}
            info.update(
                node_rates=node_rates.copy(), min_rate=float(node_rates[: cfg.K].min()), reward_rate=r_rate,
                best_schedule_rate=best, surface_share=float(self.surface_shares[u]),
                separation_fraction=float(self.separation_fractions[u]), min_distance=min_distance(q_live),
            )  # fmt: skip
            out[agent] = info
        self._state = np.concatenate(rows)
        return obs, rewards, terms, truncs, out

    def render(self) -> np.ndarray | None:
        """The UAVs' flights so far over the best node's rate map, each move coloured by the node
        its UAV serves (``plotting.plot_fleet``), an (H, W, 3) uint8 array (``"rgb_array"``)."""
        if self.render_mode is None:
            gym.logger.warn('render() needs render_mode="rgb_array" at construction; returning None')
            return None
        from ios_uav_env.plotting import figure_image, plot_fleet

        def draw(ax: Any) -> None:
            flights = [env.trajectory for env in self.uav_envs]  # each UAV's own, up to its horizon
            if not len(flights[0]):  # before the first reset: the lanes
                plot_fleet(ax, self.config, np.stack([self.starts, self.finals], axis=1))
                return
            plot_fleet(ax, self.config, flights, [env.shares for env in self.uav_envs])
            slot = max(len(f) for f in flights)
            title = f"slot {slot}/{self.config.N}, team min rate so far {self._min_rate:.3f} bps/Hz"
            ax.set_title(title, fontsize=9)

        return figure_image(draw)

    def state(self) -> np.ndarray:
        """The agents' observations of the last reset or step, concatenated (for centralised critics)."""
        return self._state

    @property
    def trajectories(self) -> np.ndarray:
        """(U, n + 1, 2) m: the UAVs' way-points so far, a UAV past its horizon held at its final
        point (``model.fleet_horizons.hold_flights``; the slot counts: :attr:`horizon_slots`)."""
        flights = [env.trajectory for env in self.uav_envs]
        n = max(len(f) for f in flights)
        return hold_flights(flights, n) if n else np.zeros((len(flights), 0, 2))
