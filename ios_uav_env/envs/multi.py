"""Several ground nodes: an env where the agent flies the UAV and schedules the nodes (TDMA).

``MultiNodeEnv`` (a preset of ``UAVEnv``: ``view="node_blocks"``; the ids
``ios_uav_env/IOSUAV-MultiNode-v0``, ``-Random-v0`` and ``-Mobile-v0`` are ``UAVEnv`` with that
view) follows the model of ``ios_uav_env.model.schedule``: node k's rate in slot n is the
single-node expected-gain rate r_k(q[n]) (``config.node_config(k)``), slot n is shared by TDMA
shares alpha_k[n] and the objective is min_k R_k, R_k = (1/N) sum_n alpha_k[n] r_k(q[n]). The
agent chooses the shares itself; the episode's score is its own ``min_k R_k``
(``scheduled_rates``), never above the trajectory's best-schedule score (``maxmin_rate``), which
the last step reports beside it. Movement, the arrival guard and the feasibility shaping are the
single env's. The transition (``multi_node.MultiNodeStepper``) is the kernel of
``ios_uav_env.envs.multi_kernels`` on a batch of one, the one that the batched env runs on B
rows. The energy objective and the Rician channel: the class docstring and
``ios_uav_env.envs.multi_energy``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ios_uav_env.envs.core.env import UAVEnv
from ios_uav_env.envs.multi_features import (
    BASE_FEATURES,
    DEFAULT_NODES,
    NODE_FEATURES,
    NODE_PEAK_FEATURES,
    rate_potential,
    share_scores,
)
from ios_uav_env.envs.multi_table import MULTI_INFO_KEYS, node_peaks
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.scenarios import MULTINODE_RANGES, sample_multinode

__all__ = [
    "BASE_FEATURES", "DEFAULT_NODES", "MULTINODE_RANGES", "MULTI_INFO_KEYS", "NODE_FEATURES",
    "NODE_PEAK_FEATURES", "MultiNodeEnv", "node_peaks", "rate_potential", "sample_multinode", "share_scores",
]  # fmt: skip


class MultiNodeEnv(UAVEnv):
    r"""A UAV flies from ``q0`` to ``qF`` and shares every slot between K ground nodes (TDMA).

    ``UAVEnv`` with the view ``"node_blocks"`` and the move-and-scores action (a preset: the
    multi-node ids are ``UAVEnv`` with these keywords, ``registration``); the stepper is
    ``multi_node.MultiNodeStepper``. This docstring is the view's contract.

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

    preset = {"view": "node_blocks"}

    def __init__(self, config: ScenarioConfig | Mapping[str, Any] | None = None, **kwargs: Any) -> None:
        super().__init__(config, **self.preset, **kwargs)
