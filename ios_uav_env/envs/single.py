"""The Gymnasium environment: one episode is one mission of the paper, one step is one slot.

The env is a thin adapter over the model (``ios_uav_env.model.channel`` and ``.trajectory``):
action -> next way-point (optionally through the arrival guard) -> rate -> reward. It never
re-derives a formula: the per-step rate is ``RateKernel.rate`` / ``RateKernel.faded_rate``,
and the score of a finished episode is ``average_rate`` (eq. (9)) of ``env.trajectory``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ios_uav_env.envs.knowledge import NodeTrack, mobile_bounds
from ios_uav_env.envs.observation import check_fits, space_bounds
from ios_uav_env.envs.observation_layout import (
    ENERGY_NAMES,
    INSTANCE_NAMES,
    OBS_NAMES,
    PEAK_NAMES,
    observation_names,
)
from ios_uav_env.envs.options import CHANNELS, EnvOptions, split_kwargs
from ios_uav_env.envs.settings import (
    check_config_keywords,
    check_scenario_overrides,
    check_world,
    several_nodes_error,
    single_node_id,
)
from ios_uav_env.envs.single_kernels import INFO, STATE, episode_row, flags_of, reset_rows, step_rows
from ios_uav_env.envs.single_mobile import MobileNode
from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model.channel import RateKernel, rate_kernel, slot_rates
from ios_uav_env.model.config import ScenarioConfig, as_config, scenario_option
from ios_uav_env.model.peak import rate_peak
from ios_uav_env.model.scenarios import ScenarioRanges

#: The keys of every step's (and the reset's) ``info``, in order: all numbers (``position``
#: a float64 array of shape (2,)), the same on every step of every id.
INFO_KEYS: tuple[str, ...] = (
    "rate", "expected_rate", "position", "distance_to_final", "slot", "reward_rate", "reward_reach",
    "reward_terminal", "average_rate", "mean_faded_rate", "feasible", "worst_violation", "terminal_miss",
    "power", "energy", "energy_efficiency", "reward_energy",
)  # fmt: skip

__all__ = ["CHANNELS", "ENERGY_NAMES", "INFO_KEYS", "INSTANCE_NAMES", "OBS_NAMES", "PEAK_NAMES", "IOSUAVEnv"]


class IOSUAVEnv(MobileNode, gym.Env):
    r"""A UAV flies from ``q0`` to ``qF`` in ``T`` seconds while serving a ground node G via an IOS.

    ## Description

    The scenario of Liu et al., "Full-Dimensional Rate Enhancement for UAV-Enabled
    Communications via Intelligent Omni-Surface" (IEEE WCL 2022; the model: ``docs/model.md``).
    A UAV at altitude z_U sends to a ground node G through the
    direct link and an intelligent omni-surface (IOS) in the plane x = x_c, which serves G by
    reflection when the UAV is on G's side and by transmission from the other side; its
    phases are the closed-form optimum (eq. (13)), so the rate depends on the UAV position
    only. The agent plans the trajectory: one step is one slot (N - 1 steps from
    ``q[1] = q0``), and the paper's objective is the average rate of eq. (9) subject to
    eq. (10): arrive at ``qF`` at slot N with at most D = v_max dt per move. Ids:
    ``ios_uav_env/IOSUAV-v0`` (IOS), ``ios_uav_env/RISUAV-v0`` (reflect-only RIS),
    ``ios_uav_env/UAV-v0`` (no surface) and ``ios_uav_env/STARUAV-v0`` (a STAR surface, one node
    per slot share); ``ios_uav_env/IOSUAV-Energy-v0`` is the IOS scenario
    with the objective ``"energy_efficiency"`` (bits per joule of propulsion energy; see
    "Energy"). ``env.unwrapped.trajectory`` is the (n, 2) array of the way-points so far (m).

    ## Action Space

    A ``Box(-1, 1, (2,), float32)``: the horizontal displacement of the slot in units of
    D; an action outside the unit disk is projected onto it (so |move| <= D). The action is
    used in float64 as given; a NaN/inf action or one of another shape raises ``ValueError``.

    | Num | Action                  | Min  | Max |
    |-----|-------------------------|------|-----|
    | 0   | x displacement / D      | -1.0 | 1.0 |
    | 1   | y displacement / D      | -1.0 | 1.0 |

    With the arrival guard (default) the displacement is then projected onto the feasible
    set: see ``arrival_guard`` below.

    ## Observation Space

    A float32 ``ndarray`` of shape (11,) (names in ``OBS_NAMES``); lengths are divided by
    ``length_scale`` L (400 m by default), every point is relative to the UAV position q, so
    the features carry over to other scenarios (for surface "none" the IOS centre is still
    ``config.ios_center``). ``moves_left`` is the number of moves left (N - 1 at the start,
    0 at the end), ``d_F = |qF - q|``. The bound B of each length component is its value at
    q0 in absolute terms plus (N - 1) D / L: no UAV gets farther, guard or not.

    | Num | Observation                                        | Min  | Max  |
    |-----|----------------------------------------------------|------|------|
    | 0-1 | UAV position q / L                                 | -B   | B    |
    | 2-3 | final point, (qF - q) / L                          | -B   | B    |
    | 4-5 | ground node, (w_G - q) / L                         | -B   | B    |
    | 6-7 | IOS centre, (x_c - x, y_c - y) / L                 | -B   | B    |
    | 8   | time left, moves_left / (N - 1)                    | 0    | 1    |
    | 9   | slack s / (1 + abs(s)), s = moves_left - d_F / D   | -1   | 1    |
    | 10  | expected-gain rate r(q) at q (bps/Hz)              | 0    | r_ub |

    The slack s is how many spare moves the UAV has to still reach qF (s < 0: qF is out of
    reach); the squashing keeps it O(1) with most resolution near s = 0. The rate at q is a
    function of the position (it adds no state) given to ease learning; r_ub is
    ``ios_uav_env.envs.observation.rate_bound``. Together they make the problem Markov.

    With ``instance_features=True`` (the randomised id's default) 6 features that define the
    instance follow (names in ``INSTANCE_NAMES``): M / 6000 (0 without a surface), is-IOS and
    is-RIS flags, t / (1 + t) with t the transmissive factor (epsilon or 0), T / 200 s and the
    seconds left / 200 s: shape (17,). See ``ios_uav_env.envs.random_env``.

    With ``peak_hint=True`` 3 more follow (names in ``PEAK_NAMES``): the reachable rate peak
    P of the scenario (``ios_uav_env.model.peak.rate_peak``: the best point a fly-hover-fly
    trajectory can visit; searched on the env's compiled rate kernel when numba is installed)
    relative to the UAV, (P - q) / L, and its rate r(P) (bps/Hz). It is derived from the
    instance (no new information) and computed once per scenario.

    With the objective ``"energy_efficiency"`` (the energy ids; ``config.objective``) 4 energy
    features (names in ``ENERGY_NAMES``) come after the instance features and before the peak
    hint (which stays last): the last move (q[n] - q[n-1]) / D (two components in [-1, 1], 0
    at the start; its length times v_max is the last speed), the energy weight w = lambda_ref
    P(0) / B of the reward below (bps/Hz, per scenario) and the minimum-power move V_mp dt / D.
    The rate objective's layouts above are unchanged.

    ``env.unwrapped.observation_names`` is the layout: the names of the components, in order
    (``observation_layout.observation_names``; with ``knowledge`` other than ``"exact"`` the rate is
    ``measured_rate``, and with ``"rates"`` features 4-5 are ``dx_ground_hidden`` /
    ``dy_ground_hidden``). Every bound is a finite float32: a setting that would take a feature
    beyond float32 (e.g. a tiny ``length_scale``, a huge ``energy_reference``) is refused with
    ``ValueError`` naming the field and its allowed range.

    ## Rewards

    Step n moves the UAV to q' = q[n+1] with m = moves_left after the move:

        reward = rate(q') - w_reach * reach - w_terminal * terminal
        reach    = max(0, |qF - q'| - m D - tol) / D
        terminal = e + sqrt(e),  e = max(0, |qF - q'| - tol) / D   (last step only; else 0)

    with tol = ``FEASIBILITY_TOL`` (1e-6 m). ``rate`` is log2(1 + eta zeta(q')^2) (channel
    "expected", the paper's objective) or one faded sample log2(1 + eta |h|^2) (channel
    "rician"). ``reach`` is how far (in moves) the UAV has put itself out of reach of qF,
    so lingering too long costs more at every step; ``terminal`` is the final miss, steep
    near zero so that even a tiny miss never pays. Both are 0 for a trajectory that meets
    eq. (10), so with the guard the reward is the rate alone and the return is N R - r(q0)
    with R of eq. (9). ``info`` holds the weighted terms, which sum to the reward:
    ``reward_rate`` (rate), ``reward_reach`` (-w_reach reach), ``reward_terminal``
    (-w_terminal terminal) and ``reward_energy`` (0 but for the energy objective).

    ## Energy

    Each move is flown at one constant speed over its slot, V_n = |q[n+1] - q[n]| / dt, at the
    propulsion power P(V_n) of ``config.propulsion`` (``ios_uav_env.propulsion_power``), so the
    flight's energy is E = dt sum_n P(V_n) and its energy efficiency EE = B dt sum_{n=1}^{N}
    r(q[n]) / E (bits/J, ``ios_uav_env.score_plan``'s; B = ``config.bandwidth_hz``). With the
    objective ``"energy_efficiency"`` the reward gains the term

        reward_energy = -(lambda_ref / B) P(V_n)   (bps/Hz; = -w P(V_n) / P(0))

    so that, with the guard (no penalties), the return is Dinkelbach's parametric objective
    scaled: return = (bits(q) - lambda_ref E(q)) / (B dt) - r(q0), bits(q) = B dt sum_n r(q[n]),
    an increasing affine function of G(q) = bits(q) - lambda_ref E(q). EE is a ratio, not a sum;
    the return ranks plans as G does, and G relates to EE as follows (lambda* = max EE, q* its
    plan, q^ a plan of the largest return):

    - lambda_ref = lambda*: G(q) = E(q) (EE(q) - lambda*) <= 0, with equality iff EE(q) =
      lambda*, so the return's maximisers are exactly the EE-optimal plans.
    - any lambda_ref: G(q^) >= G(q*) gives EE(q^) >= lambda_ref + (lambda* - lambda_ref)
      E(q*) / E(q^). For lambda_ref <= lambda*: EE(q^) >= lambda_ref and lambda* - EE(q^) <=
      (lambda* - lambda_ref) (1 - E(q*) / E(q^)). For lambda_ref >= lambda*: lambda* - EE(q^) <=
      (lambda_ref - lambda*) (E(q*) / E(q^) - 1) <= (lambda_ref - lambda*) (P_max / P(V_mp) - 1),
      as every flight's E lies in [(N - 1) dt P(V_mp), (N - 1) dt P_max], P_max = max(P(0),
      P(v_max)). The loss vanishes linearly as lambda_ref -> lambda*.

    lambda_ref is ``energy_reference`` when given (bits/J, e.g. a planner's EE*), else the
    scenario's own reference ``observation.reference_efficiency``: the EE of the rate
    objective's plan "fly to the reachable rate peak P and hover" (``policies.HoverAt("peak")``
    through the guard, ``observation.hover_flight``). It is feasible, so lambda_ref <= lambda*
    (the second case: the return's maximiser does at least as well as hovering) without
    needing lambda*. (An upper reference such as ``observation.optimistic_efficiency``,
    B N r(P) / ((N - 1) P(V_mp)), is >= lambda* but far above it on short missions, where most
    of the energy goes into the transit.) It is computed at each new scenario (one
    ``rate_peak`` search, shared with the peak hint, and one scoring) and held in
    ``env.unwrapped.reference_efficiency``. The episode's score is its EE
    (``info["energy_efficiency"]`` at slot N, ``envs.rollout.Episode.energy_efficiency``).
    A mobile env (see "Moving nodes") scores the same flights, planned on the configured node,
    on each episode's drawn node path at reset (``observation.flights_efficiency``): a feasible
    plan's EE on the episode's truth, so lambda_ref <= lambda* of that path as above. It is
    computed from the truth, so it shapes the reward only: ``energy_weight`` shows the
    scenario's value (the flights on the configured node), never the episode's.

    ## Moving nodes

    With a motion model in the scenario (``config.motion``, e.g. ``motion=GaussMarkov()``; the id
    ``ios_uav_env/IOSUAV-Mobile-v0``) or ``knowledge`` other than ``"exact"`` the env is
    *mobile* (``ios_uav_env.envs.knowledge``): each reset draws the node's path w[1..N] from
    ``np_random`` (``env.unwrapped.paths``, the truth the episode is scored on), the rate of
    slot n is r(q[n]; w[n]) (reward and ``info`` as above, on the true path), and features 4-5
    and 10 are what the UAV is told: the true position and rate (``"exact"``), a position
    report with N(0, report_sigma^2) error per component and the slot's measured (faded) rate
    (``"reports"``), or only the measured rate (``"rates"``; features 4-5 are 0). Reports and
    measured rates are clipped to the space (``knowledge``'s docstring); their bounds cover
    every motion rectangle of the family. ``env.unwrapped.reports`` and ``.measured_rates``
    hold the slots so far. ``filter_estimate=True`` (reports only, off by default) tells the
    Kalman filter's estimate of the position after each report instead of the raw report. The
    energy objective works as in "Energy"; the peak hint needs a static, exactly known node.

    ## Info

    The same keys on every step and at reset (``INFO_KEYS``), all numpy numbers (float64;
    ``slot`` int64, ``feasible`` bool_; each has a dtype), so loggers, replay buffers and
    TorchRL's info readers can stack them: ``rate`` (the reward's rate term), ``expected_rate``,
    ``position`` (x, y in m, a float64 array), ``distance_to_final`` (m), ``slot`` (the
    paper's 1-based index n of the way-point q[n]), the three reward terms, and the running
    score and check of the trajectory so far: ``average_rate`` (mean expected-gain rate of
    the way-points so far; at slot N, eq. (9)), ``mean_faded_rate`` (mean of the ``rate``
    terms; equal to ``average_rate`` for channel "expected"), ``terminal_miss`` (m by which qF
    is out of reach in the moves left; at slot N, |q[N] - qF|), ``worst_violation`` (m, the
    worst breach of eq. (10) so far) and ``feasible`` (``worst_violation`` <= 1e-6 m and, with
    ``energy_budget_j``, the energy so far within it; at slot N, ``score_plan``'s verdict: eq.
    (10) and the budget), and the flight's energy so far: ``power`` (W, P(V) of the step's move; 0 at
    reset), ``energy`` (J, dt times the sum of the powers so far) and ``energy_efficiency``
    (bits/J so far, B dt sum r(q[n]) / energy; 0 at reset; at slot N, ``score_plan``'s EE), on
    every id (the rate ids report them too, with the scenario's propulsion model). The full
    report: ``check_trajectory(env.unwrapped.config, env.unwrapped.trajectory)``.

    ## Starting State

    The UAV at ``q0``, slot 1 (deterministic; with channel "rician" the first slot's faded
    rate is drawn at reset from ``np_random``). ``reset(options={"config": cfg})`` (the only
    option; ``cfg`` a ``ScenarioConfig`` or a dict of its fields) runs that episode on ``cfg``,
    surface included (``env.unwrapped.config`` is the episode's scenario); the next reset
    without it returns to the env's own. A ``cfg`` that could take the observation out of the
    space (derived from the construction config: e.g. a longer T, a farther G) is refused
    with ``ValueError``; make the env on it instead (``gym.make(id, config=cfg, ...)``).

    ## Episode End

    ``terminated=True`` after the (N - 1)th step, at slot N: time is in the observation,
    so this is a true terminal state. The env never truncates, and the ids register no
    ``TimeLimit``: ``gym.make("ios_uav_env/IOSUAV-v0", T=300)`` runs 299 steps. (A
    ``max_episode_steps`` passed to ``gym.make`` adds Gymnasium's ``TimeLimit``, which
    truncates as asked: a trajectory cut before slot N is not a plan of eq. (10).)

    ## Arguments

    The scenario and the env's options are two separate things: ``config`` (and keywords
    named like its fields) is the scenario; the other keywords are ``EnvOptions``. Any
    other keyword raises ``TypeError`` as Python does.

    - ``config``: a ``ScenarioConfig`` (or a dict of its fields); default: the paper's.
    - ``channel``: "expected" (default, deterministic) or "rician".
    - ``arrival_guard`` (default True): projects the next position onto the intersection of
      the disk of radius D around q and the disk of radius m D around qF, so both limits hold
      at once and any action sequence gives a trajectory meeting eq. (10) (the last move lands
      exactly on qF; see ``ios_uav_env.model.guard``). On by default because the paper's
      constraints (10b)-(10c) are hard: an agent that learns them through penalties may still
      miss qF, and the guard turns the task into the paper's (maximise the rate over feasible
      trajectories). False leaves feasibility to the reward shaping.
    - ``reach_weight`` (1.0) and ``terminal_weight`` (2.0): the weights above. At the
      defaults a final miss of e moves costs 3 e + 2 sqrt(e), more than the rate it can win
      (the rate map's steepest slope is 1.5 bps/Hz per move at M = 6000).
    - ``length_scale`` (400.0 m): L of the observation.
    - ``instance_features`` (False): append the 6 instance features to the observation.
    - ``peak_hint`` (False): append the 3 features of the reachable rate peak.
    - ``energy_reference`` (None): lambda_ref (bits/J) of the energy reward (objective
      ``"energy_efficiency"``; see "Energy"); None: the scenario's hover plan's EE; "loiter":
      the better EE of its loiter and hover flights (``observation.loiter_efficiency``).
    - ``knowledge`` ("exact"), ``report_sigma`` (10 m) and ``filter_estimate`` (False): what the
      UAV is told of the node each slot, see "Moving nodes".
    - ``render_mode``: None or "rgb_array" (the trajectory over the rate map; needs
      ``pip install ios-uav-env[render]``).
    - ``**kwargs``: ``EnvOptions`` fields (the options above) and ``ScenarioConfig`` fields,
      applied with ``config.replace``; the ids set ``surface`` this way. A ``config`` field left
      at its default takes the keyword's value; one the config set to another value is refused
      (``settings.check_config_keywords``: ``IOSUAV-v0`` given a RIS config names ``RISUAV-v0``).

    A setting that would do nothing is refused with ``ValueError`` naming what it needs
    (``EnvOptions``; as keywords, ``kappa`` without faded rates, ``epsilon`` without an IOS, the
    surface's channel fields without a surface: ``settings.check_scenario_overrides``), and so
    is a config of several nodes, naming the multi-node id (``settings.several_nodes_error``).

    ```python
    >>> import gymnasium as gym
    >>> import ios_uav_env
    >>> env = gym.make("ios_uav_env/IOSUAV-v0", channel="rician", T=100)
    >>> obs, info = env.reset(seed=0)
    >>> obs.shape, info["slot"]
    ((11,), 1)

    ```

    ## Version History

    * v0: Initial version; later, without changing v0's episodes or observations:
      ``reset(options={"config": cfg})``, ``instance_features`` and ``peak_hint``; then a flat
      ``info`` with fixed keys (``INFO_KEYS``) and registration without a ``TimeLimit``; then
      ``info``'s ``power``, ``energy``, ``energy_efficiency`` and ``reward_energy`` (0 here),
      and the energy objective (ids ``ios_uav_env/IOSUAV-Energy-v0`` and
      ``ios_uav_env/IOSUAV-Energy-Random-v0``: the energy features, the energy reward); then
      moving, roughly known nodes (``knowledge``, ``report_sigma``, ``config.motion``; id
      ``ios_uav_env/IOSUAV-Mobile-v0``); then the energy objective with them.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(
        self,
        config: ScenarioConfig | Mapping[str, Any] | None = None,
        *,
        render_mode: str | None = None,
        **kwargs: Any,
    ) -> None:
        options, overrides = split_kwargs(kwargs, f"{type(self).__name__}.__init__")
        config = as_config(config)
        self._base_config: ScenarioConfig = config.replace(**overrides) if overrides else config
        self.options = EnvOptions(**options)
        own, alternative = self._own_id(), single_node_id(config, self.options.knowledge, random=self._draws)
        check_config_keywords(own, config, overrides, alternative if alternative != own else None)
        if self._base_config.K != 1:  # (before the family of the space, which is single-node)
            raise several_nodes_error(self._own_id(), self._base_config)
        self._check_overrides(overrides, (self._base_config.surface,))
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, got {render_mode!r}"
            )
        self.render_mode = render_mode
        self._rician = self.options.channel == "rician"
        self._renderer: Any = None
        self.config: ScenarioConfig | None = None  # the current episode's scenario
        self.kernel: RateKernel  # the rate kernel of self.config
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        check_world(
            self._ranges().base, self.options, self._own_id(), "ranges.base" if self._draws else "config"
        )
        # the objective of the construction scenario fixes the observation's layout and the reward
        self.energy_objective: bool = self._ranges().base.objective == "energy_efficiency"
        if self.options.energy_reference is not None and not self.energy_objective:
            raise ValueError(
                "energy_reference is the reference EE of the energy reward: it needs the objective "
                f"'energy_efficiency', got objective={self._ranges().base.objective!r}"
            )
        self.reference_efficiency: float = 0.0  # bits/J, lambda_ref of the episode (energy objective)
        low, high = space_bounds(
            self._ranges(), self.options.length_scale, self.options.instance_features, self.options.peak_hint,
            self.energy_objective, self._fixed_reference,
        )  # fmt: skip
        # moving or roughly known node (ios_uav_env.envs.knowledge): a path and kernels per episode
        base = self._ranges().base
        self.mobile: bool = base.motion is not None or self.options.knowledge != "exact"
        self._track: NodeTrack | None = None
        self._rate_clip = math.inf
        if self.mobile:
            self._check_mobile()
            low, high, self._rate_clip = mobile_bounds(self._ranges(), self.options, low, high)
        self.observation_space = spaces.Box(low, high, dtype=np.float32)
        #: The names of the observation's components, in order (``observation_layout.observation_names``).
        o = self.options
        self.observation_names: tuple[str, ...] = observation_names(
            o.instance_features, o.peak_hint, self.energy_objective, o.knowledge
        )
        # a batch of one episode for the kernels of ios_uav_env.envs.single_kernels (rows of length 1)
        self._flags = flags_of(self.options, self.energy_objective)
        self._rows = np.zeros(1, dtype=np.int64)
        self._active = np.ones(1, dtype=np.bool_)
        self._state = np.zeros((1, len(STATE)))
        self._action = np.zeros((1, 2))
        self._normals = np.zeros((1, 2))
        self._obs = np.zeros((1, low.size), dtype=np.float32)
        self._reward = np.zeros(1)
        self._terminated = np.zeros(1, dtype=np.bool_)
        self._info_row = np.zeros((1, len(INFO)))
        self._set_config(self._base_config)
        self._path = np.zeros((1, self.config.N, 2))
        self._started = False

    # --- options (read-only views of self.options) ---------------------------------------
    channel = property(lambda self: self.options.channel)
    arrival_guard = property(lambda self: self.options.arrival_guard)
    length_scale = property(lambda self: self.options.length_scale)
    instance_features = property(lambda self: self.options.instance_features)
    peak_hint = property(lambda self: self.options.peak_hint)

    # --- the env as one row of the step kernel (what the batched env copies) -------------------
    @property
    def flags(self) -> np.ndarray:
        """The kernel's option flags of this env (``single_kernels.flags_of(options)``)."""
        return self._flags

    @property
    def episode_row(self) -> np.ndarray:
        """The current scenario's episode constants, one kernel row (``single_kernels.EPISODE``)."""
        return self._episode[0]

    @property
    def max_slots(self) -> int:
        """The most slots N of any scenario this env's observation space holds."""
        return int(self._ranges().slot_range[1])

    @property
    def base_config(self) -> ScenarioConfig:
        """The scenario the env was made with (a plain reset of a fixed id keeps it)."""
        return self._base_config

    # --- scenario and spaces --------------------------------------------------------------
    def _ranges(self) -> ScenarioRanges:
        """The family of scenarios the observation space holds: here the construction config."""
        return ScenarioRanges.from_config(self._base_config)

    def _set_config(self, cfg: ScenarioConfig) -> None:
        """Make ``cfg`` the current scenario: its rate kernel and the episode's constants."""
        if cfg is self.config:
            return
        self.config = cfg
        self.kernel = rate_kernel(cfg)
        own_reference = self.energy_objective and self._fixed_reference is None
        # one peak search for the hint and the reference flights, on the env's own rate kernel
        peak = rate_peak(cfg, compiled=HAVE_NUMBA) if self.options.peak_hint or own_reference else None
        reference = self._scenario_reference(cfg, peak) if self.energy_objective else 0.0
        self.reference_efficiency = reference  # (a mobile env's reward: each episode's, see "Energy")
        hint = peak[:3] if self.options.peak_hint else (0.0, 0.0, 0.0)  # the hint's search never misses
        self._episode = episode_row(cfg, self.options.length_scale, hint, reference)[None, :]
        self._nodes, self._params = self.kernel.nodes[None], self.kernel.params[None]
        self.close()  # the renderer's rate map is the previous scenario's

    def _episode_config(self, pinned: ScenarioConfig | None) -> ScenarioConfig:  # at reset
        return self._base_config if pinned is None else pinned

    def begin_episode(self, seed: int | None, options: dict[str, Any] | None) -> ScenarioConfig:
        """The scenario part of ``reset`` (row protocol): seed ``np_random``, choose the episode's
        scenario (drawn, pinned or the env's own), check it, make it ``config``; no step, no obs."""
        gym.Env.reset(self, seed=seed)
        pinned = scenario_option(options)
        cfg = self._episode_config(pinned)
        # a pinned scenario may leave the space; the env's own draws cannot (the space is built
        # from the family they are drawn from: tests/envs/test_random_env.py checks draws)
        if pinned is not None and cfg is not self._base_config and cfg != self.config:
            self.check_scenario(cfg, 'options["config"]')
        self._set_config(cfg)
        return cfg

    def check_scenario(self, cfg: ScenarioConfig, field: str = 'options["config"]') -> None:
        """Raise ``ValueError`` naming ``field`` unless ``cfg`` can be an episode of this env: one
        ground node (K = 1) and observations inside the space (row protocol: the batched env checks
        every row's pinned scenario with it before it resets any row)."""
        if cfg.K != 1:
            raise several_nodes_error(self._own_id(), cfg, field)
        if cfg.motion is not None and not self.mobile:
            raise ValueError(
                f"{field} has a motion model; this env's nodes are static and exactly known (make an "
                "env on the scenario instead: gym.make(id, config=cfg), or use ios_uav_env/IOSUAV-Mobile-v0)"
            )
        if (cfg.objective == "energy_efficiency") != self.energy_objective:
            allowed = "'energy_efficiency'" if self.energy_objective else "'rate'"
            raise ValueError(
                f"{field} has objective={cfg.objective!r}; this env's observation and reward are those "
                f"of objective {allowed} (make an env on the scenario instead: gym.make(id, config=cfg))"
            )
        try:
            check_fits(
                cfg, self.options.length_scale, self.options.instance_features, self.observation_space,
                self.options.peak_hint, self.energy_objective, self._fixed_reference,
            )  # fmt: skip
        except ValueError as err:  # (naming the scenario's field: a pin, a draw, the construction's)
            raise ValueError(f"{field}: {err}") from None
        if self.mobile:  # where the node can be told to be, and the rate feature's bound
            low, high, _ = mobile_bounds(ScenarioRanges.from_config(cfg), self.options, *self._space())
            low, high = low.astype(np.float32), high.astype(np.float32)  # rounded as the space's were
            if np.any(high > self.observation_space.high) or np.any(low < self.observation_space.low):
                raise ValueError(
                    f"{field}: its node's motion rectangle (or reports) could take the node features "
                    "out of this env's observation space; make an env on the scenario instead"
                )

    #: Whether each reset draws its scenario (``RandomIOSUAVEnv``): which id the env is.
    _draws = False

    def _check_overrides(self, overrides: Mapping[str, Any], surfaces: tuple[str, ...]) -> None:
        """Refuse scenario keywords that would do nothing here (``settings.check_scenario_overrides``)."""
        fades = self.options.channel == "rician" or self.options.knowledge != "exact"
        check_scenario_overrides(self._own_id(), overrides, surfaces, fades=fades)

    def _own_id(self) -> str:
        """The registered id of this env, for messages (``settings.single_node_id``)."""
        return single_node_id(self._base_config, self.options.knowledge, random=self._draws)

    @property
    def _fixed_reference(self) -> float | None:
        """lambda_ref when it is one number for every scenario (``energy_reference`` in bits/J),
        else None (each scenario's own: its hover or its loiter flight's EE)."""
        ref = self.options.energy_reference
        return None if ref is None or isinstance(ref, str) else float(ref)

    def _space(self) -> tuple[np.ndarray, np.ndarray]:
        """The observation space's (low, high) as float64 arrays."""
        return self.observation_space.low.astype(np.float64), self.observation_space.high.astype(np.float64)

    def _draw_normals(self) -> None:
        if self._rician:  # h_SS of the slot: real, then imaginary part
            self._normals[0] = self.np_random.standard_normal(2)

    def _info(self) -> dict[str, Any]:
        """The ``info`` dict (``INFO_KEYS``) of the kernels' info row: numpy scalars (float64,
        ``slot`` int64, ``feasible`` bool_), which every client reads (they have a dtype)."""
        r = self._info_row[0].copy()
        return {"rate": r[0], "expected_rate": r[1], "position": r[2:4], "distance_to_final": r[4],
                "slot": np.int64(r[5]), "reward_rate": r[6], "reward_reach": r[7], "reward_terminal": r[8],
                "average_rate": r[9], "mean_faded_rate": r[10], "feasible": r[11] != 0.0,
                "worst_violation": r[12], "terminal_miss": r[13], "power": r[14], "energy": r[15],
                "energy_efficiency": r[16], "reward_energy": r[17]}  # fmt: skip

    # --- API ----------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        cfg = self.begin_episode(seed, options)
        if self._path.shape[1] != cfg.N:
            self._path = np.zeros((1, cfg.N, 2))
        self._path[0, 0] = self._state[0, 0:2] = cfg.q0
        if self.mobile:  # the episode's node path, and its slot-1 kernel in the row
            self.start_track(cfg)
            self._nodes, self._params = self._track.nodes[0:1].copy(), self._track.params[0:1].copy()
        self._draw_normals()
        reset_rows(self._rows, self._state, self._episode, self._nodes, self._params, self._normals,
                   self._flags, self._obs, self._info_row)  # fmt: skip
        if self.mobile:
            self.observe_slot(0, self._state[0, 0:2], self._obs[0])
        self._started = True
        return self._obs[0].copy(), self._info()

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if not self._started:
            raise RuntimeError("call reset() before step()")
        if self._state[0, 2] >= self._episode[0, 3]:
            raise RuntimeError(f"the episode ended at slot N = {self.config.N}; call reset()")
        if type(action) is np.ndarray and action.shape == (2,):
            ax, ay = action.tolist()
        else:
            ax, ay = self._parse_action(action)
        if not (math.isfinite(ax) and math.isfinite(ay)):
            raise ValueError(f"action must be finite (no NaN or inf), got {action!r}")
        self._action[0, 0], self._action[0, 1] = ax, ay
        slot = int(self._state[0, 2]) + 1  # 0-based index of the way-point this step flies to
        if self.mobile:
            self._nodes[0], self._params[0] = self._track.nodes[slot], self._track.params[slot]
        self._draw_normals()
        step_rows(self._action, self._state, self._episode, self._nodes, self._params, self._normals,
                  self._flags, self._obs, self._reward, self._terminated, self._info_row, self._path,
                  self._active)  # fmt: skip
        if self.mobile:
            self.observe_slot(slot, self._state[0, 0:2], self._obs[0])
        return self._obs[0].copy(), float(self._reward[0]), bool(self._terminated[0]), False, self._info()

    def _parse_action(self, action: Any) -> tuple[float, float]:
        try:
            arr = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"action must be an array of shape (2,), got {action!r}") from exc
        if arr.shape != (2,):
            raise ValueError(f"action must have shape (2,) (x, y displacement / D), got shape {arr.shape}")
        return float(arr[0]), float(arr[1])

    @property
    def trajectory(self) -> np.ndarray:
        """The way-points so far, q[1] = q0 .. q[n+1], as an (n + 1, 2) array in metres."""
        if not self._started:
            return np.zeros((0, 2))
        return self._path[0, : int(self._state[0, 2]) + 1].copy()

    def render(self) -> np.ndarray | None:
        """The trajectory so far over the rate map, as an (H, W, 3) uint8 array ("rgb_array")."""
        if self.render_mode is None:
            gym.logger.warn('render() needs render_mode="rgb_array" at construction; returning None')
            return None
        if self._renderer is None:
            from ios_uav_env.envs.rendering import FrameRenderer

            self._renderer = FrameRenderer(self.config)
        trajectory = self.trajectory
        title = f"{self.config.surface.upper()}, slot {len(trajectory)}/{self.config.N}"
        if len(trajectory):
            title += f", mean rate so far {np.mean(slot_rates(self.config, trajectory)):.3f} bps/Hz"
        return self._renderer.frame(trajectory, title=title)

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_renderer"] = None  # a matplotlib figure; rebuilt on the next render()
        return state
