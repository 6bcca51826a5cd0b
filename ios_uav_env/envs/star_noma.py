"""The NOMA STAR flight's stepper: the view ``"star_noma"``, read with the action ``"move_weight"``.

``UAVEnv`` (``ios_uav_env.envs.core.env``) runs its episodes through :class:`StarNomaStepper` when
its view is ``"star_noma"`` (the ids ``ios_uav_env/STARUAV-NOMA-v0`` and
``ios_uav_env/STARUAV-NOMA-Random-v0``; the contract is the class's docstring). The episode is
one row of ``star_noma_rows.StarNomaRows``, the rows ``UAVVectorEnv`` runs B of, so the batched
env's row i is this env seeded ``seed + i`` bit for bit.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ios_uav_env.envs.observation import ground_free_rate_bound, length_bounds, pad
from ios_uav_env.envs.options import EnvOptions, EnvViews, split_kwargs
from ios_uav_env.envs.registration import STAR_NOMA_ID, STAR_NOMA_RANDOM_ID
from ios_uav_env.envs.settings import check_config_keywords, check_scenario_overrides, check_world
from ios_uav_env.envs.star_control import BASE_CONFIG, X_RANGE, Y_SPAN
from ios_uav_env.envs.star_noma_rows import OBSERVATION_NAMES, StarNomaRows
from ios_uav_env.model.config import ScenarioConfig, as_config, scenario_option
from ios_uav_env.model.star_maps import FRONTIER_POINTS

__all__ = ["NOMA_CONFIG", "StarNomaStepper", "check_noma_scenario", "check_two_user_world"]

#: The scenario of the NOMA ids: ``STARControl-v0``'s (an 8 x 8 STAR surface low on a facade, plane
#: x = 0, users (-5, 2) and (5, -2) m, -110 dBm, the UAV from (-250, -150) to (-250, 150) m in
#: 16 s), as a STAR surface serving both users at once: ``benchmarks/star_dp.py``'s "star-control".
NOMA_CONFIG = BASE_CONFIG.replace(surface="star", star_access="noma")
_NAME = "StarNomaStepper"


def check_noma_scenario(config: ScenarioConfig, env_id: str, field: str = "config") -> None:
    """``ValueError`` naming ``env_id`` and ``field`` unless ``config`` is a scenario the NOMA env
    runs: surface ``"star"`` with ``star_access="noma"``, two static ground nodes on opposite sides
    of the surface plane, the rate objective without an energy budget (the world's own checks:
    ``components.World``)."""
    if config.surface != "star" or config.star_access != "noma":
        raise ValueError(
            f"{env_id} ({field}): the env serves a user on each side of a STAR surface by NOMA, so it "
            f"needs surface='star' and star_access='noma', got surface={config.surface!r}, "
            f"star_access={config.star_access!r} (TDMA: ios_uav_env/IOSUAV-MultiNode-v0 on the config)"
        )
    check_two_user_world(config, env_id, field, noma=True)
    x_c = config.ios_center[0]
    xs = [x for x, _ in config.nodes]
    if (xs[0] - x_c) * (xs[1] - x_c) >= 0:
        raise ValueError(
            f"{env_id} ({field}): ground_nodes must be one user on each side of the surface plane "
            f"x = {x_c:g} m (off it), got x = {xs[0]:g} and {xs[1]:g} m"
        )


def check_two_user_world(config: ScenarioConfig, env_id: str, field: str, **link: bool) -> None:
    """``ValueError`` naming ``env_id`` and ``field`` for an energy budget (the two-user envs score
    the max-min rate without one), then the world's checks (``settings.check_world`` with ``link``:
    ``noma=True`` or ``sdma=True``)."""
    if config.energy_budget_j is not None:
        raise ValueError(
            f"{env_id} ({field}): energy_budget_j must be None (the env scores the max-min rate without "
            f"an energy budget), got {config.energy_budget_j!r}"
        )
    check_world(config, EnvOptions(), env_id, field, **link)


class StarNomaStepper(EnvViews):
    r"""A UAV flies past a STAR surface that serves a user on each side at once (NOMA); the agent
    flies and weighs the two users, the env sets the surface and the power split.

    ## Description

    The scenario (``NOMA_CONFIG``; ``docs/model.md``, "STAR surfaces"): a STAR surface of
    8 x 8 elements in the plane x = 0, centre 5 m up, energy splitting with independent continuous
    phases; user 0 at (-5, 2) m (the UAV's side), user 1 at (5, -2) m; the UAV (100 m up, noise
    -110 dBm) flies from q0 = (-250, -150) m to qF = (-250, 150) m in T = 16 s (N = 16 slots of
    dt = 1 s, moves of at most D = v_max dt = 25 m). In every slot the surface serves both users
    by NOMA: one surface setting (per element the amplitudes (u^r, u^t), (u^r)^2 + (u^t)^2 <= 1,
    each side's phases aligned to its user) and a power split, the stronger user decoding by SIC.
    The id ``STARUAV-NOMA-Random-v0`` draws the line's x uniformly in [-250, -100] m at every
    reset (``STARControl-v0``'s lines).

    **The control and its derivation.** The slot's best setting depends on how the two users are
    traded: every Pareto-optimal rate pair (R_0, R_1) of the slot maximises a weighted sum
    w R_0 + (1 - w) R_1 for some w in [0, 1] (the slot's region with time sharing is convex:
    ``model.regions``, "Dual"). So the agent gives w and the env sets the slot's weighted-sum
    optimum at (w, 1 - w): with each side's phases aligned the reachable amplitudes (A_0, A_1)
    form a convex set whose Pareto frontier is traced by u_m proportional to (cos phi a_m^0,
    sin phi a_m^1), phi in [0, pi / 2], and the env takes the best of ``frontier_points``
    equally spaced angles with the best power split (``star_maps.FrontierMaps.weighted_sum``:
    ``slot_value`` = w R_0 + (1 - w) R_1 of that setting, at most the slot's f_w, ``slot_upper``
    a certified bound on f_w). One setting per slot, no time sharing inside it: the agent reaches
    the region's other points by changing w over the slots.

    ## Action Space

    ``Box(-1, 1, (3,), float32)``: (a_x, a_y) the slot's move in units of D (a longer vector is
    scaled onto the unit disk), then the move goes through the arrival guard (``model.guard``: it
    keeps q_N = qF reachable, so every flight is feasible); a_w gives user 0's weight
    w = (clip(a_w, -1, 1) + 1) / 2 (user 1's: 1 - w). A NaN/inf action or one of another shape
    raises ``ValueError``.

    ## Observation Space

    A float32 ``Box`` of 16 features (``observation_names``): the UAV position q / L, qF - q and the
    surface centre - q, / L (L = ``length_scale``, 400 m); the moves left / (N - 1); the slack
    s / (1 + |s|), s = moves left - |qF - q| / D; then per user k: its position - q, / L, its rate
    c_k(q) = log2(1 + eta (a_D^k + sum_m a_m^k)^2) with the whole surface and all the power
    (bps/Hz; ``FrontierMaps.full_snr``), and R_k = S_k / N, its rate so far (bps/Hz).

    ## Rewards

    The users' rates summed over the slots so far, S_k = sum_n R_k[n] (bps/Hz x slots); the
    reward of a step is min_k S_k after it minus min_k S_k before it (0 before slot 1), as the
    multi-node ids' max-min term: the return is N min_k R_k, N times the episode's own max-min rate
    ``info["min_rate"]`` (bps/Hz).

    ## Starting State

    The UAV at q0; slot 1 is served there at w = 1/2 (before any action). The first step's move
    and weight make slot 2, and the last step lands on qF.

    ## Episode End

    ``terminated`` after N - 1 steps (slot N, at qF); no truncation.

    ## Info

    ``slot`` (1 .. N), ``position_x``, ``position_y`` (m), ``distance_to_final`` (m), ``weight``
    (w of the slot), ``slot_rate_0``, ``slot_rate_1`` (the slot's rates, bps/Hz), ``slot_value``
    and ``slot_upper`` (above), ``rate_0``, ``rate_1`` (R_k = S_k / N), ``min_rate`` (min_k R_k),
    and ``score``: at slot N ``ios_uav_env.score_plan(config, trajectory).rate``, the flight's
    max-min with the best setting, power split and time sharing in every slot
    (``star_regions.scenario_maxmin``), the number the planners (``dp-star``) are scored by; 0
    before slot N (as the multi-node ids' ``best_schedule_rate``), NaN at slot N with
    ``score=False`` (scoring takes about 1 s a flight at 64 elements). ``min_rate`` <=
    ``score``: the env's own settings are among the scorer's.

    ## Arguments

    - ``config``: the scenario (default ``NOMA_CONFIG``): surface ``"star"``, ``star_access="noma"``
      and two static ground nodes on opposite sides of the plane; scenario fields as keywords.
    - ``random_line``: draw the line's x at every reset (the Random id; default False).
    - ``frontier_points``: the frontier angles of the weighted-sum optimum (>= 2; default 65).
    - ``score``: whether slot N's ``info`` scores the flight (default True).
    - ``length_scale``: L (m) of the observation's lengths (default 400).

    ## Version History

    * v0: Initial version.
    """

    view, action = "star_noma", "move_weight"
    #: The fixed id and the Random id (``random_line``), the default scenario, the rows' class and
    #: the observation's names: what a stepper of the same design on another link replaces.
    ids: tuple[str, str] = (STAR_NOMA_ID, STAR_NOMA_RANDOM_ID)
    default_config: ScenarioConfig = NOMA_CONFIG
    rows_class: type = StarNomaRows
    names: tuple[str, ...] = OBSERVATION_NAMES
    surfaces: tuple[str, ...] = ("star",)

    def __init__(
        self,
        env: gym.Env,
        config: ScenarioConfig | Mapping[str, Any] | None = None,
        *,
        random_line: bool = False,
        frontier_points: int = FRONTIER_POINTS,
        score: bool = True,
        render_mode: str | None = None,
        **kwargs: Any,
    ) -> None:
        self.env = env
        options, overrides = split_kwargs(kwargs, f"{_NAME}.__init__")
        default = EnvOptions()
        inert = sorted(k for k, v in options.items() if k != "length_scale" and v != getattr(default, k))
        if inert:
            raise ValueError(
                f"{inert[0]} is an option this env does not have: the NOMA STAR flight runs the expected-"
                "gain link, static and exactly known users and the arrival guard (it takes only "
                "length_scale of the env options)"
            )
        self.options = EnvOptions(**options)
        for name, flag in (("random_line", random_line), ("score", score)):
            if not isinstance(flag, (bool, np.bool_)):
                raise ValueError(f"{name} must be True or False, got {flag!r}")
        bad = isinstance(frontier_points, bool) or not isinstance(frontier_points, (int, np.integer))
        if bad or frontier_points < 2:
            raise ValueError(
                f"frontier_points must be an integer >= 2 (frontier angles), got {frontier_points!r}"
            )
        if render_mode is not None:
            raise ValueError(f"render_mode must be None (this env does not render), got {render_mode!r}")
        self.render_mode = None
        self.random_line = bool(random_line)
        self.env_id = self.ids[1] if self.random_line else self.ids[0]
        if self.random_line and (config is not None or {"q0", "qF"} & set(overrides)):
            raise ValueError(
                f"{self.env_id} draws its line (q0, qF) at every reset: give no config, q0 or qF "
                f"(one scenario: {self.ids[0]})"
            )
        # kappa, epsilon, bandwidth_hz, propulsion do nothing here (no fading, no IOS, no energy);
        # the STAR protocol and phase model are checked by the config (NOMA: "es", "independent")
        own = {k: v for k, v in overrides.items() if k not in ("star_protocol", "star_phases")}
        check_scenario_overrides(self.env_id, own, self.surfaces, fades=False, multinode=True)
        base = self.default_config if config is None else as_config(config)
        if config is not None:  # (the keywords replace the id's own scenario's fields freely)
            check_config_keywords(self.env_id, base, overrides)
        self._base = base.replace(**overrides) if overrides else base
        self.check_config(self._base, self.env_id)
        self.config = self._base
        self.observation_names: tuple[str, ...] = self.observation_layout(self._base.K)
        #: The episode as a row (``StarNomaRows`` of one: the batched env runs B of them).
        self.rows = self.rows_class(
            1, int(frontier_points), bool(score), self.options.length_scale, self._base.K
        )
        self.action_space = spaces.Box(-1.0, 1.0, (self.rows.action_size,), np.float32)
        low, high = self._bounds(self._base)
        self.observation_space = spaces.Box(low, high, dtype=np.float32)
        self._obs = np.zeros((1, len(self.observation_names)), dtype=np.float32)
        self._reward, self._terminated = np.zeros(1), np.zeros(1, dtype=np.bool_)
        self._table = np.zeros((1, self.rows.info_width))
        self._active = np.ones(1, dtype=np.bool_)
        self._started = False

    def observation_layout(self, users: int) -> tuple[str, ...]:
        """The observation's names for ``users`` users (two here: :attr:`names`)."""
        return self.names

    def _bounds(self, config: ScenarioConfig) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) of the observation over the episodes of ``config`` (over every line drawn
        with ``random_line``): lengths from ``observation.length_bounds`` (no position is farther
        than (N - 1) D from q0), rates below ``observation.ground_free_rate_bound`` of each user
        served alone (c_k, and so R_k <= max_n c_k), whatever the UAV's position."""
        fixed = ((config.q0[0],) * 2, (config.q0[1],) * 2)
        final = ((config.qF[0],) * 2, (config.qF[1],) * 2)
        if self.random_line:
            fixed, final = (X_RANGE, (Y_SPAN[0],) * 2), (X_RANGE, (Y_SPAN[1],) * 2)
        points = [final, ((config.ios_center[0],) * 2, (config.ios_center[1],) * 2)]
        points += [((x,) * 2, (y,) * 2) for x, y in config.nodes]
        scale = self.options.length_scale
        lengths = [pad(v / scale) for v in length_bounds(fixed, points, (config.N - 1) * config.D)]
        users = range(config.K)
        rate = pad(max(ground_free_rate_bound(config.node_config(k)) for k in users))
        blocks = [[*lengths[6 + 2 * k : 8 + 2 * k], rate, rate] for k in users]
        high = np.array([*lengths[:6], 1.0, 1.0, *(v for block in blocks for v in block)])
        low = -high
        low[6] = 0.0  # the moves left
        for k in users:  # and the rates
            low[10 + 4 * k : 12 + 4 * k] = 0.0
        if not np.all(np.isfinite(high.astype(np.float32))):
            raise ValueError(
                f"length_scale must be >= {max(lengths) * scale / 1e38:g} m here (the observation's "
                f"lengths over it overflow float32), got {scale!r}"
            )
        return low.astype(np.float32), high.astype(np.float32)

    # --- the row protocol -----------------------------------------------------------------
    def begin_episode(self, seed: int | None, options: dict[str, Any] | None) -> ScenarioConfig:
        """The scenario part of ``reset``: seed ``np_random``, choose the episode's scenario (pinned
        by ``options["config"]``, the line drawn (``random_line``) or the env's own), check it."""
        gym.Env.reset(self.env, seed=seed)
        pinned = scenario_option(options)
        if pinned is not None:
            self.check_scenario(pinned)
            self.config = pinned
        elif self.random_line:
            x = float(self.np_random.uniform(*X_RANGE))
            self.config = self._base.replace(q0=(x, Y_SPAN[0]), qF=(x, Y_SPAN[1]))
        else:
            self.config = self._base
        return self.config

    def check_scenario(self, cfg: ScenarioConfig, field: str = 'options["config"]') -> None:
        """``ValueError`` naming ``field`` unless the pinned ``cfg`` is a scenario this env runs."""
        self.check_config(cfg, self.env_id, field)
        if cfg.K != self._base.K:
            raise ValueError(
                f"{field}: ground_nodes must be K = {self._base.K} users (this env's spaces), got K = {cfg.K}"
            )
        low, high = self._bounds(cfg)
        if np.any(low < self.observation_space.low) or np.any(high > self.observation_space.high):
            raise ValueError(
                f"{field}: the scenario does not fit this env's observation space; make an env on it"
            )

    def check_config(self, config: ScenarioConfig, env_id: str, field: str = "config") -> None:
        """``ValueError`` naming ``env_id`` and ``field`` unless the env runs ``config``
        (:func:`check_noma_scenario`)."""
        check_noma_scenario(config, env_id, field)

    def start(self) -> tuple[np.ndarray, dict[str, Any]]:
        """The rest of ``reset``: slot 1 at q0; the first observation and ``info``."""
        self.rows.load(0, self)
        self.rows.start(np.zeros(1, dtype=np.int64), self._obs, self._table)
        self._started = True
        return self._obs[0].copy(), self._info()

    def _info(self) -> dict[str, Any]:
        return {key: value[0] for key, value in self.rows.info_arrays(self._table.copy()).items()}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """One slot of the move and weight ``action``: Gymnasium's five outputs."""
        a = self.checked_action(action, self._started, self.rows.state[0, 2] >= self.config.N - 1)
        outputs = (self._obs, self._reward, self._terminated, self._table)
        self.rows.step(a[None], self._active, outputs)
        terminated = bool(self._terminated[0])
        return self._obs[0].copy(), float(self._reward[0]), terminated, False, self._info()

    @property
    def trajectory(self) -> np.ndarray:
        """The way-points so far, (n + 1, 2) m."""
        return self.rows.trajectory(0) if self._started else np.zeros((0, 2))

    @property
    def shares(self) -> None:
        """None: no TDMA shares (``score_plan`` scores a NOMA flight with the best time sharing of
        its trajectory; ``rollout.run_episode`` reads this as the multi-node envs' shares)."""
        return None

    @property
    def weights(self) -> np.ndarray:
        """The weights each slot was served at so far: for two users user 0's, (n + 1,) (slot 1's:
        1/2), for K > 2 every user's, (n + 1, K)."""
        n = int(self.rows.state[0, 2]) + 1 if self._started else 0
        w = self.rows.weights[0, :n].copy()
        return w[:, 0] if self.rows.k == 2 else w

    def render(self) -> np.ndarray | None:
        """No frames: this env does not render (``render_mode`` None)."""
        return None

    def close(self) -> None:
        """Nothing to close."""
