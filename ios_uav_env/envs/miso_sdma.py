"""The SDMA flight's stepper: the view ``"miso_sdma"``, read with the action ``"move_weight"``.

``UAVEnv`` (``ios_uav_env.envs.core.env``) runs its episodes through :class:`MisoSdmaStepper` when
its view is ``"miso_sdma"`` (the ids ``ios_uav_env/MISOUAV-SDMA-v0`` and
``ios_uav_env/MISOUAV-SDMA-Random-v0``; the contract is the class's docstring). It is the NOMA
STAR flight's stepper (``envs.star_noma``) on another link: the same moves, weights, reward,
observation layout and score, the slot served by the multi-antenna UAV's beams.

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

from ios_uav_env.envs.registration import MISO_SDMA_ID, MISO_SDMA_RANDOM_ID
from ios_uav_env.envs.star_control import BASE_CONFIG
from ios_uav_env.envs.star_noma import StarNomaStepper, check_two_user_world
from ios_uav_env.envs.star_noma_rows import StarNomaRows
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.miso import slot_bounds, tdma_rates, weighted_sum_bound
from ios_uav_env.model.miso_sdma import (
    check_sdma_scenario,
    lattice_index,
    slot_channel_at,
    slot_setting,
    weight_lattice,
)

__all__ = [
    "OBSERVATION_NAMES", "SDMA_CONFIG", "SDMA_USERS", "MisoSdmaRows", "MisoSdmaStepper",
    "check_sdma_env_scenario",
]  # fmt: skip

#: The two users: user 0 behind the surface (transmission) at (10, -10) m, user 1 on the UAV's side
#: at (-120, -10) m, far apart along the array's axis x, so the four antennas see them at
#: different angles and serving both at once beats one at a time.
SDMA_USERS = ((10.0, -10.0), (-120.0, -10.0))
#: The scenario of the SDMA ids: ``STARControl-v0``'s (an 8 x 8 IOS low on a facade, plane x = 0,
#: -110 dBm, the UAV from (-250, -150) to (-250, 150) m in 16 s) with a 4-antenna UAV and
#: :data:`SDMA_USERS`.
SDMA_CONFIG = BASE_CONFIG.replace(ground_nodes=SDMA_USERS, antennas=4)


def check_sdma_env_scenario(config: ScenarioConfig, env_id: str, field: str = "config") -> None:
    """``ValueError`` naming ``env_id`` and ``field`` unless ``config`` is a scenario the SDMA env
    runs: N_t >= 2 antennas, two static ground nodes, an IOS of at most ``miso_sdma.MAX_ELEMENTS``
    elements, the rate objective without an energy budget (the world's checks:
    ``components.World``)."""
    if config.antennas < 2:
        raise ValueError(
            f"{env_id} ({field}): antennas must be an integer in [2, 64] (the UAV serves both users at "
            f"once with its beams), got {config.antennas} (one antenna: ios_uav_env/IOSUAV-MultiNode-v0)"
        )
    if config.K != 2:
        raise ValueError(
            f"{env_id} ({field}): ground_nodes must be two users (the action weighs user 0 against user 1), "
            f"got K = {config.K}"
        )
    check_two_user_world(config, env_id, field, sdma=True)
    try:
        check_sdma_scenario(config, field)
    except ValueError as err:
        raise ValueError(f"{env_id} ({err})") from None


#: The observation's features (``MisoSdmaStepper``'s docstring), per user k = 0, 1 the last four.
OBSERVATION_NAMES = (
    "sdma_x", "sdma_y", "sdma_dx_final", "sdma_dy_final", "sdma_dx_surface", "sdma_dy_surface",
    "sdma_time_left", "sdma_slack",
    *(f"sdma_{f}_{k}" for k in (0, 1) for f in ("dx_user", "dy_user", "rate_alone", "rate")),
)  # fmt: skip
LATTICE = weight_lattice(2)


class MisoSdmaRows(StarNomaRows):
    """B episodes of the SDMA flight (module docstring). ``points`` is not used (the lattice
    is fixed: ``model.miso_sdma.LATTICE_LEVELS``); ``score`` and ``length_scale`` as the NOMA rows'."""

    def slot(self, i: int, x: float, y: float, w: float) -> tuple[float, float, float, np.ndarray]:
        """Row ``i``'s slot at (``x``, ``y``) m at the lattice weight nearest (``w``, 1 - ``w``):
        (that weight of user 0, w . R of its setting, the certified ``miso.weighted_sum_bound`` of
        the slot at it, the rates R (2,)); ``alone[i]``: each user alone (``miso.tdma_rates``)."""
        channel = slot_channel_at(self.configs[i], np.array([x, y]))
        weights = LATTICE[lattice_index(np.array([w, 1.0 - w]), LATTICE)]
        self.alone[i] = tdma_rates(channel)
        rates = slot_setting(channel, weights, self.alone[i])
        value = float(weights @ rates)
        # a user alone attains the bound (rank one): the two then differ by rounding at the most
        upper = max(weighted_sum_bound(slot_bounds(channel).gains, weights), value)
        return float(weights[0]), value, upper, rates


class MisoSdmaStepper(StarNomaStepper):
    r"""A multi-antenna UAV flies past an IOS and serves two users at once (SDMA); the agent flies
    and weighs the two users, the env sets the beams and the surface's phases.

    ## Description

    The scenario (``SDMA_CONFIG``; ``docs/model.md``, "Multi-antenna UAV"): an IOS of 8 x 8
    elements in the plane x = 0, centre 5 m up; user 0 at (10, -10) m (behind it, served by
    transmission), user 1 at (-120, -10) m (the UAV's side); the UAV (100 m up, 4 antennas, a
    lambda / 2 ULA along x, noise -110 dBm) flies from q0 = (-250, -150) m to qF = (-250, 150) m
    in T = 16 s (N = 16 slots of dt = 1 s, moves of at most D = v_max dt = 25 m). In every slot the
    UAV serves both users at once: two beams of total power P and one setting of the surface's
    phases. The id ``MISOUAV-SDMA-Random-v0`` draws the line's x uniformly in [-250, -100] m at
    every reset (``STARControl-v0``'s lines).

    **The control and its derivation.** Every Pareto-optimal rate pair of the slot's region with
    time sharing maximises a weighted sum w R_0 + (1 - w) R_1 for some w in [0, 1]
    (``model.regions``, "Dual"). The agent gives w; the env takes the nearest point of the
    weight lattice (w_0 = 0, 1/8, ..., 1: ``model.miso_sdma.weight_lattice``) and sets that
    weight's setting (``model.miso_sdma.slot_setting``): the per-slot alternating optimisation of
    the weighted sum rate (weighted WMMSE beams and closed-form phase updates, from each user's
    aligned phases with MRT and ZF), or one user served alone if that is better at the weight.
    These settings are the ones ``score_plan`` credits the slot with, so the flight's own rates are
    a point of the scorer's region. One setting per slot, no time sharing inside it.

    ## Action Space

    ``Box(-1, 1, (3,), float32)``: (a_x, a_y) the slot's move in units of D (a longer vector is
    scaled onto the unit disk), then the move goes through the arrival guard (``model.guard``: it
    keeps q_N = qF reachable, so every flight is feasible); a_w gives user 0's weight
    w = (clip(a_w, -1, 1) + 1) / 2 (user 1's: 1 - w), rounded to the lattice. A NaN/inf action or
    one of another shape raises ``ValueError``.

    ## Observation Space

    A float32 ``Box`` of 16 features (``observation_names``): the UAV position q / L, qF - q and the
    surface centre - q, / L (L = ``length_scale``, 400 m); the moves left / (N - 1); the slack
    s / (1 + |s|), s = moves left - |qF - q| / D; then per user k: its position - q, / L, its rate
    c_k(q) served alone with its aligned phases and MRT (bps/Hz; ``miso.tdma_rates``), and
    R_k = S_k / N, its rate so far (bps/Hz).

    ## Rewards

    The users' rates summed over the slots so far, S_k = sum_n R_k[n] (bps/Hz x slots); the
    reward of a step is min_k S_k after it minus min_k S_k before it (0 before slot 1): the return
    is N min_k R_k, N times the episode's own max-min rate ``info["min_rate"]`` (bps/Hz).

    ## Starting State

    The UAV at q0; slot 1 is served there at w = 1/2 (before any action). The first step's move
    and weight make slot 2, and the last step lands on qF.

    ## Episode End

    ``terminated`` after N - 1 steps (slot N, at qF); no truncation.

    ## Info

    ``slot`` (1 .. N), ``position_x``, ``position_y`` (m), ``distance_to_final`` (m), ``weight``
    (the lattice w of the slot), ``slot_rate_0``, ``slot_rate_1`` (the slot's rates, bps/Hz),
    ``slot_value`` (w R_0 + (1 - w) R_1 of the setting), ``slot_upper`` (a certified bound on
    the slot's best weighted sum over every beam set and surface setting,
    ``miso.weighted_sum_bound``), ``rate_0``, ``rate_1`` (R_k = S_k / N), ``min_rate``
    (min_k R_k), and ``score``: at slot N ``ios_uav_env.score_plan(config, trajectory).rate``,
    the flight's max-min with time sharing of the lattice settings in every slot
    (``model.miso_sdma.sdma_maxmin``), the number the planner ``dp-miso-sdma`` is scored by; 0
    before slot N, NaN at slot N with ``score=False`` (scoring runs 9 per-slot AOs a slot: several
    seconds a flight). ``min_rate`` <= ``score``: the env's settings are among the scorer's.

    ## Arguments

    - ``config``: the scenario (default ``SDMA_CONFIG``): ``antennas`` >= 2, two static ground
      nodes, an IOS of at most 256 elements; scenario fields as keywords.
    - ``random_line``: draw the line's x at every reset (the Random id; default False).
    - ``score``: whether slot N's ``info`` scores the flight (default True).
    - ``length_scale``: L (m) of the observation's lengths (default 400).

    ## Version History

    * v0: Initial version.
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
        super().__init__(env, config, random_line=random_line, score=score, render_mode=render_mode, **kwargs)

    def check_config(self, config: ScenarioConfig, env_id: str, field: str = "config") -> None:
        """``ValueError`` naming ``env_id`` and ``field`` unless the env runs ``config``
        (:func:`check_sdma_env_scenario`)."""
        check_sdma_env_scenario(config, env_id, field)
