"""The single-node stepper: one ground node, the v0 observation view, the 2-d move.

``UAVEnv`` (``ios_uav_env.envs.core.env``) runs its episodes through :class:`SingleNodeStepper`
when its view is ``"v0"`` (the ids of ``IOSUAVEnv`` and ``RandomIOSUAVEnv``, whose docstrings hold
the contract: spaces, rewards, ``info``). The stepper is a thin adapter over the model
(``ios_uav_env.model.channel`` and ``.trajectory``): action -> next way-point (optionally through
the arrival guard) -> rate -> reward, the per-step rate ``RateKernel.rate`` /
``RateKernel.faded_rate`` in the compiled kernels of ``single_kernels`` on a batch of one, and the
score of a finished episode ``average_rate`` (eq. (9)) of ``trajectory``. It holds the episode's
state and makes the single-node row protocol's calls (``row_protocol.SingleNodeRow``); its
generator is its env's ``np_random``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ios_uav_env.envs.core.kernel import flags_of
from ios_uav_env.envs.knowledge import NodeTrack, mobile_bounds
from ios_uav_env.envs.observation import check_fits, space_bounds
from ios_uav_env.envs.observation_layout import observation_names
from ios_uav_env.envs.options import EnvOptions, EnvViews, split_kwargs
from ios_uav_env.envs.settings import (
    check_config_keywords,
    check_scenario_overrides,
    check_world,
    several_nodes_error,
    single_node_id,
)
from ios_uav_env.envs.single_kernels import INFO, STATE, episode_row, reset_rows, step_rows
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

__all__ = ["INFO_KEYS", "SingleNodeStepper"]


class SingleNodeStepper(MobileNode, EnvViews):
    """The single-node stepper: one node, the v0 observation view and the 2-d move (module docstring)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}
    #: The observation view and the action type of this stepper (``core.stepper.VIEWS``).
    view, action = "v0", "move"

    def __init__(
        self,
        env: gym.Env,
        config: ScenarioConfig | Mapping[str, Any] | None = None,
        *,
        render_mode: str | None = None,
        **kwargs: Any,
    ) -> None:
        #: The env whose episodes this stepper runs (its ``np_random`` is the stepper's generator).
        self.env = env
        options, overrides = split_kwargs(kwargs, f"{type(env).__name__}.__init__")
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

    # --- options (read-only views of self.options; the common ones: EnvViews) ---------------
    instance_features = property(lambda self: self.options.instance_features)
    peak_hint = property(lambda self: self.options.peak_hint)

    # --- the env as one row of the step kernel (what the batched env copies) -------------------
    @property
    def flags(self) -> np.ndarray:
        """The kernel's option flags of this env (``core.kernel.flags_of(options)``)."""
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
        gym.Env.reset(self.env, seed=seed)
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

    # --- the stepper's interface (core.stepper.Stepper) ------------------------------------
    def start(self) -> tuple[np.ndarray, dict[str, Any]]:
        """The rest of ``reset`` after :meth:`begin_episode`: the UAV at q0 in slot 1, the node's
        path (mobile), slot 1's fading (Rician); the first observation and ``info``."""
        cfg = self.config
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
        """One slot of the move ``action``: Gymnasium's (observation, reward, terminated, truncated
        (never), ``info``)."""
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
        """Close the renderer's figure (rebuilt on the next ``render()``)."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_renderer"] = None  # a matplotlib figure; rebuilt on the next render()
        return state
