"""Several ground nodes: an env where the agent flies the UAV and schedules the nodes (TDMA).

``MultiNodeEnv`` (ids ``ios_uav_env/IOSUAV-MultiNode-v0`` and ``-Random-v0``) follows the
model of ``ios_uav_env.model.schedule``: node k's rate in slot n is the single-node expected-gain
rate r_k(q[n]) (``config.node_config(k)``), slot n is shared by TDMA shares alpha_k[n] and
the objective is min_k R_k, R_k = (1/N) sum_n alpha_k[n] r_k(q[n]). The agent chooses the
shares itself; the episode's score is its own ``min_k R_k`` (``scheduled_rates``), never
above the trajectory's best-schedule score (``maxmin_rate``), which the last step reports
beside it. Movement, the arrival guard and the feasibility shaping are the single env's. The
transition is the kernel of ``ios_uav_env.envs.multi_kernels`` on a batch of one, the one that
``MultiNodeVectorEnv`` runs on B rows. The energy objective and the Rician channel: the class
docstring and ``ios_uav_env.envs.multi_energy``.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ios_uav_env.envs.knowledge import NodesTrack
from ios_uav_env.envs.multi_energy import ENERGY_NAMES, EnergyChannel, check_options
from ios_uav_env.envs.multi_features import (
    BASE_FEATURES,
    DEFAULT_NODES,
    NODE_FEATURES,
    NODE_PEAK_FEATURES,
    rate_potential,
    share_scores,
)
from ios_uav_env.envs.multi_kernels import NodeRows, track_kernels
from ios_uav_env.envs.multi_mobile import MobileNodes
from ios_uav_env.envs.multi_space import multinode_bounds, rate_high
from ios_uav_env.envs.multi_table import (
    BEST,
    MULTI_INFO_KEYS,
    info_arrays,
    info_columns,
    info_keys,
    node_peaks,
)
from ios_uav_env.envs.observation_layout import node_block_names
from ios_uav_env.envs.options import EnvOptions, split_kwargs
from ios_uav_env.envs.settings import (
    check_config_keywords,
    check_multinode_arguments,
    check_scenario_overrides,
    check_world,
    multinode_id,
    multinode_objective,
)
from ios_uav_env.model.config import ScenarioConfig, as_config, scenario_option
from ios_uav_env.model.scenarios import MULTINODE_RANGES, RANGED_FIELDS, ScenarioRanges, sample_multinode
from ios_uav_env.model.schedule import reported_maxmin_rate

__all__ = [
    "BASE_FEATURES", "DEFAULT_NODES", "MULTINODE_RANGES", "MULTI_INFO_KEYS", "NODE_FEATURES",
    "NODE_PEAK_FEATURES", "MultiNodeEnv", "node_peaks", "rate_potential", "sample_multinode", "share_scores",
]  # fmt: skip


class MultiNodeEnv(MobileNodes, EnergyChannel, gym.Env):
    r"""A UAV flies from ``q0`` to ``qF`` and shares every slot between K ground nodes (TDMA).

    ## Description

    K ground nodes around an IOS; the UAV must serve every one of them: the objective is the
    minimum over nodes of the average rate each node receives, with time-division shares
    chosen per slot (max-min fairness; the model of ``ios_uav_env.model.schedule``). The agent
    decides where to fly and whom to serve when. Ids: ``ios_uav_env/IOSUAV-MultiNode-v0``
    (the 3 nodes of ``DEFAULT_NODES``), ``ios_uav_env/IOSUAV-MultiNode-Random-v0`` (2 to 4
    nodes drawn at every reset: ``sample_multinode`` over ``MULTINODE_RANGES``) and
    ``ios_uav_env/IOSUAV-MultiNode-Mobile-v0`` (the same draws, the nodes walking and reported:
    Moving nodes below). Each id takes ``objective="energy_efficiency"`` (the worst node's bits
    per joule: Energy below) and ``channel="rician"`` (faded rates: Rician channel below).

    ## Action Space

    ``Box(-1, 1, (2 + K_max,), float32)``: the move of the slot in units of D (projected onto
    the unit disk, then by the arrival guard, as in ``IOSUAVEnv``), then one score per node;
    the shares of the new slot are the softmax of ``share_sharpness`` x the scores of the
    scenario's K nodes, each clipped to the space's [-1, 1] (padding entries are ignored), so
    they are >= 0 and sum to 1 for any finite action. Slot 1 (q0, before any action) is
    shared equally.

    ## Observation Space

    A float32 array of 12 + 6 K_max components: ``BASE_FEATURES`` (the UAV q / L, qF and the
    IOS centre relative to it, the time left, the slack to still reach qF, M / 6000, IOS and
    RIS flags, T / 200 s), then per node slot k ``NODE_FEATURES``: mask (1 for a node of the
    scenario, 0 for padding, whose other entries are 0), (w_k - q) / L, the node's side of the
    IOS plane (+1 at x > x_c, -1 otherwise), the rate served to it so far
    S_k / N with S_k = sum_{m <= n} alpha_k[m] r_k(q[m]) (bps/Hz), and its rate r_k(q) now.
    With ``peak_hint=True`` each node block has 3 more (``NODE_PEAK_FEATURES``, 12 + 9 K_max in
    all): the node's own reachable rate peak P_k (``rate_peak`` of ``config.node_config(k)``,
    the single-node hint) relative to the UAV, (P_k - q) / L, and r_k(P_k). It says where each
    node alone is best served, not the order of the visits, the hover times or the shares.
    The bounds hold for every scenario of the family (lengths: the largest value at q0 plus
    (N_max - 1) D / L, and 2 (N_max - 1) D / L for P_k - q, both within (N_max - 1) D of q0;
    rates: ``ground_free_rate_bound``). ``env.unwrapped.observation_names`` holds the names of
    the components, in order: ``BASE_FEATURES``, then ``<feature>_<k>`` for node slot k (unless
    the knowledge is exact, ``served_measured_<k>`` and ``measured_rate_<k>``; with ``"rates"``
    ``dx_node_hidden_<k>`` and ``dy_node_hidden_<k>``), then with the energy objective the 4
    energy features of the single env (``ENERGY_NAMES``, after the node blocks, whose offsets
    stay 12 + width k): the last move (q[n] - q[n-1]) / D (0 at the start), the energy weight
    w = lambda_ref P(0) / B (bps/Hz) and the minimum-power move V_mp dt / D. With channel
    "rician" the served features are sums of faded rates, clipped in the observation at the rate
    bound plus ``knowledge.FADE_MARGIN`` (the clip of measured rates, which a faded sample
    rarely reaches, and S_k / N never exceeds the largest sample); the rate features stay the
    expected-gain r_k(q).

    ## Rewards

    With m_n = min_k S_k / N after slot n (m before slot 1 = 0) the rate term of the step that
    ends at slot n is N (m_n - m_{n-1}), so the return is N min_k R_k: the agent's own score
    times the fixed N, plus the single env's reach and terminal penalties (0 for a feasible
    trajectory; with the guard, always 0).

    With ``softmin_beta`` = beta > 0 the rate term is potential-based shaping of the same
    return: N (Phi_n - Phi_{n-1}) with Phi_n the soft minimum of the S_k / N
    (``rate_potential``; Phi before slot 1 = 0), and the last step adds N (m_N - Phi_N) <= 0.
    The terms still sum to N min_k R_k exactly, but every slot's service now earns a reward
    weighted towards the nodes served least so far (a denser signal for learning whom to serve
    and where to fly); the last step's correction is 0 when the nodes end equally served and
    never below -N log(K) / beta.

    ## Energy

    With ``objective="energy_efficiency"`` (``score_plan``'s EE = B T min_k R_k / E, the worst
    node's bits per joule of propulsion energy) each step also adds

        reward_energy = -(lambda_ref / B) P(V_n)   (bps/Hz)

    as the single env does (``IOSUAVEnv``, "Energy"), so with the guard the return is
    (bits - lambda_ref E) / (B dt), bits = B T min_k R_k of the agent's own shares (no start
    term: slot 1's service is in the first step's rate term): an increasing affine function of
    Dinkelbach's G = bits - lambda_ref E, whose maximisers have an EE of at least lambda_ref
    when lambda_ref <= EE*. lambda_ref is ``energy_reference`` (bits/J) when given, else the
    better EE of two flights with their best schedules, the straight flight q0 -> qF at one
    constant speed (unless it exceeds ``energy_budget_j``) and the least-energy flight (equal
    moves at the speed of ``config.least_energy()``) (``multi_energy.reference_efficiency``,
    computed at reset; for moving nodes scored on the episode's true paths, while the
    observation's energy weight keeps the configured nodes' value): feasible plans, so
    lambda_ref <= EE*. ``env.unwrapped.reference_efficiency`` holds it. The episode's score is
    ``info["energy_efficiency"]`` at slot N.

    ## Rician channel

    With ``channel="rician"`` each slot draws two standard normals per node from ``np_random``
    (the reset's slot 1, after the scenario's and the paths' draws, then every step's; (K, 2) at
    a time) and node k is served its faded rate log2(1 + eta |h_k|^2) of the slot
    (``channel.faded_point``; Rician factor ``kappa``): the served S_k, ``node_rates``,
    ``min_rate`` and the rate term are the faded rates the agent actually got. The score stays
    the expected-gain one, as the single env's ``average_rate``: ``info`` adds
    ``expected_node_rates`` (K_max, sum_m alpha_k[m] r_k(q[m]) / N) and ``expected_min_rate``
    (at slot N ``score_plan(config, q, shares).rate``); ``best_schedule_rate`` and the EE are
    taken on the expected-gain rates too. It needs ``knowledge="exact"`` (measured rates are
    faded samples already).

    ## Moving nodes

    With a motion model (``motion``, applied to the drawn scenarios too) or ``knowledge`` other
    than ``"exact"`` the env is *mobile* (``ios_uav_env.envs.multi_mobile``): each reset draws
    every node's path w_k[1..N] from ``np_random``, and slot n's rates, the served rates, the
    reward and the score are those at the true positions (``score_plan(config, q, shares,
    paths=env.paths)``). What a node block tells: with ``"exact"`` the node's true position;
    with ``"reports"`` a position report (std ``report_sigma``, clipped to the node's motion
    rectangle widened by 4 sigma), with ``filter_estimate=True`` the Kalman filter's estimate
    instead; with ``"rates"`` no position (0). Unless exact, the rate feature is the rate the
    node measured in the slot (one faded sample; 0 if its share was at most
    ``ios_uav_env.model.reports.SERVED_SHARE``) and
    the served feature the UAV's own tally sum_m alpha_k[m] x measured_k[m] / N. With
    ``"reports"`` the draws are ``baselines.mpc.run_online``'s, so the env and MPC see the same
    paths and noise for a seed. ``env.unwrapped.paths``, ``.reports`` and ``.measured_rates``
    hold the episode's. ``peak_hint`` is refused.

    ## Info

    Every step and the reset carry ``MULTI_INFO_KEYS``: ``position``, ``slot``,
    ``distance_to_final``, ``shares`` (K_max, this slot's), ``node_rates`` (K_max, S_k / N so
    far), ``min_rate`` (m_n: at slot N the agent's own score min_k R_k), ``best_schedule_rate``
    (at slot N ``maxmin_rate`` of the trajectory, the best shares for the same flight, the
    certified best schedule of ``ios_uav_env.model.schedule``: NaN if scipy is not installed
    and the schedule needs its HiGHS fallback, K > 8 or a failed certificate; 0 before), the
    three reward terms, ``feasible`` (eq. (10) so far and, with ``energy_budget_j``,
    the flight's energy so far within it: at slot N, ``score_plan``'s verdict), ``worst_violation``,
    ``terminal_miss``.
    The best schedule's wall time is kept in ``score_seconds`` (0 before slot N): it scores the flight, so
    the benchmark leaves it out of a policy's plan time. With the energy objective ``info`` adds
    ``power`` (W, P(V) of the step's move; 0 at reset), ``energy`` (J so far), ``energy_efficiency``
    (bits/J so far, B dt min_k sum_m alpha_k[m] r_k(q[m]) / energy; 0 at reset; at slot N
    ``score_plan``'s EE) and ``reward_energy``; with channel "rician" ``expected_node_rates`` and
    ``expected_min_rate`` (Rician channel). ``env.unwrapped.info_keys`` lists the keys.

    ## Episode End

    ``terminated=True`` at slot N (after N - 1 steps); no ``TimeLimit`` is registered.

    ## Arguments

    - ``config``: the scenario (``ground_nodes`` with K <= ``max_nodes``); default the 3
      nodes of ``DEFAULT_NODES``. ``reset(options={"config": cfg})`` runs one episode on
      another scenario with at most ``max_nodes`` nodes that fits the observation space.
    - ``max_nodes`` (K of ``config``, 4 for the randomised id): K_max of the spaces.
    - ``share_sharpness`` (5.0): the softmax's inverse temperature.
    - ``softmin_beta`` (0.0): beta of the shaped rate term (Rewards); 0 is the plain minimum.
    - ``best_schedule`` (True): compute ``info["best_schedule_rate"]`` at the episode's end (False:
      NaN there, as the batched env's ``best_schedule=False``; the schedule scores, it does not
      train).
    - ``random_nodes`` ((2, 4) for the randomised id, None otherwise): draw a new scenario with
      that many nodes at every reset.
    - ``peak_hint`` (False): append each node's reachable rate peak (Observation Space; one
      ``rate_peak`` per node and scenario, cached: ``node_peaks``).
    - ``arrival_guard``, ``reach_weight``, ``terminal_weight``, ``length_scale``, ``knowledge``,
      ``report_sigma``, ``filter_estimate``, ``channel`` ("expected" or "rician", the latter with
      ``knowledge="exact"``), ``energy_reference`` (None or bits/J; the energy objective only):
      as ``IOSUAVEnv`` (``EnvOptions``); ``instance_features`` is refused.
    - ``render_mode``: None or "rgb_array" (the best node's rate map, every node, and the
      trajectory so far coloured by the node with the largest share in each slot; needs
      ``pip install ios-uav-env[render]``).
    - ``**kwargs``: ``ScenarioConfig`` fields applied to ``config`` (with ``random_nodes``: to the
      drawn scenarios; a drawn field, ``config`` or, without ``random_nodes``, ``ranges`` would
      be unused and is refused). ``objective``: ``"rate"`` (the max-min rate) or
      ``"energy_efficiency"`` (Energy); with the rate objective ``bandwidth_hz``, and
      ``propulsion`` without ``energy_budget_j``, would do nothing and are refused.

    ```python
    >>> import gymnasium as gym
    >>> import ios_uav_env
    >>> env = gym.make("ios_uav_env/IOSUAV-MultiNode-v0")
    >>> obs, info = env.reset(seed=0)
    >>> obs.shape, env.action_space.shape, info["shares"].round(3).tolist()
    ((30,), (5,), [0.333, 0.333, 0.333])

    ```

    ## Version History

    * v0: Initial version; later, without changing v0's episodes, observations or ``info`` keys:
      ``objective="energy_efficiency"`` (the energy reward, features and ``info``) and
      ``channel="rician"`` (faded service, the expected-gain scoring in ``info``).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(
        self,
        config: ScenarioConfig | Mapping[str, Any] | None = None,
        *,
        max_nodes: int | None = None,
        share_sharpness: float = 5.0,
        softmin_beta: float = 0.0,
        random_nodes: tuple[int, int] | None = None,
        ranges: ScenarioRanges = MULTINODE_RANGES,
        render_mode: str | None = None,
        best_schedule: bool = True,
        **kwargs: Any,
    ) -> None:
        options, overrides = split_kwargs(kwargs, f"{type(self).__name__}.__init__")
        self.options = EnvOptions(**options)
        if not isinstance(best_schedule, (bool, np.bool_)):
            raise ValueError(f"best_schedule must be True or False, got {best_schedule!r}")
        #: Whether an episode's end computes ``info["best_schedule_rate"]`` (else NaN there).
        self.best_schedule = bool(best_schedule)
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        check_multinode_arguments(config, random_nodes, ranges, MULTINODE_RANGES, overrides)
        base = as_config(config if config is not None else ScenarioConfig(ground_nodes=DEFAULT_NODES))
        check_config_keywords(multinode_id(random_nodes, False), base, overrides)
        self._base = base.replace(**overrides) if overrides else base
        if random_nodes is not None:
            lo, hi = (int(v) for v in random_nodes)
            if not 1 <= lo <= hi:
                raise ValueError(
                    f"random_nodes must be (low, high) with 1 <= low <= high, got {random_nodes!r}"
                )
            random_nodes = (lo, hi)
        self.random_nodes = random_nodes
        unranged = {k: v for k, v in overrides.items() if k not in RANGED_FIELDS | {"ground_nodes"}}
        if random_nodes and unranged:  # the drawn scenarios take the same fields (a motion model, ...)
            ranges = dataclasses.replace(ranges, base=ranges.base.replace(**unranged))
        self.ranges = ranges
        # moving or roughly known nodes (ios_uav_env.envs.knowledge): paths and kernels per episode
        family = ranges.base if random_nodes else self._base
        self.mobile: bool = family.motion is not None or self.options.knowledge != "exact"
        # the objective fixes the reward and the observation's layout (multi_energy)
        self.energy_objective: bool = family.objective == "energy_efficiency"
        self.reference_efficiency: float = 0.0  # bits/J, lambda_ref of the episode (energy objective)
        check_options(self.options, self.energy_objective)
        check_world(family, self.options, self._own_id(), "ranges.base" if random_nodes else "config")
        fades = self.options.channel == "rician" or self.options.knowledge != "exact"
        surfaces = ranges.surfaces if random_nodes else (self._base.surface,)
        check_scenario_overrides(
            self._own_id(), overrides, surfaces, fades=fades, multinode=True,
            budget=family.energy_budget_j is not None, energy=self.energy_objective,
        )  # fmt: skip
        if self.mobile and self.options.peak_hint:
            raise ValueError(
                "peak_hint is a static node's rate peak: it needs static, exactly known nodes (motion=None "
                f"and knowledge='exact'), got motion={family.motion!r}, knowledge={self.options.knowledge!r}"
            )
        self._track: NodesTrack | None = None
        # the most nodes an episode can have: random_nodes' high when every reset draws (the
        # config is then not an episode's scenario), else the config's K
        needed = random_nodes[1] if random_nodes else self._base.K
        what = f"random_nodes' high = {needed}" if random_nodes else f"the scenario's K = {needed}"
        if max_nodes is not None and (
            isinstance(max_nodes, bool) or not isinstance(max_nodes, (int, np.integer)) or max_nodes < needed
        ):
            raise ValueError(f"max_nodes must be an integer >= {what}, got {max_nodes!r}")
        self.max_nodes = int(needed if max_nodes is None else max_nodes)
        if not (
            isinstance(share_sharpness, (int, float))
            and math.isfinite(share_sharpness)
            and share_sharpness > 0
        ):
            raise ValueError(f"share_sharpness must be a finite number > 0, got {share_sharpness!r}")
        self.share_sharpness = float(share_sharpness)
        if not (isinstance(softmin_beta, (int, float)) and math.isfinite(softmin_beta) and softmin_beta >= 0):
            raise ValueError(f"softmin_beta must be a finite number >= 0, got {softmin_beta!r}")
        self.softmin_beta = float(softmin_beta)
        self.score_seconds = 0.0  # see reset()
        self.render_mode = render_mode
        self.node_features = NODE_FEATURES + (NODE_PEAK_FEATURES if self.options.peak_hint else ())
        #: The names of the observation's components, in order: ``BASE_FEATURES``, then node slot
        #: k's ``node_features`` as ``<feature>_<k>`` (``observation_layout.node_block_names``).
        self.observation_names: tuple[str, ...] = (
            BASE_FEATURES
            + node_block_names(self.node_features, self.max_nodes, self.options.knowledge)
            + (ENERGY_NAMES if self.energy_objective else ())
        )
        self.action_space = spaces.Box(-1.0, 1.0, (2 + self.max_nodes,), np.float32)
        low, high = self._bounds()
        self.observation_space = spaces.Box(low, high, dtype=np.float32)
        # where a measured rate is clipped (the space's rate bound, over the env's family)
        own = self.ranges if random_nodes else ScenarioRanges.from_config(self._base.node_config(0))
        self._rate_clip = self._rate_high(own)
        #: bps/Hz: where the observation clips a served rate (channel "rician"; else inf): the kernels'.
        self.served_clip: float = rate_high(own, "exact", True) if self._rician else math.inf
        #: The keys of ``info`` (``multi_table.info_keys``: more with the energy objective, Rician).
        self.info_keys: tuple[str, ...] = info_keys(self.energy_objective, self._rician)
        self.config = self._base
        # a batch of one episode for the kernels of ios_uav_env.envs.multi_kernels
        self._rows = NodeRows(
            1, self.max_nodes, self.options, self.share_sharpness, self.softmin_beta, self.energy_objective,
            self.served_clip,
        )  # fmt: skip
        self._one, self._active = np.zeros(1, dtype=np.int64), np.ones(1, dtype=np.bool_)
        self._action, self._norm = np.zeros((1, 2 + self.max_nodes)), np.zeros(1)
        self._obs = np.zeros((1, low.size), dtype=np.float32)
        self._reward, self._terminated = np.zeros(1), np.zeros(1, dtype=np.bool_)
        more = self.energy_objective or self.options.channel == "rician"  # (their info columns)
        self._table = np.zeros((1, info_columns(self.max_nodes, more)))
        self._started = False

    # --- options (read-only views of self.options, as on IOSUAVEnv) -------------------------
    channel = property(lambda self: self.options.channel)
    arrival_guard = property(lambda self: self.options.arrival_guard)
    length_scale = property(lambda self: self.options.length_scale)

    # --- spaces ---------------------------------------------------------------------------
    def _bounds(self, config: ScenarioConfig | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) over the env's family (its ranges, or its one config), or over ``config``
        (``multi_space.multinode_bounds``)."""
        return multinode_bounds(self, config)

    def _own_id(self) -> str:
        """The registered id of this env, for messages (``settings.multinode_id``)."""
        return multinode_id(self.random_nodes, self.mobile)

    def _rate_high(self, r: ScenarioRanges) -> float:
        """bps/Hz: the rate features' bound over ``r`` (``multi_space.rate_high``)."""
        return rate_high(r, self.options.knowledge)

    # --- episode --------------------------------------------------------------------------
    def _episode_config(self, pinned: ScenarioConfig | None) -> ScenarioConfig:
        if pinned is not None:
            return pinned
        if self.random_nodes:
            return sample_multinode(self.np_random, self.ranges, self.random_nodes)
        return self._base

    def begin_episode(self, seed: int | None, options: dict[str, Any] | None) -> ScenarioConfig:
        """The scenario part of ``reset`` (row protocol; ``MultiNodeVectorEnv`` runs it on each row's
        env): seed ``np_random``, choose the episode's scenario (pinned, drawn or the env's own),
        check that it fits the spaces, make it ``config``; no step, no observation."""
        super().reset(seed=seed)
        pinned = scenario_option(options)
        cfg = self._episode_config(pinned)
        if pinned is not None:
            self.check_scenario(cfg)
        self.config = cfg
        return cfg

    def check_scenario(self, cfg: ScenarioConfig, field: str = 'options["config"]') -> None:
        """Raise ``ValueError`` naming ``field`` unless the pinned scenario ``cfg`` can be an episode
        of this env: at most ``max_nodes`` nodes and observations inside the space (row protocol:
        the batched env checks every row's pinned scenario with it before it resets any row)."""
        if cfg.motion is not None and not self.mobile:
            raise ValueError(
                f"{field} has a motion model; this env's nodes are static: make the env on the scenario "
                "instead (MultiNodeEnv(cfg)), or use ios_uav_env/IOSUAV-MultiNode-Mobile-v0"
            )
        multinode_objective(cfg, field, self._own_id(), self.energy_objective)
        if cfg.K > self.max_nodes:
            raise ValueError(
                f"{field}: the scenario has K = {cfg.K} nodes; this env observes at most max_nodes = "
                f"{self.max_nodes}"
            )
        if cfg != self._base:  # could its observations leave the space?
            low, high = self._bounds(cfg)
            if np.any(low < self.observation_space.low) or np.any(high > self.observation_space.high):
                raise ValueError(
                    f"{field}: the scenario {cfg} does not fit this env's observation space; make an env "
                    "on it instead"
                )

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict]:
        self.begin_episode(seed, options)
        self.load_row(self._rows, 0)  # the scenario, node paths, lambda_ref, the first slot's fading
        self.score_seconds = 0.0  # wall time of the episode's best schedule (scoring, not planning)
        self._rows.start(self._one, self._obs, self._table)
        self.observe_slot(self._rows, 0, self._obs[0])
        self._started = True
        return self._obs[0].copy(), self._info()

    def _info(self) -> dict[str, Any]:
        """The ``info`` dict (``MULTI_INFO_KEYS``) of the info table: numpy scalars and arrays."""
        table = self._table.copy()
        return {key: value[0] for key, value in info_arrays(table, self.max_nodes, self.info_keys).items()}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict]:
        if not self._started:
            raise RuntimeError("call reset() before step()")
        if self._rows.state[0, 2] >= self._rows.episode[0, 3]:
            raise RuntimeError(f"the episode ended at slot N = {self.config.N}; call reset()")
        a = np.asarray(action, dtype=np.float64)
        if a.shape != self.action_space.shape:
            raise ValueError(f"action must have shape {self.action_space.shape}, got {a.shape}")
        if not np.isfinite(a).all():
            raise ValueError(f"action must be finite (no NaN or inf), got {action!r}")
        self._action[0] = a
        self._norm[0] = math.hypot(a[0], a[1])  # (Python's hypot: see multi_kernels.move_norms)
        outputs = (self._obs, self._reward, self._terminated, self._table)
        self.prepare_slot(self._rows, 0)
        self._rows.step(self._action, self._active, outputs, self._norm, serial=True)
        self.observe_slot(self._rows, 0, self._obs[0])
        terminated = bool(self._terminated[0])
        if terminated and not self.best_schedule:
            self._table[0, BEST] = np.nan  # (as the batched env's best_schedule=False)
        elif terminated:
            start = time.perf_counter()
            self._table[0, BEST] = reported_maxmin_rate(
                self.config, self.trajectory, self.truth, track_kernels(self.track)
            )
            self.score_seconds = time.perf_counter() - start
        return self._obs[0].copy(), float(self._reward[0]), terminated, False, self._info()

    @property
    def trajectory(self) -> np.ndarray:
        """The way-points so far, (n + 1, 2) m."""
        if not self._started:
            return np.zeros((0, 2))
        return self._rows.path[0, : int(self._rows.state[0, 2]) + 1].copy()

    @property
    def shares(self) -> np.ndarray:
        """The shares so far, (K, n + 1): slot 1's equal shares, then one column per step."""
        if not self._started:
            return np.zeros((self.config.K, 0))
        return self._rows.schedule(0, self.config.K)

    def render(self) -> np.ndarray | None:
        """The trajectory so far over the best node's rate map, an (H, W, 3) uint8 array."""
        if self.render_mode is None:
            gym.logger.warn('render() needs render_mode="rgb_array" at construction; returning None')
            return None
        from ios_uav_env.plotting import figure_image, plot_multinode_map, plot_served_trajectories

        def draw(ax: Any) -> None:
            plot_multinode_map(ax, self.config, resolution=(120, 60))
            if self._started:
                plot_served_trajectories(ax, self.config, {"UAV": self.trajectory}, {"UAV": self.shares})
                slot, low = len(self.trajectory), self._rows.state[0, 4]  # (min_rate so far)
                ax.set_title(f"slot {slot}/{self.config.N}, min rate so far {low:.3f} bps/Hz", fontsize=9)

        return figure_image(draw)
