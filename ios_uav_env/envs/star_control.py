"""The STAR surface as the agent's control: each step the agent sets the surface's coefficients.

A thin adapter over ``ios_uav_env.model.star`` and ``.star_slot``: the action is mapped to a
setting (``star_control_rows.ControlMap``; phases quantised by ``star.quantise``), the reward is
the max-min rate of that setting (``star_slot.evaluate_rows`` on the slot's row, which is
``star_slot.evaluate``), and ``info`` carries the slot's optimum (``star_slot.slot_optima``: the
value and certified bound of ``slot_optimum``), so a policy is scored as a share of the per-slot
optimum. The batched form (``star_control_vector``) makes the same calls on B rows.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ios_uav_env.envs.star_control_rows import CONTROLS, ControlMap
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.star import StarChannels, StarSurface, path_channels
from ios_uav_env.model.star_rows import StarRows
from ios_uav_env.model.star_slot import evaluate_rows, slot_optima

#: The small-surface STAR scenario: a surface low on a facade (centre 5 m up, plane x = 0), the
#: paper's UAV altitude (100 m) and radio but for the noise: -110 dBm, the thermal noise of 1 MHz
#: with a 4 dB noise figure (the paper's -80 dBm leaves 16 elements at ~1e-5 bps/Hz); lambda / 2.
#: Its nodes are the two users and its q0 -> qF the line of an episode (x replaced at every reset).
USER_R = (-5.0, 2.0)  # m, the reflection user (the UAV's side of the plane)
USER_T = (5.0, -2.0)  # m, the transmission user (the other side)
Y_SPAN = (-150.0, 150.0)  # m, the line's start and end y
X_RANGE = (-250.0, -100.0)  # m, the line's x, drawn per episode
BASE_CONFIG = ScenarioConfig(
    ios_center=(0.0, 0.0, 5.0), ios_shape=(8, 8), noise_dbm=-110.0, T=16.0, ground_nodes=(USER_R, USER_T),
    q0=(X_RANGE[0], Y_SPAN[0]), qF=(X_RANGE[0], Y_SPAN[1]),
)  # fmt: skip
N_SLOTS = BASE_CONFIG.N  # slots of an episode (dt = 1 s; 20 m per slot <= v_max dt = 25 m)
LENGTH_SCALE = 400.0  # m, lengths in the observation are divided by it
M_RANGE = (16, 256)  # the surface sizes the env takes (element by element control)
PROTOCOLS = ("es", "ms")
ACCESS = ("tdma", "noma")
#: The users' features of the observation: each user relative to the surface's centre, scaled.
USERS_FEATURES = np.concatenate(
    [(np.asarray(user) - np.asarray(BASE_CONFIG.ios_center[:2])) / LENGTH_SCALE for user in (USER_R, USER_T)]
)
#: The keys of a setting the action expresses.
_SETTING = ("u_r", "u_t", "theta_r", "theta_t", "share", "split")
INFO_KEYS = (
    "slot", "uav_x", "uav_y", "rate_r", "rate_t", "value", "optimum", "optimum_upper", "return",
    "optimum_return", "pct_of_optimum",
)  # fmt: skip


def _elements(value: object) -> tuple[int, int]:
    ok = isinstance(value, (tuple, list)) and len(value) == 2
    ok = ok and all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= 1 for v in value)
    if not ok or not M_RANGE[0] <= value[0] * value[1] <= M_RANGE[1]:
        raise ValueError(
            f"elements must be a surface shape (M_y, M_z) of two integers >= 1 with M = M_y M_z in "
            f"[{M_RANGE[0]}, {M_RANGE[1]}], got {value!r}"
        )
    return int(value[0]), int(value[1])


class STARControlEnv(gym.Env):
    r"""A UAV flies past a small STAR surface; the agent sets the surface in every slot.

    ## Description

    A STAR surface (``docs/model.md``, "STAR surfaces") of M = M_y M_z elements (16 to 256, small
    enough to be set element by element) stands in the plane x = 0, its centre 5 m above the ground;
    user r at (-5, 2) m is on the UAV's side (reflection), user t at (5, -2) m on the other
    (transmission). The UAV (altitude 100 m; noise -110 dBm, the paper's radio otherwise) flies the
    straight line from (x, -150) to (x, 150) m over N = 16 slots at 20 m per slot, with x drawn
    uniformly in [-250, -100] m at every reset: the UAV's path is given, not controlled, and it
    stays on user r's side, so the roles never swap. The UAV-user links are blocked by default
    (``direct_link=False``, a usual assumption of the STAR literature): the users hear the UAV
    through the surface only, so the score measures the surface's control alone. With
    ``direct_link=True`` the paper's direct LoS paths (path-loss exponent 5) are kept; there 16 to
    256 elements add about 1% to 80% to a user's amplitude, and random phases already reach most of
    the optimum. A fixed line would let a policy memorise N settings from the slot index; drawing
    the line makes it read the channels. The agent is the surface's controller: every step it sets
    the slot's coefficients and is paid the slot's max-min rate min(R_r, R_t)
    (``star_slot.evaluate``). Phases are independent (theta^r, theta^t free).

    Access ``"tdma"`` (default): user r is served for a share tau of the slot and user t for the
    rest, each with the whole surface on its side (u^s = 1) and its own phases; the optimum is
    closed form (each side aligned, tau = c_t / (c_r + c_t)), so the score is exact, and the
    protocol does not enter (only ``"es"`` is taken). Access ``"noma"``: one setting serves both at
    once, with per element the amplitude split (``"es"``: (u^r, u^t) = (cos g, sin g)) or the mode
    (``"ms"``) and a power split p to user r; the optimum is the ES frontier's branch and bound
    (relative gap 1e-6) or MS's threshold search, about 0.05-0.15 s per slot.

    ## Action Space

    A ``Box(-1, 1, (A,), float32)``; the action is used in float64 as given (so a setting given
    as a float64 action, e.g. the optimum's through :meth:`action_of`, is scored to rounding).
    G = M / ``group`` groups; group k is elements k ``group`` ... (k + 1) ``group`` - 1
    (``model.surface.element_positions``' order: ``group`` adjacent elements of one column, along
    z), all set alike. Phases: theta = pi a, then ``star.quantise(theta, bits)`` (the nearest of
    the 2^b levels; unchanged with ``bits=None``). The table is ``control="direct"``'s; with
    ``control="residual"`` the phases are theta_m^s = phi_m^s + pi a (the aligned phases plus the
    action, then quantised) and the TDMA share tau = tau* + a / 2 clipped to [0, 1] (tau* the
    aligned sides' max-min share), so that a zero action is the aligned surface
    (``star_control_rows``' docstring).

    | Num       | Action                                            | access | Min | Max |
    |-----------|---------------------------------------------------|--------|-----|-----|
    | 0 .. G-1  | theta^r of group k, / pi                          | both   | -1  | 1   |
    | G .. 2G-1 | theta^t of group k, / pi                          | both   | -1  | 1   |
    | 2G        | TDMA share of user r, tau = (a + 1) / 2           | tdma   | -1  | 1   |
    | 2G .. 3G-1| ES: g = (a + 1) pi / 4; MS: transmit iff a > 0    | noma   | -1  | 1   |
    | 3G        | NOMA power fraction of user r, p = (a + 1) / 2    | noma   | -1  | 1   |

    A = 2G + 1 (TDMA) or 3G + 1 (NOMA). A NaN/inf action or one of another shape raises
    ``ValueError``.

    ## Observation Space

    A float32 ``Box(-1, 1, (8 [+ 2G],))``, names in ``env.unwrapped.observation_names``: the UAV
    position (x, y) / 400 m; users r and t relative to the surface's centre, / 400 m; the slot
    index n / (N - 1); user r's share c_r / (c_r + c_t) of the two users' rates served alone (the
    TDMA optimum's 1 - tau); and, with ``channel_phases=True`` (default), per group and side the
    phase of the group's channel, arg(sum_{m in k} a_m^s e^{j phi_m^s}) / pi in [-1, 1): with
    continuous phases and TDMA the optimal action is that feature itself. Without them the
    per-element phases, which wrap every wavelength (5 cm) of path difference, must be inferred
    from the UAV position: not learnable at a sensible budget, which is why they are on.

    ## Rewards

    reward = min(R_r, R_t) (bps/Hz) of the slot's setting, ``star_slot.evaluate``. ``info`` holds
    ``rate_r``, ``rate_t``, ``value`` (the reward), ``optimum`` and ``optimum_upper`` (the slot's
    ``slot_optimum`` value and certified upper bound: equal under TDMA), the episode's ``return``
    and ``optimum_return`` so far and ``pct_of_optimum`` = 100 return / optimum_return (at slot N:
    the episode's score as a % of the per-slot optimum). At reset every value is 0.

    ## Starting State

    The UAV at (x, -150) m, x ~ U[-250, -100] m from ``reset(seed=...)``'s generator (the only
    draw). ``env.unwrapped.config`` is the episode's scenario (the ``ScenarioConfig`` with the
    users as its nodes and the line as q0 -> qF), ``env.unwrapped.positions`` the UAV's (N, 2)
    way-points and ``env.unwrapped.channels`` each slot's ``StarChannels``.

    ## Episode End

    ``terminated`` after N = 16 steps (slots); no truncation.

    ## Arguments

    - ``elements``: the surface shape (M_y, M_z), M in [16, 256]; default (8, 8).
    - ``bits``: phase bits b in [1, 8], or None (default) for continuous phases.
    - ``group``: elements per group (default 1), a divisor of M_z.
    - ``protocol``: ``"es"`` (default) or ``"ms"`` (``"ms"`` with NOMA only).
    - ``access``: ``"tdma"`` (default) or ``"noma"``.
    - ``channel_phases``: whether the per-group channel phases are observed (default True).
    - ``direct_link``: whether the UAV-user LoS links exist (default False: blocked).
    - ``control``: ``"direct"`` (default) or ``"residual"`` (the action offsets the aligned surface).
    - ``optimum``: whether the per-slot optimum is computed for ``info`` (default True; False: its
      keys ``optimum``, ``optimum_upper``, ``optimum_return`` and ``pct_of_optimum`` are NaN, and
      NOMA's per-slot search, ~0.1 s a slot with ES, is skipped).

    >>> import gymnasium as gym
    >>> import ios_uav_env
    >>> env = gym.make("ios_uav_env/STARControl-v0", elements=(4, 4), bits=1)
    >>> obs, info = env.reset(seed=0)
    >>> obs.shape, env.action_space.shape
    ((40,), (33,))

    ## Version History

    * v0: Initial version.
    """

    metadata = {"render_modes": []}

    def __init__(
        self,
        elements: tuple[int, int] = (8, 8),
        bits: int | None = None,
        group: int = 1,
        protocol: str = "es",
        access: str = "tdma",
        channel_phases: bool = True,
        direct_link: bool = False,
        control: str = "direct",
        optimum: bool = True,
    ) -> None:
        shape = _elements(elements)
        if access not in ACCESS:
            raise ValueError(f"access must be one of {ACCESS}, got {access!r}")
        if protocol not in PROTOCOLS:
            raise ValueError(f"protocol must be one of {PROTOCOLS}, got {protocol!r}")
        if access == "tdma" and protocol != "es":
            raise ValueError(
                f"protocol must be 'es' with access='tdma' (each user gets the whole surface: every "
                f"protocol gives the same slot), got {protocol!r}"
            )
        if (
            isinstance(group, bool)
            or not isinstance(group, (int, np.integer))
            or group < 1
            or shape[1] % group
        ):
            raise ValueError(f"group must be an integer >= 1 dividing M_z = {shape[1]}, got {group!r}")
        if control not in CONTROLS:
            raise ValueError(f"control must be one of {CONTROLS}, got {control!r}")
        for name, flag in (
            ("channel_phases", channel_phases),
            ("direct_link", direct_link),
            ("optimum", optimum),
        ):
            if not isinstance(flag, bool):
                raise ValueError(f"{name} must be True or False, got {flag!r}")
        self.surface = StarSurface(protocol, "independent", bits)  # checks bits, naming it
        self.access, self.group, self.channel_phases = access, int(group), channel_phases
        self.direct_link, self.control, self.optimum = direct_link, control, optimum
        self.config = self._base = BASE_CONFIG.replace(ios_shape=shape)
        self.M = shape[0] * shape[1]
        self.G = self.M // self.group
        #: The action and observation maps (one row here, B rows in the batched form).
        self.map = ControlMap(
            self.M, self.group, access, protocol, self.surface.bits, control, channel_phases
        )
        self.action_space = spaces.Box(-1.0, 1.0, (self.map.width,), np.float32)
        names = ["star_uav_x", "star_uav_y", "star_user_r_dx", "star_user_r_dy", "star_user_t_dx",
                 "star_user_t_dy", "star_slot", "star_rate_share_r"]  # fmt: skip
        if channel_phases:
            names += [f"star_phase_{s}_{k}" for s in ("r", "t") for k in range(self.G)]
        self.observation_names = tuple(names)
        self.observation_space = spaces.Box(-1.0, 1.0, (len(names),), np.float32)
        self.channels: list[StarChannels] = []
        #: The episode's channels as rows, one per slot ((N, M) arrays).
        self.rows: StarRows | None = None
        self.positions = np.zeros((N_SLOTS, 2))
        self.slot = 0
        self._totals = np.zeros(2)  # return, optimum return

    # -- the episode --------------------------------------------------------------------------
    def begin_episode(self, seed: int | None, options: dict | None) -> ScenarioConfig:
        """The scenario part of :meth:`reset` (the row protocol of the batched form): seed, draw
        the line, build its slots' channels; no observation. Returns the episode's scenario."""
        super().reset(seed=seed)
        if options:
            raise ValueError(f"options must be None or empty (this env takes none), got {options!r}")
        x = float(self.np_random.uniform(*X_RANGE))
        self.config = self._base.replace(q0=(x, Y_SPAN[0]), qF=(x, Y_SPAN[1]))  # the episode's line
        self.positions = np.column_stack([np.full(N_SLOTS, x), np.linspace(*Y_SPAN, N_SLOTS)])
        self.channels = path_channels(self.config, self.positions, USER_R, USER_T)
        if not self.direct_link:  # blocked: the users hear the UAV through the surface only
            self.channels = [dataclasses.replace(ch, direct_r=0.0, direct_t=0.0) for ch in self.channels]
        self.rows = StarRows.of(self.channels)
        return self.config

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        self.begin_episode(seed, options)
        self.slot = 0
        self._totals = np.zeros(2)
        return self._observation(), self._info(0.0, 0.0, 0.0, 0.0)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict]:
        if self.rows is None:
            raise RuntimeError("call reset() before step()")
        if self.slot >= N_SLOTS:
            raise RuntimeError("the episode has ended: call reset()")
        base = self.rows.take([self.slot])
        rates = evaluate_rows(base, self.surface, self.access, self.map.settings(self._action(action), base))
        rate_r, rate_t = float(rates[0][0]), float(rates[1][0])
        if self.optimum:
            best, upper = (float(v[0]) for v in slot_optima(base, self.surface, self.access))
        else:
            best = upper = float("nan")
        value = min(rate_r, rate_t)
        self._totals += (value, best)
        info = self._info(rate_r, rate_t, best, upper)
        self.slot += 1
        return self._observation(), float(value), self.slot == N_SLOTS, False, info

    # -- the action ---------------------------------------------------------------------------
    def _action(self, action: Any) -> np.ndarray:
        """``action`` as a checked (1, A) float64 row."""
        a = np.asarray(action, dtype=np.float64)
        if a.shape != self.action_space.shape or not np.all(np.isfinite(a)):
            raise ValueError(
                f"action must be a finite array of shape {self.action_space.shape}, got {action!r}"
            )
        return a[None]

    def _slot_rows(self) -> StarRows:
        if self.rows is None:
            raise RuntimeError("call reset() before setting() or action_of()")
        return self.rows.take([min(self.slot, N_SLOTS - 1)])

    def setting(self, action: Any) -> dict[str, Any]:
        """The surface setting of ``action`` at the current slot (``star_slot.evaluate``'s keys),
        phases quantised."""
        out = self.map.settings(self._action(action), self._slot_rows())
        return {key: value[0] if value.ndim > 1 else float(value[0]) for key, value in out.items()}

    def action_of(self, setting: dict[str, Any]) -> np.ndarray:
        """The action that gives ``setting`` at the current slot (one value per group: its first
        element's), the inverse of :meth:`setting` on settings it can express (e.g.
        ``slot_optimum``'s at group 1)."""
        one = {
            key: np.asarray(value, dtype=np.float64)[None]
            for key, value in setting.items()
            if key in _SETTING
        }
        return self.map.actions_of(one, self._slot_rows())[0]

    # -- what the agent sees ------------------------------------------------------------------
    def _observation(self) -> np.ndarray:
        n = min(self.slot, N_SLOTS - 1)
        head = np.concatenate([self.positions[n] / LENGTH_SCALE, USERS_FEATURES, [n / (N_SLOTS - 1)]])
        return self.map.observations(self.rows.take([n]), head[None])[0]

    def _info(self, rate_r: float, rate_t: float, optimum: float, upper: float) -> dict[str, Any]:
        q = self.positions[min(self.slot, N_SLOTS - 1)]
        ret, best = (float(v) for v in self._totals)
        pct = 100.0 * ret / best if best > 0 else (float("nan") if np.isnan(best) else 0.0)
        return {
            "slot": int(self.slot), "uav_x": float(q[0]), "uav_y": float(q[1]), "rate_r": float(rate_r),
            "rate_t": float(rate_t), "value": float(min(rate_r, rate_t)), "optimum": float(optimum),
            "optimum_upper": float(upper), "return": ret, "optimum_return": best,
            "pct_of_optimum": pct,
        }  # fmt: skip
