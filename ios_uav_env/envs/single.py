"""The v0 contract: one ground node on one scenario (``IOSUAVEnv``, a preset of ``UAVEnv``).

``IOSUAVEnv`` is ``ios_uav_env.envs.core.env.UAVEnv`` with the view ``"v0"`` and the move action:
the ids ``IOSUAV-v0``, ``RISUAV-v0``, ``UAV-v0``, ``STARUAV-v0``, ``MISOUAV-v0`` and
``IOSUAV-Energy-v0`` are ``UAVEnv`` with those keywords, and this class makes the same env for code
that names it. The episode runs in ``single_node.SingleNodeStepper``; the class docstring below is
the contract of the view (its spaces, rewards, ``info``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ios_uav_env.envs.core.env import UAVEnv
from ios_uav_env.envs.observation_layout import ENERGY_NAMES, INSTANCE_NAMES, OBS_NAMES, PEAK_NAMES
from ios_uav_env.envs.options import CHANNELS
from ios_uav_env.envs.single_node import INFO_KEYS
from ios_uav_env.model.config import ScenarioConfig

__all__ = ["CHANNELS", "ENERGY_NAMES", "INFO_KEYS", "INSTANCE_NAMES", "OBS_NAMES", "PEAK_NAMES", "IOSUAVEnv"]


class IOSUAVEnv(UAVEnv):
    r"""A UAV flies from ``q0`` to ``qF`` in ``T`` seconds while serving a ground node G via an IOS.

    ``UAVEnv`` with the v0 view (``view="v0"``, the move action): the preset of the fixed
    single-node ids, which are ``UAVEnv`` itself with these keywords (``registration``). This
    docstring is the v0 view's contract; the stepper is ``single_node.SingleNodeStepper``.

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
    per slot share; with ``star_bits`` = b the env sets the node's exact b-bit phases in every
    slot); ``ios_uav_env/MISOUAV-v0`` is the IOS scenario with an N_t-antenna UAV
    (``antennas``, 4; a multi-antenna UAV below); ``ios_uav_env/IOSUAV-Energy-v0`` is the IOS scenario
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
    "expected", the paper's objective) or one faded sample log2(1 + eta |h|^2) (channel "rician");
    with ``antennas`` = N_t > 1 the env sets the beam and the phases at their closed-form joint
    optimum (aligned phases and MRT, ``ios_uav_env.model.miso``) and ``rate`` is log2(1 + G(q')),
    G = eta (N_t (S^2 + a_D^2) + 2 S a_D |a_c^T conj(a_G)|) (``channel.aligned_gain``; channel
    "expected" only); on a STAR surface of b-bit phases (``star_bits`` = b) the env sets the node's
    exact b-bit phases and ``rate`` is log2(1 + eta |h_b(q')|^2), |h_b| the amplitude at those
    phases (``channel.zeta``): the node's rate in ``star_slot.slot_optimum``'s per-slot b-bit
    optimum under TDMA (channel "expected" only). ``reach`` is how far (in moves) the UAV has put
    itself out of reach of qF, so lingering too long costs more at every step; ``terminal`` is the
    final miss, steep near zero so that even a tiny miss never pays. Both are 0 for a trajectory
    that meets eq. (10), so with the guard the reward is the rate alone and the return is
    N R - r(q0) with R of eq. (9). ``info`` holds the weighted terms, which sum to the reward:
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
    - ``antennas`` (a ``ScenarioConfig`` field; 1, ``MISOUAV-v0``'s 4): the UAV's antennas N_t, an
      integer in [1, 64]; with N_t > 1 the faded and measured rates are refused (no faded sample of
      a multi-antenna flight is modelled; per slot: ``MISOControl-v0``'s Rician ``channel``), naming
      the world's rule.
    - ``star_bits`` (a ``ScenarioConfig`` field of the STAR surface; None): b-bit phases, an
      integer in [1, 8] (``STARUAV-v0`` and ``STARUAV-Random-v0``: ``gym.make(id, star_bits=2)``),
      the rate above; the faded and measured rates, NOMA (``star_access="noma"``) and several
      antennas are refused with them, each naming what runs. The STAR surface's protocol and
      phase model stay out of a TDMA rate with bits too (as keywords: refused as doing nothing).
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
    >>> env = gym.make("ios_uav_env/STARUAV-v0", star_bits=2)  # the node's exact 2-bit phases per slot
    >>> env.unwrapped.config.star_bits, env.reset(seed=0)[0].shape
    (2, (11,))

    ```

    ## Version History

    * v0: Initial version; later, without changing v0's episodes or observations:
      ``reset(options={"config": cfg})``, ``instance_features`` and ``peak_hint``; then a flat
      ``info`` with fixed keys (``INFO_KEYS``) and registration without a ``TimeLimit``; then
      ``info``'s ``power``, ``energy``, ``energy_efficiency`` and ``reward_energy`` (0 here),
      and the energy objective (ids ``ios_uav_env/IOSUAV-Energy-v0`` and
      ``ios_uav_env/IOSUAV-Energy-Random-v0``: the energy features, the energy reward); then
      moving, roughly known nodes (``knowledge``, ``report_sigma``, ``config.motion``; id
      ``ios_uav_env/IOSUAV-Mobile-v0``); then the energy objective with them; then the
      multi-antenna UAV (``antennas``; id ``ios_uav_env/MISOUAV-v0``), one antenna unchanged;
      then b-bit phases on the STAR surface (``star_bits``), continuous phases unchanged.
    """

    preset = {"view": "v0"}

    def __init__(
        self,
        config: ScenarioConfig | Mapping[str, Any] | None = None,
        *,
        render_mode: str | None = None,
        **kwargs: Any,
    ) -> None:
        super().__init__(config, **self.preset, render_mode=render_mode, **kwargs)
