"""The multi-antenna UAV's beams and the surface's phases as the agent's control, slot by slot.

A thin adapter over ``ios_uav_env.model.miso`` and ``.miso_slot``: the action is mapped to K beams
of total power P and M phase shifts, the reward is the slot's objective of that setting
(``miso.user_rates``, ``miso.objective_value``), and ``info`` carries the slot's per-slot AO value
(``miso_slot.slot_optimum``), its certified bound (``miso.slot_bounds``) and the baselines
(``miso.baselines``), so a policy is scored as a share of the per-slot AO value and of the bound.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ios_uav_env.envs.star_control import BASE_CONFIG, LENGTH_SCALE, N_SLOTS, X_RANGE, Y_SPAN
from ios_uav_env.model.array import ArrayConfig, link_response
from ios_uav_env.model.miso import (
    SlotChannel,
    aligned_phases,
    baselines,
    check_objective,
    objective_value,
    slot_bounds,
    slot_channels,
    user_rates,
)
from ios_uav_env.model.miso_fading import rician_slot_channels
from ios_uav_env.model.miso_noma import decoding_order, sic_rates
from ios_uav_env.model.miso_noma_slot import NomaSolution, noma_optimum
from ios_uav_env.model.miso_slot import SlotSolution, slot_optimum

#: The K <= 4 users (m; the first K of them), around the small surface of STARControl-v0's
#: scenario (an IOS, centre 5 m up in the plane x = 0, noise -110 dBm): users 0 and 2 on the UAV's
#: side (reflection), 1 and 3 behind the surface (transmission), spread along y so that the array,
#: whose axis is the flight's direction y, sees them at different angles.
USERS = ((-10.0, 10.0), (10.0, -10.0), (-10.0, -30.0), (10.0, 30.0))
ANTENNAS = (1, 8)  # N_t, the antennas the env takes
#: How the K users share the slot: linear precoding, every user treating the others as noise
#: ("sdma", ``miso.user_rates``), or superposition coding with SIC in the slot's decoding order
#: ("noma", ``miso_noma.sic_rates`` with ``miso_noma.decoding_order``).
ACCESS = ("sdma", "noma")
USER_COUNTS = (1, len(USERS))  # K
M_RANGE = (4, 64)  # M = M_y M_z, small enough for element-by-element control and a per-slot AO
#: The UAV's ULA: lambda / 2 spacing, its axis along y (the flight's direction), one far-field angle
#: to the surface's centre (``steering="centre"``: the UAV-surface channel is rank one).
ORIENTATION = math.pi / 2
#: The slot channels (``channel``): LoS, or one Rician draw per slot (``model.miso_fading``) with
#: the scattering "link" ("rician") or "element" ("rician_element").
CHANNELS: dict[str, str | None] = {"los": None, "rician": "link", "rician_element": "element"}
INFO_KEYS = (
    "slot", "uav_x", "uav_y", "rates", "value", "optimum", "bound", "mrt_aligned", "zf_aligned", "tdma",
    "return", "optimum_return", "bound_return", "pct_of_optimum", "pct_of_bound",
)  # fmt: skip


def _count(name: str, value: object, allowed: tuple[int, int], meaning: str) -> int:
    ok = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
    if not ok or not allowed[0] <= value <= allowed[1]:
        raise ValueError(
            f"{name} must be an integer in [{allowed[0]}, {allowed[1]}] ({meaning}), got {value!r}"
        )
    return int(value)


def _elements(value: object) -> tuple[int, int]:
    ok = isinstance(value, (tuple, list)) and len(value) == 2
    ok = ok and all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= 1 for v in value)
    if not ok or not M_RANGE[0] <= value[0] * value[1] <= M_RANGE[1]:
        raise ValueError(
            f"elements must be a surface shape (M_y, M_z) of two integers >= 1 with M = M_y M_z in "
            f"[{M_RANGE[0]}, {M_RANGE[1]}], got {value!r}"
        )
    return int(value[0]), int(value[1])


def wrap(theta: np.ndarray) -> np.ndarray:
    """Angles (rad) wrapped to [-pi, pi) and divided by pi: values in [-1, 1)."""
    return (np.mod(np.asarray(theta, dtype=np.float64) + np.pi, 2 * np.pi) - np.pi) / np.pi


class MISOControlEnv(gym.Env):
    r"""A multi-antenna UAV flies past a small IOS; the agent sets the K beams and the M phases.

    ## Description

    The multi-antenna UAV of ``docs/model.md`` ("Multi-antenna UAV"): N_t antennas (a lambda / 2
    ULA, its axis along y, the flight's direction) serve K users at once by linear precoding, through
    their direct LoS links and through an IOS of M = M_y M_z elements (4 to 64) whose phase shifts
    are one setting shared by every user. The scenario is STARControl-v0's small surface (the IOS in
    the plane x = 0, its centre 5 m up; UAV altitude 100 m; noise -110 dBm, the paper's radio
    otherwise) with the first K users of (-10, 10), (10, -10), (-10, -30), (10, 30) m (even
    indices on the UAV's side, served by reflection; odd ones behind the surface, by
    transmission). The UAV flies the straight line from (x, -150) to (x, 150) m over N = 16 slots,
    x drawn uniformly in [-250, -100] m at every reset: its path is given, not controlled. Every
    step the agent sets the slot's beams W = [w_1 ... w_K] (N_t x K complex) and phases psi (M)
    and is paid the slot's objective of that setting. Each slot's reward depends on that slot's
    setting only: a contextual bandit, as STARControl-v0.

    ## Action Space

    A ``Box(-1, 1, (2 N_t K + M,), float32)``, used in float64 as given (clipped to [-1, 1]):

    | Num                      | Action                                        | Min | Max |
    |--------------------------|-----------------------------------------------|-----|-----|
    | k N_t + n                | Re of A[n, k], antenna n of user k's beam     | -1  | 1   |
    | N_t K + k N_t + n        | Im of A[n, k]                                 | -1  | 1   |
    | 2 N_t K + m              | psi_m / pi, element m's phase shift (rad)     | -1  | 1   |

    The beams are W = A / ||A||_F: total power sum_k ||w_k||^2 = 1 (P), every beam set of full
    power is reachable (scale A into the box), and nothing is lost by spending all of P, since
    scaling every beam up raises every SINR_k = a / (b + 1 / c^2). A = 0 sends nothing (rates 0).
    Element m is ``model.surface.element_positions``' m-th. :meth:`action_of` maps a setting back.
    A NaN/inf action or one of another shape raises ``ValueError``.

    ## Observation Space

    A float32 ``Box(-1, 1, (3 + 4K + 2 N_t (K + 1) + K M,))``, names in
    ``env.unwrapped.observation_names``: the UAV position (x, y) / 400 m and the slot index
    n / (N - 1); each user's position relative to the surface's centre / 400 m; per user its
    surface share sqrt(N_t) S_k / (sqrt(N_t) S_k + ||d_k||) (S_k = sum_m |c_km|: what the surface can
    add to its amplitude against its direct row d_k) and its share G_k / sum_j G_j of the users'
    single-user gains (``miso.slot_bounds``); each user's direct row d_k / ||d_k|| (real parts,
    then imaginary); the steering vector to the surface a_c / sqrt(N_t) (real, imaginary); and per
    user the phases ``miso.aligned_phases`` (wrapped, / pi): with K = 1 the optimum is those
    phases with MRT (closed form), the phases of the action being that feature itself.

    ## Rewards

    reward = f(R_1, ..., R_K) of the slot's setting, R_k = ``miso.user_rates`` (bps/Hz; with
    ``access="noma"`` the SIC rates, see Arguments) and f the
    ``objective``: the sum rate (``"sum"``) or the smallest rate (``"maxmin"``). ``info`` holds
    ``rates`` (K,), ``value`` (the reward), ``bound`` (``miso.slot_bounds``, certified: no setting
    beats it), the scoring references ``optimum`` (``miso_slot.slot_optimum``'s AO value of the
    slot, warm-started from the previous slot's AO setting), ``mrt_aligned`` and ``zf_aligned``
    (``miso.baselines``: equal-power MRT / ZF with the best user's aligned phases; ZF NaN when
    N_t < K) and ``tdma`` (each user alone in its share of the slot), the episode's ``return``,
    ``optimum_return`` and ``bound_return`` so far, and ``pct_of_optimum`` and ``pct_of_bound``
    (100 return / optimum_return, / bound_return: at slot N the episode's score). At reset every
    value is 0 (``rates`` zeros). With ``optimum=False`` the references, ``optimum_return`` and
    ``pct_of_optimum`` are NaN throughout: training needs the reward only.

    ## Starting State

    The UAV at (x, -150) m, x ~ U[-250, -100] m from ``reset(seed=...)``'s generator (the only
    draw with ``channel="los"``; a Rician channel then draws every slot's fading from it, in
    ``model.miso_fading``'s order). ``env.unwrapped.config`` is the episode's scenario (the users
    as its nodes, the line as q0 -> qF), ``env.unwrapped.array`` the ``ArrayConfig``,
    ``env.unwrapped.positions`` the (N, 2) way-points and ``env.unwrapped.channels`` each slot's
    ``miso.SlotChannel`` (the drawn ones with a Rician ``channel``).

    ## Episode End

    ``terminated`` after N = 16 steps (slots); no truncation.

    ## Arguments

    - ``antennas``: N_t in [1, 8]; default 4.
    - ``users``: K in [1, 4]; default 2.
    - ``elements``: the surface shape (M_y, M_z), M in [4, 64]; default (4, 4).
    - ``objective``: ``"sum"`` (default) or ``"maxmin"`` (``miso.SLOT_OBJECTIVES``).
    - ``channel``: ``"los"`` (default: the LoS channels), ``"rician"`` or ``"rician_element"``: one
      Rician draw per slot (Rician factor kappa = 3, ``model.miso_fading.rician_slot_channels``)
      with the scattering ``"link"`` (the paper's eqs. (4)-(8) per antenna: the UAV-surface channel
      stays rank one) or ``"element"`` (i.i.d. per element and antenna: a full-rank UAV-surface
      channel, on which the aligned phases with MRT are no longer the K = 1 optimum). The reward,
      the bound and the references are those of the drawn channel; the observation's steering
      vector stays the LoS one.
    - ``access``: ``"sdma"`` (default: linear precoding, each user treating the others' signals as
      noise, ``miso.user_rates``) or ``"noma"`` (superposition coding with SIC,
      ``miso_noma.sic_rates``): the action is still the beams and the phases, and the env decodes
      in the slot's stated order ``miso_noma.decoding_order`` (ascending single-user gain bound
      G_k, which the observation's gain shares give), so the reward is the objective of the SIC
      rates, ``optimum`` is ``miso_noma_slot.noma_optimum``'s AO value (warm-started as above) and
      ``bound`` is the same ``miso.slot_bounds`` (it bounds the SIC rates too); ``mrt_aligned``,
      ``zf_aligned`` and ``tdma`` stay the linear-precoding and TDMA references. The default
      leaves every output of the SDMA env unchanged.
    - ``optimum``: whether ``info`` carries the scoring references, the per-slot AO value and the
      baselines (default True). The AO costs hundredths to tenths of a second a slot, far more
      than the step (``benchmarks/miso_control.py`` prints both): train without it, score with it.

    >>> import gymnasium as gym
    >>> import ios_uav_env
    >>> env = gym.make("ios_uav_env/MISOControl-v0", antennas=2, users=2, elements=(4, 4))
    >>> obs, info = env.reset(seed=0)
    >>> obs.shape, env.action_space.shape
    ((55,), (24,))

    ## Version History

    * v0: Initial version.
    """

    metadata = {"render_modes": []}

    def __init__(
        self,
        antennas: int = 4,
        users: int = 2,
        elements: tuple[int, int] = (4, 4),
        objective: str = "sum",
        optimum: bool = True,
        channel: str = "los",
        access: str = "sdma",
    ) -> None:
        self.n_t = _count("antennas", antennas, ANTENNAS, "N_t, the UAV's antennas")
        self.K = _count("users", users, USER_COUNTS, "K, the users served at once")
        shape = _elements(elements)
        check_objective(objective)
        if not isinstance(optimum, bool):
            raise ValueError(f"optimum must be True or False, got {optimum!r}")
        if not (isinstance(channel, str) and channel in CHANNELS):
            raise ValueError(f"channel must be one of {tuple(CHANNELS)}, got {channel!r}")
        if not (isinstance(access, str) and access in ACCESS):
            raise ValueError(f"access must be one of {ACCESS} (how the users share the slot), got {access!r}")
        self.access = access
        self.objective, self.with_optimum, self.channel = objective, optimum, channel
        self.array = ArrayConfig(n_t=self.n_t, orientation_rad=ORIENTATION)
        self.config = self._base = BASE_CONFIG.replace(ios_shape=shape, ground_nodes=USERS[: self.K])
        self.M = shape[0] * shape[1]
        self.action_space = spaces.Box(-1.0, 1.0, (2 * self.n_t * self.K + self.M,), np.float32)
        names = ["miso_uav_x", "miso_uav_y", "miso_slot"]
        names += [f"miso_user_{k}_{a}" for k in range(self.K) for a in ("dx", "dy")]
        names += [f"miso_surface_share_{k}" for k in range(self.K)]
        names += [f"miso_gain_share_{k}" for k in range(self.K)]
        names += [f"miso_direct_{k}_{part}_{n}" for k in range(self.K) for part in ("re", "im")
                  for n in range(self.n_t)]  # fmt: skip
        names += [f"miso_steering_{part}_{n}" for part in ("re", "im") for n in range(self.n_t)]
        names += [f"miso_aligned_{k}_{m}" for k in range(self.K) for m in range(self.M)]
        self.observation_names = tuple(names)
        self.observation_space = spaces.Box(-1.0, 1.0, (len(names),), np.float32)
        self.channels: list[SlotChannel] = []
        self.positions = np.zeros((N_SLOTS, 2))
        self.slot = 0
        self.solution: SlotSolution | NomaSolution | None = None  # the last slot's AO setting (warm start)
        self._steering: np.ndarray | None = None  # (N, N_t) the LoS a_c of a Rician episode
        self._totals = np.zeros(3)  # return, optimum return (NaN without the optimum), bound return

    # -- the episode --------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        if options:
            raise ValueError(f"options must be None or empty (this env takes none), got {options!r}")
        x = float(self.np_random.uniform(*X_RANGE))
        self.config = self._base.replace(q0=(x, Y_SPAN[0]), qF=(x, Y_SPAN[1]))  # the episode's line
        self.positions = np.column_stack([np.full(N_SLOTS, x), np.linspace(*Y_SPAN, N_SLOTS)])
        scattering = CHANNELS[self.channel]
        if scattering is None:
            self.channels, self._steering = slot_channels(self.config, self.array, self.positions), None
        else:
            self.channels = rician_slot_channels(
                self.config, self.array, self.positions, self.np_random, scattering
            )
            uav = np.column_stack([self.positions, np.full(N_SLOTS, self.config.uav_altitude)])
            self._steering = link_response(self.array, uav, np.asarray(self.config.ios_center))
        self.slot, self.solution = 0, None
        self._totals = np.array([0.0, 0.0 if self.with_optimum else math.nan, 0.0])
        start = 0.0 if self.with_optimum else math.nan
        refs = dict.fromkeys(("optimum", "mrt_aligned", "zf_aligned", "tdma"), start)
        return self._observation(), self._info(np.zeros(self.K), refs, 0.0)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict]:
        if not self.channels:
            raise RuntimeError("call reset() before step()")
        if self.slot >= N_SLOTS:
            raise RuntimeError("the episode has ended: call reset()")
        ch = self.channels[self.slot]
        phases, beams = self.setting(action)
        rates = self.rates(ch, phases, beams)
        value = objective_value(rates, self.objective)
        bound = slot_bounds(ch).of(self.objective)
        refs = self._references(ch)
        self._totals += (value, refs["optimum"], bound)
        info = self._info(rates, refs, bound)
        self.slot += 1
        return self._observation(), float(value), self.slot == N_SLOTS, False, info

    def rates(self, channel: SlotChannel, phases: np.ndarray, beams: np.ndarray) -> np.ndarray:
        """The users' rates (K,) bps/Hz of a setting under the env's ``access``: ``miso.user_rates``
        (SDMA) or ``miso_noma.sic_rates`` in ``miso_noma.decoding_order(channel)`` (NOMA)."""
        H = channel.matrix(phases)
        if self.access == "noma":
            return sic_rates(H, beams, decoding_order(channel))
        return user_rates(H, beams)

    # -- the action ---------------------------------------------------------------------------
    def setting(self, action: Any) -> tuple[np.ndarray, np.ndarray]:
        """The phases psi (M,) rad and beams W (N_t, K) of ``action`` (the class docstring)."""
        a = np.asarray(action, dtype=np.float64)
        if a.shape != self.action_space.shape or not np.all(np.isfinite(a)):
            raise ValueError(
                f"action must be a finite array of shape {self.action_space.shape}, got {action!r}"
            )
        a = np.clip(a, -1.0, 1.0)
        width = self.n_t * self.K
        A = (a[:width] + 1j * a[width : 2 * width]).reshape(self.K, self.n_t).T
        norm = float(np.linalg.norm(A))
        beams = A / norm if norm > 0 else np.zeros_like(A)
        return np.pi * a[2 * width :], beams

    def action_of(self, phases: np.ndarray, beams: np.ndarray) -> np.ndarray:
        """An action that gives (``phases``, ``beams``), the beams scaled to full power: the
        inverse of :meth:`setting` up to rounding (e.g. for ``miso_slot.slot_optimum``'s setting)."""
        W = np.asarray(beams, dtype=complex)
        if W.shape != (self.n_t, self.K):
            raise ValueError(f"beams must have shape ({self.n_t}, {self.K}) (N_t, K), got {W.shape}")
        columns = W.T.reshape(-1)
        peak = float(np.max(np.abs(np.concatenate([columns.real, columns.imag])), initial=0.0))
        scaled = columns / peak if peak > 0 else columns
        return np.concatenate([scaled.real, scaled.imag, wrap(np.asarray(phases, dtype=np.float64))])

    # -- what the agent sees ------------------------------------------------------------------
    def _observation(self) -> np.ndarray:
        n = min(self.slot, N_SLOTS - 1)
        ch, q = self.channels[n], self.positions[n]
        centre = np.asarray(self.config.ios_center[:2])
        users = (np.asarray(USERS[: self.K]) - centre) / LENGTH_SCALE
        surface = math.sqrt(self.n_t) * np.abs(ch.coef).sum(axis=1)
        direct = np.linalg.norm(ch.direct, axis=1)
        gains = slot_bounds(ch).gains
        unit = ch.direct / np.where(direct > 0, direct, 1.0)[:, None]
        steering = (ch.to_elements[0] if self._steering is None else self._steering[n]) / math.sqrt(self.n_t)
        parts = [
            [*(q / LENGTH_SCALE), n / (N_SLOTS - 1)], users.ravel(),
            surface / np.where(surface + direct > 0, surface + direct, 1.0),
            gains / gains.sum() if gains.sum() > 0 else np.full(self.K, 1.0 / self.K),
            np.concatenate([unit.real, unit.imag], axis=1).ravel(), steering.real, steering.imag,
            *(wrap(aligned_phases(ch, k)) for k in range(self.K)),
        ]  # fmt: skip
        return np.clip(np.concatenate([np.asarray(p, dtype=np.float64) for p in parts]), -1.0, 1.0).astype(
            np.float32
        )

    def _references(self, ch: SlotChannel) -> dict[str, float]:
        """The slot's scoring references: the AO value (warm-started from the previous slot's AO
        setting, kept in ``solution``) and the baselines; NaN without ``optimum``."""
        if not self.with_optimum:
            return dict.fromkeys(("optimum", "mrt_aligned", "zf_aligned", "tdma"), math.nan)
        if self.access == "noma":
            self.solution = noma_optimum(ch, self.objective, warm=self.solution)
        else:
            self.solution = slot_optimum(ch, self.objective, warm=self.solution)
        base = baselines(ch, self.objective, np.random.default_rng(0))  # (its random draw unused)
        return {"optimum": self.solution.value, "mrt_aligned": base["MRT aligned"],
                "zf_aligned": base["ZF aligned"], "tdma": base["TDMA"]}  # fmt: skip

    def _info(self, rates: np.ndarray, refs: dict[str, float], bound: float) -> dict[str, Any]:
        q = self.positions[min(self.slot, N_SLOTS - 1)]
        ret, best, top = (float(v) for v in self._totals)
        if math.isnan(best):
            pct = math.nan
        else:
            pct = 100.0 * ret / best if best > 0 else 0.0
        return {
            "slot": int(self.slot), "uav_x": float(q[0]), "uav_y": float(q[1]),
            "rates": np.asarray(rates, dtype=np.float64).copy(),
            "value": float(objective_value(rates, self.objective)),
            "optimum": float(refs["optimum"]), "bound": float(bound),
            "mrt_aligned": float(refs["mrt_aligned"]), "zf_aligned": float(refs["zf_aligned"]),
            "tdma": float(refs["tdma"]),
            "return": ret, "optimum_return": best, "bound_return": top,
            "pct_of_optimum": pct,
            "pct_of_bound": 100.0 * ret / top if top > 0 else 0.0,
        }  # fmt: skip
