"""The Gymnasium environment: one episode is one mission of the paper, one step is one slot.

The env is a thin adapter over the model (``ios_uav_env.channel`` and ``.trajectory``):
action -> next way-point (optionally through the arrival guard) -> rate -> reward. It never
re-derives a formula: the per-step rate is ``RateKernel.rate`` / ``RateKernel.faded_rate``,
the episode's score is ``average_rate`` (eq. (9)) and its feasibility ``check_trajectory``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ios_uav_env.channel import RateKernel, rate_kernel, slot_rates
from ios_uav_env.config import FEASIBILITY_TOL, ScenarioConfig, as_config, scenario_option
from ios_uav_env.guard import guarded_position
from ios_uav_env.observation import (
    INSTANCE_NAMES,
    OBS_NAMES,
    PEAK_NAMES,
    T_SCALE,
    check_fits,
    instance_values,
    observation_bounds,
    rate_upper_bound,
)
from ios_uav_env.peak import rate_peak
from ios_uav_env.trajectory import average_rate, check_trajectory

#: Values of the ``channel`` argument: the expected-gain rate (the paper's objective) or a
#: Rician faded-rate sample per slot.
CHANNELS: tuple[str, ...] = ("expected", "rician")

__all__ = [
    "CHANNELS",
    "INSTANCE_NAMES",
    "OBS_NAMES",
    "PEAK_NAMES",
    "IOSUAVEnv",
    "rate_upper_bound",
    "scenario_option",
]


class IOSUAVEnv(gym.Env):
    r"""A UAV flies from ``q0`` to ``qF`` in ``T`` seconds while serving a ground node G via an IOS.

    ## Description

    The scenario of Liu et al., "Full-Dimensional Rate Enhancement for UAV-Enabled
    Communications via Intelligent Omni-Surface" (IEEE WCL 2022); the model is
    ``shared/spec/model.md``. A UAV at altitude z_U sends to a ground node G through the
    direct link and an intelligent omni-surface (IOS) in the plane x = x_c, which serves G by
    reflection when the UAV is on G's side and by transmission from the other side; its
    phases are the closed-form optimum (eq. (13)), so the rate depends on the UAV position
    only. The agent plans the trajectory: one step is one slot (N - 1 steps from
    ``q[1] = q0``), and the paper's objective is the average rate of eq. (9) subject to
    eq. (10): arrive at ``qF`` at slot N with at most D = v_max dt per move. Ids:
    ``ios_uav_env/IOSUAV-v0`` (IOS), ``ios_uav_env/RISUAV-v0`` (reflect-only RIS) and
    ``ios_uav_env/UAV-v0`` (no surface). ``env.unwrapped.trajectory`` is the (n, 2) array
    of the way-points so far (m); every step's info has ``rate`` (the reward's rate term),
    ``expected_rate``, ``position`` (x, y), ``distance_to_final``, ``slot`` (the paper's
    1-based index n of the UAV's way-point q[n]) and ``rewards``.

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
    :func:`rate_upper_bound`. Together they make the problem Markov.

    With ``instance_features=True`` (the randomised id's default) 6 features that define the
    instance follow (names in ``INSTANCE_NAMES``): M / 6000 (0 without a surface), is-IOS and
    is-RIS flags, t / (1 + t) with t the transmissive factor (epsilon or 0), T / 200 s and the
    seconds left / 200 s: shape (17,). See ``ios_uav_env.random_env``.

    With ``peak_hint=True`` 3 more follow (names in ``PEAK_NAMES``): the reachable rate peak
    P of the scenario (``ios_uav_env.peak.rate_peak``: the best point a fly-hover-fly
    trajectory can visit) relative to the UAV, (P - q) / L, and its rate r(P) (bps/Hz). It
    is derived from the instance (no new information) and computed once per scenario.

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
    with R of eq. (9). ``info["rewards"]`` holds the three weighted terms, which sum to the
    reward: {"rate": rate, "reach": -w_reach reach, "terminal": -w_terminal terminal}.

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
    so this is a true terminal state. The env never truncates (``gym.make``'s ``TimeLimit`` of
    N - 1 steps flags ``truncated`` at that same step too; ``terminated`` is what counts), and
    a ``TimeLimit`` shorter than N - 1 steps is refused at reset (pass e.g.
    ``gym.make(..., T=300, max_episode_steps=299)``). The
    last step's info adds ``average_rate`` (eq. (9) over all N way-points), for "rician"
    ``mean_faded_rate`` (mean of the N faded samples), and the eq. (10) check: ``feasible``,
    ``terminal_miss`` (m), ``worst_violation`` (m) and the full ``report``.

    ## Arguments

    - ``config``: a ``ScenarioConfig`` (or a dict of its fields); default: the paper's.
    - ``channel``: "expected" (default, deterministic) or "rician".
    - ``arrival_guard`` (default True): projects the next position onto the intersection of
      the disk of radius D around q and the disk of radius m D around qF, so both limits hold
      at once and any action sequence gives a trajectory meeting eq. (10) (the last move lands
      exactly on qF; see ``ios_uav_env.guard``). On by default because the paper's
      constraints (10b)-(10c) are hard: an agent that learns them through penalties may still
      miss qF, and the guard turns the task into the paper's (maximise the rate over feasible
      trajectories). False leaves feasibility to the reward shaping.
    - ``reach_weight`` (1.0) and ``terminal_weight`` (2.0): the weights above. At the
      defaults a final miss of e moves costs 3 e + 2 sqrt(e), more than the rate it can win
      (the rate map's steepest slope is 1.5 bps/Hz per move at M = 6000).
    - ``length_scale`` (400.0 m): L of the observation.
    - ``instance_features`` (False): append the 6 instance features to the observation.
    - ``peak_hint`` (False): append the 3 features of the reachable rate peak.
    - ``render_mode``: None or "rgb_array" (the trajectory over the rate map; needs
      ``pip install ios-uav-env[render]``).
    - ``**overrides``: ``ScenarioConfig`` fields applied with ``config.replace``; the ids set
      ``surface`` this way, so ``config``'s surface is replaced by the id's.

    ```python
    >>> import gymnasium as gym
    >>> import ios_uav_env
    >>> env = gym.make("ios_uav_env/IOSUAV-v0", channel="rician", T=100, max_episode_steps=99)
    >>> obs, info = env.reset(seed=0)
    >>> obs.shape, info["slot"]
    ((11,), 1)

    ```

    ## Version History

    * v0: Initial version; later, without changing v0's observations: ``reset(options=
      {"config": cfg})``, ``instance_features`` and ``peak_hint`` (issue #6).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(
        self,
        config: ScenarioConfig | Mapping[str, Any] | None = None,
        *,
        channel: str = "expected",
        arrival_guard: bool = True,
        reach_weight: float = 1.0,
        terminal_weight: float = 2.0,
        length_scale: float = 400.0,
        instance_features: bool = False,
        peak_hint: bool = False,
        render_mode: str | None = None,
        **overrides: Any,
    ) -> None:
        config = as_config(config)
        self._base_config: ScenarioConfig = config.replace(**overrides) if overrides else config
        if channel not in CHANNELS:
            raise ValueError(f"channel must be one of {CHANNELS}, got {channel!r}")
        if not isinstance(arrival_guard, (bool, np.bool_)):
            raise ValueError(f"arrival_guard must be True or False, got {arrival_guard!r}")
        for name, value in (("reach_weight", reach_weight), ("terminal_weight", terminal_weight)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        if not (isinstance(length_scale, (int, float)) and math.isfinite(length_scale) and length_scale > 0):
            raise ValueError(f"length_scale must be a finite number > 0 (m), got {length_scale!r}")
        if not isinstance(instance_features, (bool, np.bool_)):
            raise ValueError(f"instance_features must be True or False, got {instance_features!r}")
        if not isinstance(peak_hint, (bool, np.bool_)):
            raise ValueError(f"peak_hint must be True or False, got {peak_hint!r}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, got {render_mode!r}"
            )
        self.channel = channel
        self.arrival_guard = bool(arrival_guard)
        self.reach_weight, self.terminal_weight = float(reach_weight), float(terminal_weight)
        self.length_scale = float(length_scale)
        self.render_mode = render_mode
        self.instance_features = bool(instance_features)
        self.peak_hint = bool(peak_hint)
        self._inv_l = 1.0 / self.length_scale
        self._rician = channel == "rician"
        self._renderer: Any = None
        self.config: ScenarioConfig | None = None  # the current episode's scenario
        self.kernel: RateKernel  # the rate kernel of self.config
        self._set_config(self._base_config)
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.observation_space = spaces.Box(*self._space_bounds(), dtype=np.float32)

        self._n: int | None = None  # moves made; None before the first reset
        self._x, self._y = self.config.q0
        self._xs: list[float] = []  # way-points so far (x, then y)
        self._ys: list[float] = []
        self._faded: list[float] = []

    # --- scenario and spaces --------------------------------------------------------------
    def _set_config(self, cfg: ScenarioConfig) -> None:
        """Make ``cfg`` the current scenario: its rate kernel and the observation's constants."""
        if cfg is self.config:
            return
        self.config = cfg
        self.kernel = rate_kernel(cfg)
        self._moves = cfg.N - 1
        self._D = cfg.D
        self._qf = cfg.qF
        points = (cfg.qF, cfg.ground_node, cfg.ios_center[:2])
        self._scaled = tuple(c * self._inv_l for p in points for c in p)  # the points / L
        self._inv_moves = 1.0 / self._moves
        self._instance = instance_values(cfg) if self.instance_features else ()
        self._peak: tuple[float, ...] = ()
        if self.peak_hint:
            peak = rate_peak(cfg)
            self._peak = (peak.x * self._inv_l, peak.y * self._inv_l, peak.rate)
        self._left_scale = cfg.dt / T_SCALE  # seconds left / T_SCALE per move left
        self.close()  # the renderer's rate map is the previous scenario's

    def _space_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) of the observation space: those of the construction config."""
        rate_high = rate_upper_bound(self.kernel)
        return observation_bounds(
            self._base_config, self.length_scale, self.instance_features, rate_high, self.peak_hint
        )

    def _episode_config(self, pinned: ScenarioConfig | None) -> ScenarioConfig:  # at reset
        return self._base_config if pinned is None else pinned

    def _horizon_moves(self, pinned: ScenarioConfig | None) -> int:  # an episode's most steps
        return (self._base_config if pinned is None else pinned).N - 1

    def _observe(self, x: float, y: float, left: int, dist: float, rate: float) -> np.ndarray:
        x, y = x * self._inv_l, y * self._inv_l
        fx, fy, gx, gy, cx, cy = self._scaled
        s = left - dist / self._D
        relative = (fx - x, fy - y, gx - x, gy - y, cx - x, cy - y)
        base = (x, y, *relative, left * self._inv_moves, s / (1.0 + abs(s)), rate)
        if self.peak_hint:
            px, py, peak_rate = self._peak
            hint: tuple[float, ...] = (px - x, py - y, peak_rate)
        else:
            hint = ()
        if self.instance_features:
            return np.array((*base, *self._instance, left * self._left_scale, *hint), dtype=np.float32)
        return np.array((*base, *hint), dtype=np.float32)

    # --- API ----------------------------------------------------------------------
    def check_time_limit(self, spec: Any, config: ScenarioConfig | None = None) -> None:
        """Raise ``ValueError`` if ``spec.max_episode_steps`` would cut an episode (on ``config``
        if given, the one pinned at reset) before slot N."""
        limit = getattr(spec, "max_episode_steps", None)
        moves = self._horizon_moves(config)
        if limit is not None and limit < moves:
            what = "" if config is None else f" (options config: T={config.T:g} s, dt={config.dt:g} s)"
            raise ValueError(
                f"max_episode_steps={limit} would truncate the episode before it reaches slot N: this "
                f"env's episodes{what} last up to N - 1 = {moves} steps; "
                f"pass max_episode_steps={moves} to gym.make"
            )

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        pinned = scenario_option(options)
        self.check_time_limit(self.spec, pinned)
        cfg = self._episode_config(pinned)
        if cfg is not self._base_config and cfg != self.config:  # may it leave the space?
            check_fits(cfg, self.length_scale, self.instance_features, self.observation_space, self.peak_hint)
        self._set_config(cfg)
        x, y = cfg.q0
        self._n, self._x, self._y = 0, x, y
        self._xs, self._ys = [x], [y]
        expected = self.kernel.rate(x, y)
        rate = expected
        if self._rician:
            rate = self.kernel.faded_rate(x, y, self.np_random)
            self._faded = [rate]
        dist = math.hypot(self._qf[0] - x, self._qf[1] - y)
        info = {"rate": rate, "expected_rate": expected, "position": (x, y),
                "distance_to_final": dist, "slot": 1}  # fmt: skip
        return self._observe(x, y, self._moves, dist, expected), info

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        n = self._n
        if n is None:
            raise RuntimeError("call reset() before step()")
        if n >= self._moves:
            raise RuntimeError(f"the episode ended at slot N = {self._moves + 1}; call reset()")
        if type(action) is np.ndarray and action.shape == (2,):
            ax, ay = action.tolist()
        else:
            ax, ay = self._parse_action(action)
        if not (math.isfinite(ax) and math.isfinite(ay)):
            raise ValueError(f"action must be finite (no NaN or inf), got {action!r}")
        norm2 = ax * ax + ay * ay
        if norm2 > 1.0:
            scale = 1.0 / math.sqrt(norm2)
            ax, ay = ax * scale, ay * scale
        D, (fx, fy) = self._D, self._qf
        x, y = self._x + D * ax, self._y + D * ay
        left = self._moves - n - 1  # moves left after this one
        if self.arrival_guard:
            x, y = guarded_position((self._x, self._y), (x, y), (fx, fy), D, left)
        self._n, self._x, self._y = n + 1, x, y
        self._xs.append(x)
        self._ys.append(y)

        expected = self.kernel.rate(x, y)
        rate = expected
        if self._rician:
            rate = self.kernel.faded_rate(x, y, self.np_random)
            self._faded.append(rate)
        dist = math.hypot(fx - x, fy - y)
        reach = max(0.0, dist - left * D - FEASIBILITY_TOL) / D
        terms = {"rate": rate, "reach": -self.reach_weight * reach if reach else 0.0, "terminal": 0.0}
        terminated = left == 0
        if terminated:
            miss = max(0.0, dist - FEASIBILITY_TOL) / D
            if miss:
                terms["terminal"] = -self.terminal_weight * (miss + math.sqrt(miss))
        reward = terms["rate"] + terms["reach"] + terms["terminal"]
        info = {"rate": rate, "expected_rate": expected, "position": (x, y),
                "distance_to_final": dist, "slot": n + 2, "rewards": terms}  # fmt: skip
        if terminated:
            self._final_info(info)
        return self._observe(x, y, left, dist, expected), reward, terminated, False, info

    def _parse_action(self, action: Any) -> tuple[float, float]:
        try:
            arr = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"action must be an array of shape (2,), got {action!r}") from exc
        if arr.shape != (2,):
            raise ValueError(f"action must have shape (2,) (x, y displacement / D), got shape {arr.shape}")
        return float(arr[0]), float(arr[1])

    def _final_info(self, info: dict[str, Any]) -> None:
        trajectory = self.trajectory
        report = check_trajectory(self.config, trajectory)
        info["average_rate"] = average_rate(self.config, trajectory)
        if self._rician:
            info["mean_faded_rate"] = float(np.mean(self._faded))
        info.update(feasible=report.feasible, terminal_miss=report.end_error,
                    worst_violation=report.worst_violation, report=report)  # fmt: skip

    @property
    def trajectory(self) -> np.ndarray:
        """The way-points so far, q[1] = q0 .. q[n+1], as an (n + 1, 2) array in metres."""
        return np.array((self._xs, self._ys), dtype=float).T.copy()

    def render(self) -> np.ndarray | None:
        """The trajectory so far over the rate map, as an (H, W, 3) uint8 array ("rgb_array")."""
        if self.render_mode is None:
            gym.logger.warn('render() needs render_mode="rgb_array" at construction; returning None')
            return None
        if self._renderer is None:
            from ios_uav_env.rendering import FrameRenderer

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
