"""The SDMA flight's stepper: the view ``"miso_sdma"``, read with the action ``"move_weight"``.

``UAVEnv`` (``ios_uav_env.envs.core.env``) runs its episodes through :class:`MisoSdmaStepper` when
its view is ``"miso_sdma"`` (the ids ``ios_uav_env/MISOUAV-SDMA-v0``,
``ios_uav_env/MISOUAV-SDMA-Random-v0`` and, for three and four users, ``-K3-v0`` and ``-K4-v0``;
the contract is the class's docstring). It is the NOMA STAR flight's stepper (``envs.star_noma``)
on another link and for K = 2 to 4 users: the same moves, weights (one per user for K > 2),
reward, observation layout (a block per user) and score, the slot served by the multi-antenna
UAV's beams.

:class:`MisoSdmaRows` holds B episodes of the view (the stepper holds one row; ``UAVVectorEnv``
holds B, so the batched env's row i is this env seeded ``seed + i`` bit for bit): the NOMA STAR
flight's rows (``star_noma_rows.StarNomaRows``: the moves, the arrival guard, the users'
cumulative rates, the reward and the score) with the multi-antenna UAV's slot. A slot is served at
the lattice weight nearest the agent's (``model.miso_sdma.lattice_index``) with that weight's
setting (``model.miso_sdma.slot_setting``: the weighted-sum AO of the beams and the surface's
phases, or a user alone), on the slot channel built for the row's one position
(``slot_channel_at``), so a row's numbers never depend on the other rows and each slot's rates
are one of the settings ``score_plan`` credits that slot (``model.miso_sdma.slot_points``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np

from ios_uav_env.envs.registration import MISO_SDMA_ID, MISO_SDMA_K3_ID, MISO_SDMA_K4_ID, MISO_SDMA_RANDOM_ID
from ios_uav_env.envs.star_control import BASE_CONFIG
from ios_uav_env.envs.star_noma import StarNomaStepper, check_two_user_world
from ios_uav_env.envs.star_noma_rows import StarNomaRows
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.miso import slot_bounds, tdma_rates, weighted_sum_bound
from ios_uav_env.model.miso_sdma import (
    LATTICE_LEVELS,
    check_sdma_scenario,
    lattice_index,
    slot_channel_at,
    slot_setting,
    weight_lattice,
)

__all__ = [
    "OBSERVATION_NAMES", "SDMA_CONFIG", "SDMA_CONFIGS", "SDMA_USERS", "MisoSdmaRows", "MisoSdmaStepper",
    "check_sdma_env_scenario", "observation_names",
]  # fmt: skip

#: The two users: user 0 behind the surface (transmission) at (10, -10) m, user 1 on the UAV's side
#: at (-120, -10) m, far apart along the array's axis x, so the four antennas see them at
#: different angles and serving both at once beats one at a time.
SDMA_USERS = ((10.0, -10.0), (-120.0, -10.0))
#: The scenario of the SDMA ids: ``STARControl-v0``'s (an 8 x 8 IOS low on a facade, plane x = 0,
#: -110 dBm, the UAV from (-250, -150) to (-250, 150) m in 16 s) with a 4-antenna UAV and
#: :data:`SDMA_USERS`.
SDMA_CONFIG = BASE_CONFIG.replace(ground_nodes=SDMA_USERS, antennas=4)
#: The scenario of K = 2, 3, 4 users (the keyword ``users``; the ids ``MISOUAV-SDMA-v0``, ``-K3-v0``,
#: ``-K4-v0``): :data:`SDMA_CONFIG` with users added on both sides of the surface and spread in
#: angle as the flight (x = -250 m, y from -150 to 150 m) sees them: user 2 at (-60, 50) m on the
#: UAV's side, north of the others, and user 3 at (20, 30) m behind the surface. The UAV keeps its
#: 4 antennas (N_t >= K: the AO's ZF start serves every user).
SDMA_CONFIGS: dict[int, ScenarioConfig] = {
    2: SDMA_CONFIG,
    3: SDMA_CONFIG.replace(ground_nodes=(*SDMA_USERS, (-60.0, 50.0))),
    4: SDMA_CONFIG.replace(ground_nodes=(*SDMA_USERS, (-60.0, 50.0), (20.0, 30.0))),
}
#: users -> the fixed id of that many users (their Random draws: ``MISOUAV-SDMA-Random-v0``, ``users``).
USERS_IDS = {2: MISO_SDMA_ID, 3: MISO_SDMA_K3_ID, 4: MISO_SDMA_K4_ID}


def check_sdma_env_scenario(config: ScenarioConfig, env_id: str, field: str = "config") -> None:
    """``ValueError`` naming ``env_id`` and ``field`` unless ``config`` is a scenario the SDMA env
    runs: N_t >= 2 antennas, K in [2, 4] static ground nodes (the scorer's weight lattices,
    ``model.miso_sdma.LATTICE_LEVELS``), an IOS of at most ``miso_sdma.MAX_ELEMENTS`` elements, the
    rate objective without an energy budget (the world's checks: ``components.World``)."""
    if config.antennas < 2:
        raise ValueError(
            f"{env_id} ({field}): antennas must be an integer in [2, 64] (the UAV serves the users at "
            f"once with its beams), got {config.antennas} (one antenna: ios_uav_env/IOSUAV-MultiNode-v0)"
        )
    if config.K not in LATTICE_LEVELS:
        raise ValueError(
            f"{env_id} ({field}): ground_nodes must be K in [{min(LATTICE_LEVELS)}, {max(LATTICE_LEVELS)}] "
            f"users (the weight lattices of model.miso_sdma), got K = {config.K}"
        )
    check_two_user_world(config, env_id, field, sdma=True)
    try:
        check_sdma_scenario(config, field)
    except ValueError as err:
        raise ValueError(f"{env_id} ({err})") from None


def observation_names(users: int = 2) -> tuple[str, ...]:
    """The observation's features (``MisoSdmaStepper``'s docstring) for ``users`` users: eight,
    then four per user k."""
    return (
        "sdma_x", "sdma_y", "sdma_dx_final", "sdma_dy_final", "sdma_dx_surface", "sdma_dy_surface",
        "sdma_time_left", "sdma_slack",
        *(f"sdma_{f}_{k}" for k in range(users) for f in ("dx_user", "dy_user", "rate_alone", "rate")),
    )  # fmt: skip


#: The observation's features of two users.
OBSERVATION_NAMES = observation_names(2)
#: users -> the weight lattice (J, K) of the slot's settings (``model.miso_sdma.weight_lattice``).
LATTICES = {k: weight_lattice(k) for k in LATTICE_LEVELS}


class MisoSdmaRows(StarNomaRows):
    """B episodes of the SDMA flight (module docstring). ``points`` is not used (the lattice
    is fixed: ``model.miso_sdma.LATTICE_LEVELS``); ``score`` and ``length_scale`` as the NOMA rows'."""

    def slot(self, i: int, x: float, y: float, w: np.ndarray) -> tuple[np.ndarray, float, float, np.ndarray]:
        """Row ``i``'s slot at (``x``, ``y``) m at the lattice weights nearest ``w`` (K,): (those
        weights, w . R of their setting, the certified ``miso.weighted_sum_bound`` of the slot at
        them, the rates R (K,)); ``alone[i]``: each user alone (``miso.tdma_rates``)."""
        channel = slot_channel_at(self.configs[i], np.array([x, y]))
        lattice = LATTICES[self.k]
        weights = lattice[lattice_index(w, lattice)]
        self.alone[i] = tdma_rates(channel)
        rates = slot_setting(channel, weights, self.alone[i])
        value = float(weights @ rates)
        # a user alone attains the bound (rank one): the two then differ by rounding at the most
        upper = max(weighted_sum_bound(slot_bounds(channel).gains, weights), value)
        return weights, value, upper, rates


class MisoSdmaStepper(StarNomaStepper):
    r"""A multi-antenna UAV flies past an IOS and serves K = 2, 3 or 4 users at once (SDMA); the
    agent flies and weighs the users, the env sets the beams and the surface's phases.

    ## Description

    The scenario (``SDMA_CONFIG``; ``docs/model.md``, "Multi-antenna UAV"): an IOS of 8 x 8
    elements in the plane x = 0, centre 5 m up; user 0 at (10, -10) m (behind it, served by
    transmission), user 1 at (-120, -10) m (the UAV's side); the UAV (100 m up, 4 antennas, a
    lambda / 2 ULA along x, noise -110 dBm) flies from q0 = (-250, -150) m to qF = (-250, 150) m
    in T = 16 s (N = 16 slots of dt = 1 s, moves of at most D = v_max dt = 25 m). In every slot the
    UAV serves every user at once: K beams of total power P and one setting of the surface's
    phases. ``users=3`` (``MISOUAV-SDMA-K3-v0``) adds user 2 at (-60, 50) m (the UAV's side),
    ``users=4`` (``MISOUAV-SDMA-K4-v0``) also user 3 at (20, 30) m (behind the surface)
    (``SDMA_CONFIGS``). The id ``MISOUAV-SDMA-Random-v0`` draws the line's x uniformly in
    [-250, -100] m at every reset (``STARControl-v0``'s lines), of ``users`` users.

    **The control and its derivation.** Every Pareto-optimal rate vector of the slot's region with
    time sharing maximises a weighted sum w . R for some w on the simplex (``model.regions``,
    "Dual"). The agent gives w; the env takes the nearest point (Euclidean, the first of ties) of
    the weight lattice (the simplex's points with coordinates multiples of 1 / L, L = 8, 4, 2 for
    K = 2, 3, 4: ``model.miso_sdma.weight_lattice``, 9, 15, 10 points) and sets that weight's
    setting (``model.miso_sdma.slot_setting``): the per-slot alternating optimisation of the
    weighted sum rate (weighted WMMSE beams and closed-form phase updates, from each user's
    aligned phases with MRT and ZF), or one user served alone if that is better at the weight.
    These settings are the ones ``score_plan`` credits the slot with, so the flight's own rates are
    a point of the scorer's region. One setting per slot, no time sharing inside it.

    ## Action Space

    ``Box(-1, 1, (3,), float32)`` for two users, ``Box(-1, 1, (2 + K,), float32)`` for K > 2:
    (a_x, a_y) the slot's move in units of D (a longer vector is scaled onto the unit disk), then
    the move goes through the arrival guard (``model.guard``: it keeps q_N = qF reachable, so every
    flight is feasible); then the weights, rounded to the lattice. Two users: a_w gives user 0's
    weight w = (clip(a_w, -1, 1) + 1) / 2 (user 1's: 1 - w). K > 2: a_0 .. a_{K-1}, one per user,
    give the normalised shifted scores w_k = p_k / sum_j p_j, p_k = (clip(a_k, -1, 1) + 1) / 2
    (1 / K each when every a_k is -1; ``StarNomaRows.action_weights``): a_k = -1 drops user k,
    equal a_k weigh the users alike. A NaN/inf action or one of another shape raises ``ValueError``.

    ## Observation Space

    A float32 ``Box`` of 8 + 4 K features (16, 20, 24; ``observation_names``): the UAV position
    q / L, qF - q and the surface centre - q, / L (L = ``length_scale``, 400 m); the moves left /
    (N - 1); the slack s / (1 + |s|), s = moves left - |qF - q| / D; then per user k (``sdma_*_k``):
    its position - q, / L, its rate c_k(q) served alone with its aligned phases and MRT (bps/Hz;
    ``miso.tdma_rates``), and R_k = S_k / N, its rate so far (bps/Hz).

    ## Rewards

    The users' rates summed over the slots so far, S_k = sum_n R_k[n] (bps/Hz x slots); the
    reward of a step is min_k S_k after it minus min_k S_k before it (0 before slot 1): the return
    is N min_k R_k, N times the episode's own max-min rate ``info["min_rate"]`` (bps/Hz).

    ## Starting State

    The UAV at q0; slot 1 is served there at the lattice point nearest (1 / K, ..., 1 / K) (before
    any action: w = 1/2 for two users, (1/2, 1/4, 1/4) for three, (1/2, 1/2, 0, 0) for four). The
    first step's move and weights make slot 2, and the last step lands on qF.

    ## Episode End

    ``terminated`` after N - 1 steps (slot N, at qF); no truncation.

    ## Info

    ``slot`` (1 .. N), ``position_x``, ``position_y`` (m), ``distance_to_final`` (m), the lattice
    weights of the slot (two users: ``weight``, user 0's; K > 2: ``weight_0`` .. ``weight_{K-1}``),
    ``slot_rate_k`` (the slot's rates, bps/Hz), ``slot_value`` (w . R of the setting),
    ``slot_upper`` (a certified bound on the slot's best weighted sum over every beam set and
    surface setting, ``miso.weighted_sum_bound``), ``rate_k`` (R_k = S_k / N), ``min_rate``
    (min_k R_k), and ``score``: at slot N ``ios_uav_env.score_plan(config, trajectory).rate``,
    the flight's max-min with time sharing of the lattice settings in every slot
    (``model.miso_sdma.sdma_maxmin``), the number the planner ``dp-miso-sdma`` is scored by; 0
    before slot N, NaN at slot N with ``score=False`` (scoring runs J per-slot AOs a slot: seconds
    a flight). ``min_rate`` <= ``score``: the env's settings are among the scorer's.

    ## Arguments

    - ``config``: the scenario (default ``SDMA_CONFIGS[users]``): ``antennas`` >= 2, K in [2, 4]
      static ground nodes, an IOS of at most 256 elements; scenario fields as keywords.
    - ``users``: K, 2, 3 or 4 (default: the config's K, or 2): the default scenario's users; a
      config or ``ground_nodes`` of another K is refused.
    - ``random_line``: draw the line's x at every reset (the Random id; default False).
    - ``score``: whether slot N's ``info`` scores the flight (default True).
    - ``length_scale``: L (m) of the observation's lengths (default 400).

    ## Version History

    * v0: Initial version (two users); then K = 3 and 4 (``users``, the K3 and K4 ids), the
      two-user episodes unchanged.
    """

    view = "miso_sdma"
    ids = (MISO_SDMA_ID, MISO_SDMA_RANDOM_ID)
    default_config = SDMA_CONFIG
    rows_class = MisoSdmaRows
    names = OBSERVATION_NAMES
    surfaces = ("ios",)

    def __init__(
        self,
        env: gym.Env,
        config: ScenarioConfig | Mapping[str, Any] | None = None,
        *,
        users: int | None = None,
        random_line: bool = False,
        score: bool = True,
        render_mode: str | None = None,
        **kwargs: Any,
    ) -> None:
        if "frontier_points" in kwargs:
            raise ValueError(
                "frontier_points is the NOMA STAR env's argument; the SDMA env's settings are the "
                "weight lattice's (model.miso_sdma.weight_lattice)"
            )
        if users is not None:
            bad = isinstance(users, bool) or not isinstance(users, (int, np.integer))
            if bad or users not in SDMA_CONFIGS:
                raise ValueError(
                    f"users must be an integer in [{min(SDMA_CONFIGS)}, {max(SDMA_CONFIGS)}] (the SDMA "
                    f"weight lattices of model.miso_sdma), got {users!r}"
                )
            self.default_config = SDMA_CONFIGS[int(users)]
            self.ids = (USERS_IDS[int(users)], MISO_SDMA_RANDOM_ID)
        super().__init__(env, config, random_line=random_line, score=score, render_mode=render_mode, **kwargs)
        if users is not None and self.config.K != users:
            raise ValueError(
                f"{self.env_id}: users={users}, but the scenario's ground_nodes are K = {self.config.K} "
                f"users (give one of the two, or both alike)"
            )

    def observation_layout(self, users: int) -> tuple[str, ...]:
        """The observation's names for ``users`` users (:func:`observation_names`)."""
        return observation_names(users)

    def check_config(self, config: ScenarioConfig, env_id: str, field: str = "config") -> None:
        """``ValueError`` naming ``env_id`` and ``field`` unless the env runs ``config``
        (:func:`check_sdma_env_scenario`)."""
        check_sdma_env_scenario(config, env_id, field)
