"""Several UAVs on PettingZoo's Parallel API: one surface, K ground nodes, a team objective.

:class:`FleetParallelEnv` (made by ``ios_uav_env.parallel_env``) flies U UAVs, agents
``uav_0 .. uav_{U-1}``, over the same N slots of one scenario: each UAV is a row of the multi-node
env (``MultiNodeEnv`` on the scenario with that UAV's start and final point: its move, arrival
guard, node shares, propulsion and observation), and the fleet couples them through the nodes'
service and the surface (``ios_uav_env.model.fleet``) and through the separation guard
(``ios_uav_env.model.separation``). With U = 1 the env is ``MultiNodeEnv`` itself, step for step
(tested bit for bit). What it reports (each agent's outputs of a slot, ``state()``, the flights
so far, the rendered frame) is its base ``ios_uav_env.envs.fleet_outputs.FleetOutputs``'.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium import spaces

from ios_uav_env.components.base import finite_number
from ios_uav_env.envs.fleet_outputs import OWN_KEYS, FleetOutputs  # noqa: F401 (OWN_KEYS re-exported)
from ios_uav_env.envs.fleet_rules import (
    check_team_world,
    guard_distance,
    guarded_moves,
    slots_of,
    surface_shares,
)
from ios_uav_env.envs.multi import MultiNodeEnv
from ios_uav_env.envs.observation import pad
from ios_uav_env.model.config import SCENARIO_FIELDS, ScenarioConfig, as_config
from ios_uav_env.model.fleet import fleet_setup
from ios_uav_env.model.fleet_horizons import horizon_slots
from ios_uav_env.model.scenarios import DEFAULT_NODES
from ios_uav_env.model.separation import DEFAULT_SEPARATION

try:
    from pettingzoo import ParallelEnv
except ImportError as exc:  # pragma: no cover - exercised in an env without the extra
    raise ImportError(
        "ios_uav_env.parallel_env needs PettingZoo: pip install 'ios-uav-env[marl]' (pettingzoo>=1.24)"
    ) from exc

__all__ = ["FleetParallelEnv"]


class FleetParallelEnv(FleetOutputs, ParallelEnv):
    """U UAVs serving K ground nodes through one IOS, as a PettingZoo ``ParallelEnv``.

    ## Description

    UAV u flies from ``starts[u]`` to ``finals[u]`` in the scenario's N slots (its speed limit D
    per slot, its arrival guard) and transmits in a band of its own (``access="orthogonal"``: no
    interference) or in one band with the others (``"shared"``: the other UAVs' signals are
    interference at the nodes, ``model.fleet``). Each slot it shares its time between the nodes
    (softmax of its node scores, as in ``MultiNodeEnv``), and the surface shares its alignment
    between the UAVs (softmax of ``surface_sharpness`` x their surface bids): while it serves UAV
    u it is lined up with the node u serves, and every other UAV sees misaligned phases
    (``ios_uav_env.model.fleet.slot_service``, ``shared_slot_service``). The team's objective is
    the nodes' max-min rate over the flight, the rates summed over the UAVs.

    ## Action Space

    Per agent, ``Box(-1, 1, (2 + K_max + 1,))``: the move / D (projected on the unit disk), one
    score per node slot, and the surface bid. With U = 1 there is no bid (``MultiNodeEnv``'s
    action, ``(2 + K_max,)``).

    ## Observation Space

    Per agent, ``MultiNodeEnv``'s observation of its own UAV (``observation_names``), with each
    node block's ``served`` the team's served rate so far / N, then for each other UAV v (in
    agent order) its position relative to this one, (q_v - q_u) / L (``dx_uav_<v>``,
    ``dy_uav_<v>``). ``state()``: the agents' observations, concatenated.

    ## Rewards

    Every agent gets the team reward: N x the change of min_k (served_k / N) (as
    ``MultiNodeEnv`` with ``softmin_beta`` = 0) plus every UAV's reach and terminal terms.

    ## Separation

    No two UAVs come closer than ``min_separation`` m, between way-points included, whatever the
    actions: a pair that would meet flies up to its contact, the other UAVs fly on
    (``model.separation``; each agent's ``separation_fraction`` is the share of its move it flew).
    A pair in contact that keeps pushing together stays put, so the agents have to go round each
    other; a UAV held back may miss its final point (``terminal_miss``, penalised).

    ## Horizons

    ``horizons`` (s, one per UAV; default every UAV the scenario's T): UAV u flies the slots 0 ..
    N_u - 1 (N_u = its horizon / dt, its row a ``MultiNodeEnv`` with that T) and its arrival
    guard brings it to its final point by its horizon. It then leaves: its agent terminates with
    that step's team reward and leaves ``env.agents``; from then on it serves no node, takes no
    share of the surface, causes no interference and is not guarded against. The rates are still
    averaged over the scenario's N slots. :attr:`trajectories` holds it at its final point after
    its horizon (``model.fleet_horizons``); the others still observe that point, and ``state()``
    keeps its last row (the team's rates and the others' positions updated).

    ## Episode End

    Every agent terminates after its last slot, N_u (slot N when every horizon is T); the episode
    ends when the last one does. ``info``'s ``best_schedule_rate`` is then the flown
    trajectories' best schedule (``fleet_maxmin`` with the UAVs' slot counts; bps/Hz; 0 before),
    at least the team's ``min_rate``: the gap says how much better the same flights could have
    shared the time (in a shared band the best schedule may also keep a UAV silent, which the
    actions cannot).

    ## Arguments

    ``config`` (K ground nodes; default ``MultiNodeEnv``'s three), ``uavs`` (U >= 1, default 2),
    ``starts`` / ``finals`` ((U, 2) m; default ``model.fleet.default_lanes``), ``min_separation``
    (m, default ``model.separation.DEFAULT_SEPARATION``), ``surface_sharpness`` (> 0), ``access``,
    ``speeds`` ((U,) m/s, each UAV's speed limit; default the scenario's ``v_max``), ``horizons``
    ((U,) s, each UAV's horizon, a multiple of dt within [2 dt, T]; default the scenario's T; one
    UAV flies T), ``best_schedule`` (compute the episode-end schedule, default True), and ``MultiNodeEnv``'s
    keywords (``share_sharpness``, ``max_nodes``, the env options); a ``ScenarioConfig`` field
    as a keyword changes the fleet's scenario (every UAV's). The fleet's arguments are checked by
    ``model.fleet.fleet_setup``. With U >= 2 the nodes are static and exactly known, the channel
    is ``"expected"`` and the objective is the rate (refused otherwise, naming the field);
    ``reset(options={"config": ...})`` is ``MultiNodeEnv``'s with U = 1 and refused with more
    (other keys are ignored: PettingZoo's API test passes some).
    """

    metadata = {"name": "ios_uav_fleet_v0", "render_modes": ["rgb_array"], "is_parallelizable": True}

    def __init__(
        self,
        config: ScenarioConfig | Mapping[str, Any] | None = None,
        *,
        uavs: int = 2,
        starts: Any = None,
        finals: Any = None,
        min_separation: float = DEFAULT_SEPARATION,
        surface_sharpness: float = 5.0,
        access: str = "orthogonal",
        speeds: Any = None,
        horizons: Any = None,
        best_schedule: bool = True,
        render_mode: str | None = None,
        **kwargs: Any,
    ) -> None:
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.render_mode = render_mode
        surface_sharpness = finite_number(
            surface_sharpness, "surface_sharpness", positive=True, unit="the bids' softmax scale"
        )
        base = as_config(config if config is not None else ScenarioConfig(ground_nodes=DEFAULT_NODES))
        overrides = {name: kwargs.pop(name) for name in list(kwargs) if name in SCENARIO_FIELDS}
        base = base.replace(**overrides) if overrides else base  # the fleet's scenario, and each UAV's
        self.starts, self.finals, configs = fleet_setup(
            base, uavs, starts, finals, min_separation, access, speeds, horizons
        )
        #: Each UAV's slot count N_u (its horizon / dt; ``model.fleet_horizons``).
        self.horizon_slots = horizon_slots(configs)
        if len(configs) == 1 and self.horizon_slots[0] < base.N:
            raise ValueError(
                f"horizons: one UAV flies the scenario's T = {base.T:g} s (give it T={configs[0].T:g} "
                "for a shorter flight)"
            )
        #: m: each UAV's largest move per slot (its speed limit x dt).
        self.moves_per_slot = np.array([c.D for c in configs])
        self.access, self.min_separation = access, float(min_separation)
        u_n = len(configs)
        #: m: the distance the separation guard keeps (``model.separation.guard_distance``; 0 for one UAV).
        self.guard = guard_distance(self.min_separation) if u_n > 1 else 0.0
        if u_n > 1:
            check_team_world(base, kwargs)
            # the fleet guards the moves (both guards) and scores the flights (fleet_maxmin)
            kwargs = {**kwargs, "arrival_guard": False, "best_schedule": False}
        self.surface_sharpness = float(surface_sharpness)
        self.best_schedule = bool(best_schedule)
        self.config = base
        self.uav_envs: list[MultiNodeEnv] = [MultiNodeEnv(cfg, **kwargs) for cfg in configs]
        self.possible_agents = [f"uav_{u}" for u in range(u_n)]
        self.agents: list[str] = []
        first = self.uav_envs[0]
        self.max_nodes = first.max_nodes
        #: The observation's columns of the node blocks' ``served`` (the team's, with several UAVs).
        self.served_at = [first.observation_names.index(f"served_{k}") for k in range(self.max_nodes)]
        self.observation_spaces = {a: self._observation_space(u) for u, a in enumerate(self.possible_agents)}
        width = 2 + self.max_nodes + (1 if u_n > 1 else 0)
        self.action_spaces = {a: spaces.Box(-1.0, 1.0, (width,), np.float32) for a in self.possible_agents}
        self.team_served = np.zeros(self.max_nodes)
        self.surface_shares = np.ones(u_n) / u_n
        #: Each UAV's fraction of its last move the separation guard let it fly (1: all of it).
        self.separation_fractions = np.ones(u_n)
        spaces_ = [self.observation_spaces[a] for a in self.possible_agents]
        #: The space of :meth:`state`: the agents' observation spaces, concatenated.
        self.state_space = spaces.Box(
            np.concatenate([b.low for b in spaces_]),
            np.concatenate([b.high for b in spaces_]),
            dtype=np.float32,
        )
        self._state = np.zeros(self.state_space.shape, dtype=np.float32)
        self._min_rate = 0.0  # the team's min rate so far (render's title)

    # --- construction -----------------------------------------------------------------------
    def _observation_space(self, u: int) -> spaces.Box:
        space = self.uav_envs[u].observation_space
        if len(self.uav_envs) == 1:
            return space
        low, high = space.low.astype(np.float64), space.high.astype(np.float64)
        high[self.served_at] *= len(self.uav_envs)  # the team's served rates: at most U x one UAV's
        cfg, scale = self.config, self.uav_envs[u].options.length_scale
        reach = (cfg.N - 1) * float(self.moves_per_slot.max())
        for v in range(len(self.uav_envs)):
            if v != u:
                far = pad((float(np.abs(self.starts[v] - self.starts[u]).max()) + 2.0 * reach) / scale)
                low, high = np.append(low, [-far, -far]), np.append(high, [far, far])
        return spaces.Box(low.astype(np.float32), high.astype(np.float32), dtype=np.float32)

    def observation_space(self, agent: str) -> spaces.Box:
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Box:
        return self.action_spaces[agent]

    @property
    def observation_names(self) -> tuple[str, ...]:
        """uav_0's observation components, in order (each agent's: ``dx_uav_<v>`` for its others)."""
        names = self.uav_envs[0].observation_names
        others = [f"{c}_uav_{v}" for v in range(1, len(self.uav_envs)) for c in ("dx", "dy")]
        return names + tuple(others)

    # --- API ---------------------------------------------------------------------------------
    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        pinned = {"config": options["config"]} if options and "config" in options else None
        if len(self.uav_envs) == 1:  # MultiNodeEnv's reset with its pinned scenario, if any
            obs, info = self.uav_envs[0].reset(seed=seed, options=pinned)
            self.agents = list(self.possible_agents)
            self._min_rate = float(info["min_rate"])
            self._state = obs.copy()
            return {self.agents[0]: obs}, {self.agents[0]: info}
        if pinned is not None:
            raise ValueError(
                'options["config"]: several UAVs fly the fleet\'s scenario; make a fleet on another '
                "with parallel_env(config)"
            )
        self.agents = list(self.possible_agents)
        results = [env.reset(seed=None if seed is None else seed + u) for u, env in enumerate(self.uav_envs)]
        u_n, k_n = len(self.uav_envs), self.config.K
        self._slot = 0
        self._rows = np.array([r[0] for r in results])
        self.team_served = np.zeros(self.max_nodes)
        shares = np.full((u_n, k_n), 1.0 / k_n)  # slot 1: equal shares, as each row
        self.surface_shares = np.ones(u_n) / u_n
        self.separation_fractions = np.ones(u_n)
        live = np.arange(u_n)
        self._serve(live, shares)
        self._previous = 0.0  # the potential before slot 1, as MultiNodeEnv's: the return is N x min rate
        return self._team_outputs(live, results, 0.0)[0::4]  # (obs, infos)

    def step(self, actions: Mapping[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        if not self.agents:
            raise RuntimeError("the episode is over (or was never started): call reset()")
        acts = self._check_actions(actions)
        if len(self.uav_envs) == 1:
            obs, reward, term, trunc, info = self.uav_envs[0].step(acts[0])
            agent = self.agents[0]
            self._min_rate = float(info["min_rate"])
            self._state = obs.copy()
            if term or trunc:
                self.agents = []
            return {agent: obs}, {agent: reward}, {agent: term}, {agent: trunc}, {agent: info}
        live = np.array([self.possible_agents.index(a) for a in self.agents])  # the UAVs still flying
        moves = self._guarded_moves(live, acts)
        results = []
        for i, u in enumerate(live):
            a = acts[i, : 2 + self.max_nodes].copy()
            a[:2] = moves[i]
            results.append(self.uav_envs[u].step(a))
        self.surface_shares = np.zeros(len(self.uav_envs))  # a UAV past its horizon takes none
        self.surface_shares[live] = surface_shares(acts[:, -1], self.surface_sharpness)
        self._slot += 1
        k_n = self.config.K
        self._serve(live, np.array([self.uav_envs[u].shares[:, -1] for u in live]))
        low = self.team_served[:k_n].min() / self.config.N
        r_rate = self.config.N * (low - self._previous)
        self._previous = low
        out = self._team_outputs(live, results, r_rate)
        # an agent leaves at its horizon (its row's last slot): its termination is reported now
        self.agents = [self.possible_agents[u] for u, r in zip(live, results, strict=True) if not r[2]]
        return out

    def _check_actions(self, actions: Mapping[str, Any]) -> np.ndarray:
        if not isinstance(actions, Mapping) or set(actions) != set(self.agents):
            got = sorted(actions) if isinstance(actions, Mapping) else type(actions).__name__
            raise ValueError(f"actions must map each live agent {self.agents} to an action, got {got}")
        width = self.action_spaces[self.agents[0]].shape[0]
        out = np.empty((len(self.agents), width))
        for u, agent in enumerate(self.agents):
            a = np.asarray(actions[agent], dtype=np.float64)
            if a.shape != (width,):
                raise ValueError(f"actions[{agent!r}] must have shape ({width},), got {a.shape}")
            if not np.isfinite(a).all():
                raise ValueError(f"actions[{agent!r}] must be finite (no NaN or inf), got {actions[agent]!r}")
            out[u] = a
        return out

    def _guarded_moves(self, live: np.ndarray, acts: np.ndarray) -> np.ndarray:
        """(len(live), 2): the ``live`` UAVs' moves / D after their unit-disk projection, their
        arrival guards (each to its own horizon) and the separation guard between them
        (``model.separation.guarded_moves``)."""
        q = np.array([self.uav_envs[u].trajectory[-1] for u in live])
        left = self.horizon_slots[live] - self._slot - 2  # each UAV's moves left after this one
        moves, fractions = guarded_moves(
            q, acts[:, :2], self.finals[live], self.moves_per_slot[live], left, self.guard
        )
        self.separation_fractions = np.ones(len(self.uav_envs))
        self.separation_fractions[live] = fractions
        return moves

    def _serve(self, live: np.ndarray, shares: np.ndarray) -> None:
        """Add the slot's service of the nodes by the ``live`` UAVs with their node ``shares``
        (``fleet_rules.slots_of``) to the team's served sums, the slot's link gains kept in the
        model's per-slot cache for the episode end's best schedule (and any later scoring)."""
        k_n = self.config.K
        q = np.array([self.uav_envs[u].trajectory[-1] for u in live])
        beta = self.surface_shares[live]
        slot = slots_of(self.config, self.access, q[None], shares[None, :, :k_n], beta[None], cache=True)
        self.team_served[:k_n] += slot[0]

    def close(self) -> None:
        for env in self.uav_envs:
            env.close()
