"""The multi-node stepper: K >= 1 ground nodes, the node-block view, the move and the node scores.

``UAVEnv`` (``ios_uav_env.envs.core.env``) runs its episodes through :class:`MultiNodeStepper`
when its view is ``"node_blocks"`` (the ids of ``MultiNodeEnv``, whose docstring holds the
contract: spaces, shares, rewards, ``info``). It follows the model of
``ios_uav_env.model.schedule``: node k's rate in slot n is the single-node expected-gain rate
r_k(q[n]), slot n is shared by the agent's TDMA shares, and the score is min_k R_k. The
transition is the kernel of ``ios_uav_env.envs.multi_kernels`` on a batch of one, the one the
batched env runs on B rows. It holds the episode's state and makes the multi-node row protocol's
calls (``row_protocol.MultiNodeRow``; mixins ``multi_mobile.MobileNodes`` and
``multi_energy.EnergyChannel``); its generator is its env's ``np_random``.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ios_uav_env.envs.knowledge import NodesTrack
from ios_uav_env.envs.multi_energy import ENERGY_NAMES, EnergyChannel, check_options
from ios_uav_env.envs.multi_features import (
    BASE_FEATURES,
    DEFAULT_NODES,
    NODE_FEATURES,
    NODE_PEAK_FEATURES,
)
from ios_uav_env.envs.multi_kernels import NodeRows, track_kernels
from ios_uav_env.envs.multi_mobile import MobileNodes
from ios_uav_env.envs.multi_space import multinode_bounds, rate_high
from ios_uav_env.envs.multi_table import (
    BEST,
    info_arrays,
    info_columns,
    info_keys,
)
from ios_uav_env.envs.observation_layout import node_block_names
from ios_uav_env.envs.options import EnvOptions, EnvViews, split_kwargs
from ios_uav_env.envs.settings import (
    check_config_keywords,
    check_multinode_arguments,
    check_scenario_overrides,
    check_world,
    multinode_id,
    multinode_objective,
)
from ios_uav_env.model.config import ScenarioConfig, as_config, scenario_option
from ios_uav_env.model.scenarios import MULTINODE_RANGES, RANGED_FIELDS, ScenarioRanges, sample_multinode
from ios_uav_env.model.schedule import reported_maxmin_rate

__all__ = ["MultiNodeStepper"]


class MultiNodeStepper(MobileNodes, EnergyChannel, EnvViews):
    """The multi-node stepper (module docstring; the arguments: ``MultiNodeEnv``'s)."""

    #: The observation view and the action type of this stepper (``core.stepper.VIEWS``).
    view, action = "node_blocks", "move_scores"

    def __init__(
        self,
        env: gym.Env,
        config: ScenarioConfig | Mapping[str, Any] | None = None,
        *,
        max_nodes: int | None = None,
        share_sharpness: float = 5.0,
        softmin_beta: float = 0.0,
        random_nodes: tuple[int, int] | None = None,
        ranges: ScenarioRanges = MULTINODE_RANGES,
        render_mode: str | None = None,
        best_schedule: bool = True,
        **kwargs: Any,
    ) -> None:
        #: The env whose episodes this stepper runs (its ``np_random`` is the stepper's generator).
        self.env = env
        options, overrides = split_kwargs(kwargs, f"{type(env).__name__}.__init__")
        self.options = EnvOptions(**options)
        if not isinstance(best_schedule, (bool, np.bool_)):
            raise ValueError(f"best_schedule must be True or False, got {best_schedule!r}")
        #: Whether an episode's end computes ``info["best_schedule_rate"]`` (else NaN there).
        self.best_schedule = bool(best_schedule)
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        check_multinode_arguments(config, random_nodes, ranges, MULTINODE_RANGES, overrides)
        base = as_config(config if config is not None else ScenarioConfig(ground_nodes=DEFAULT_NODES))
        check_config_keywords(multinode_id(random_nodes, False), base, overrides)
        self._base = base.replace(**overrides) if overrides else base
        if random_nodes is not None:
            lo, hi = (int(v) for v in random_nodes)
            if not 1 <= lo <= hi:
                raise ValueError(
                    f"random_nodes must be (low, high) with 1 <= low <= high, got {random_nodes!r}"
                )
            random_nodes = (lo, hi)
        self.random_nodes = random_nodes
        unranged = {k: v for k, v in overrides.items() if k not in RANGED_FIELDS | {"ground_nodes"}}
        if random_nodes and unranged:  # the drawn scenarios take the same fields (a motion model, ...)
            ranges = dataclasses.replace(ranges, base=ranges.base.replace(**unranged))
        self.ranges = ranges
        # moving or roughly known nodes (ios_uav_env.envs.knowledge): paths and kernels per episode
        family = ranges.base if random_nodes else self._base
        self.mobile: bool = family.motion is not None or self.options.knowledge != "exact"
        # the objective fixes the reward and the observation's layout (multi_energy)
        self.energy_objective: bool = family.objective == "energy_efficiency"
        self.reference_efficiency: float = 0.0  # bits/J, lambda_ref of the episode (energy objective)
        check_options(self.options, self.energy_objective)
        check_world(family, self.options, self._own_id(), "ranges.base" if random_nodes else "config")
        fades = self.options.channel == "rician" or self.options.knowledge != "exact"
        surfaces = ranges.surfaces if random_nodes else (self._base.surface,)
        check_scenario_overrides(
            self._own_id(), overrides, surfaces, fades=fades, multinode=True,
            budget=family.energy_budget_j is not None, energy=self.energy_objective,
        )  # fmt: skip
        if self.mobile and self.options.peak_hint:
            raise ValueError(
                "peak_hint is a static node's rate peak: it needs static, exactly known nodes (motion=None "
                f"and knowledge='exact'), got motion={family.motion!r}, knowledge={self.options.knowledge!r}"
            )
        self._track: NodesTrack | None = None
        # the most nodes an episode can have: random_nodes' high when every reset draws (the
        # config is then not an episode's scenario), else the config's K
        needed = random_nodes[1] if random_nodes else self._base.K
        what = f"random_nodes' high = {needed}" if random_nodes else f"the scenario's K = {needed}"
        if max_nodes is not None and (
            isinstance(max_nodes, bool) or not isinstance(max_nodes, (int, np.integer)) or max_nodes < needed
        ):
            raise ValueError(f"max_nodes must be an integer >= {what}, got {max_nodes!r}")
        self.max_nodes = int(needed if max_nodes is None else max_nodes)
        if not (
            isinstance(share_sharpness, (int, float))
            and math.isfinite(share_sharpness)
            and share_sharpness > 0
        ):
            raise ValueError(f"share_sharpness must be a finite number > 0, got {share_sharpness!r}")
        self.share_sharpness = float(share_sharpness)
        if not (isinstance(softmin_beta, (int, float)) and math.isfinite(softmin_beta) and softmin_beta >= 0):
            raise ValueError(f"softmin_beta must be a finite number >= 0, got {softmin_beta!r}")
        self.softmin_beta = float(softmin_beta)
        self.score_seconds = 0.0  # see reset()
        self.render_mode = render_mode
        self.node_features = NODE_FEATURES + (NODE_PEAK_FEATURES if self.options.peak_hint else ())
        #: The names of the observation's components, in order: ``BASE_FEATURES``, then node slot
        #: k's ``node_features`` as ``<feature>_<k>`` (``observation_layout.node_block_names``).
        self.observation_names: tuple[str, ...] = (
            BASE_FEATURES
            + node_block_names(self.node_features, self.max_nodes, self.options.knowledge)
            + (ENERGY_NAMES if self.energy_objective else ())
        )
        self.action_space = spaces.Box(-1.0, 1.0, (2 + self.max_nodes,), np.float32)
        low, high = self._bounds()
        self.observation_space = spaces.Box(low, high, dtype=np.float32)
        # where a measured rate is clipped (the space's rate bound, over the env's family)
        own = self.ranges if random_nodes else ScenarioRanges.from_config(self._base.node_config(0))
        self._rate_clip = self._rate_high(own)
        #: bps/Hz: where the observation clips a served rate (channel "rician"; else inf): the kernels'.
        self.served_clip: float = rate_high(own, "exact", True) if self._rician else math.inf
        #: The keys of ``info`` (``multi_table.info_keys``: more with the energy objective, Rician).
        self.info_keys: tuple[str, ...] = info_keys(self.energy_objective, self._rician)
        self.config = self._base
        # a batch of one episode for the kernels of ios_uav_env.envs.multi_kernels
        self._rows = NodeRows(
            1, self.max_nodes, self.options, self.share_sharpness, self.softmin_beta, self.energy_objective,
            self.served_clip,
        )  # fmt: skip
        self._one, self._active = np.zeros(1, dtype=np.int64), np.ones(1, dtype=np.bool_)
        self._action, self._norm = np.zeros((1, 2 + self.max_nodes)), np.zeros(1)
        self._obs = np.zeros((1, low.size), dtype=np.float32)
        self._reward, self._terminated = np.zeros(1), np.zeros(1, dtype=np.bool_)
        more = self.energy_objective or self.options.channel == "rician"  # (their info columns)
        self._table = np.zeros((1, info_columns(self.max_nodes, more)))
        self._started = False

    # --- spaces ---------------------------------------------------------------------------
    def _bounds(self, config: ScenarioConfig | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) over the env's family (its ranges, or its one config), or over ``config``
        (``multi_space.multinode_bounds``)."""
        return multinode_bounds(self, config)

    def _own_id(self) -> str:
        """The registered id of this env, for messages (``settings.multinode_id``)."""
        return multinode_id(self.random_nodes, self.mobile)

    def _rate_high(self, r: ScenarioRanges) -> float:
        """bps/Hz: the rate features' bound over ``r`` (``multi_space.rate_high``)."""
        return rate_high(r, self.options.knowledge)

    # --- episode --------------------------------------------------------------------------
    def _episode_config(self, pinned: ScenarioConfig | None) -> ScenarioConfig:
        if pinned is not None:
            return pinned
        if self.random_nodes:
            return sample_multinode(self.np_random, self.ranges, self.random_nodes)
        return self._base

    def begin_episode(self, seed: int | None, options: dict[str, Any] | None) -> ScenarioConfig:
        """The scenario part of ``reset`` (row protocol; ``MultiNodeVectorEnv`` runs it on each row's
        env): seed ``np_random``, choose the episode's scenario (pinned, drawn or the env's own),
        check that it fits the spaces, make it ``config``; no step, no observation."""
        gym.Env.reset(self.env, seed=seed)
        pinned = scenario_option(options)
        cfg = self._episode_config(pinned)
        if pinned is not None:
            self.check_scenario(cfg)
        self.config = cfg
        return cfg

    def check_scenario(self, cfg: ScenarioConfig, field: str = 'options["config"]') -> None:
        """Raise ``ValueError`` naming ``field`` unless the pinned scenario ``cfg`` can be an episode
        of this env: at most ``max_nodes`` nodes and observations inside the space (row protocol:
        the batched env checks every row's pinned scenario with it before it resets any row)."""
        if cfg.motion is not None and not self.mobile:
            raise ValueError(
                f"{field} has a motion model; this env's nodes are static: make the env on the scenario "
                "instead (MultiNodeEnv(cfg)), or use ios_uav_env/IOSUAV-MultiNode-Mobile-v0"
            )
        multinode_objective(cfg, field, self._own_id(), self.energy_objective)
        if cfg.K > self.max_nodes:
            raise ValueError(
                f"{field}: the scenario has K = {cfg.K} nodes; this env observes at most max_nodes = "
                f"{self.max_nodes}"
            )
        if cfg != self._base:  # could its observations leave the space?
            low, high = self._bounds(cfg)
            if np.any(low < self.observation_space.low) or np.any(high > self.observation_space.high):
                raise ValueError(
                    f"{field}: the scenario {cfg} does not fit this env's observation space; make an env "
                    "on it instead"
                )

    def start(self) -> tuple[np.ndarray, dict[str, Any]]:
        """The rest of ``reset`` after :meth:`begin_episode`: the episode in the one row (node
        paths, lambda_ref, slot 1's fading); the first observation and ``info``."""
        self.load_row(self._rows, 0)  # the scenario, node paths, lambda_ref, the first slot's fading
        self.score_seconds = 0.0  # wall time of the episode's best schedule (scoring, not planning)
        self._rows.start(self._one, self._obs, self._table)
        self.observe_slot(self._rows, 0, self._obs[0])
        self._started = True
        return self._obs[0].copy(), self._info()

    def _info(self) -> dict[str, Any]:
        """The ``info`` dict (``MULTI_INFO_KEYS``) of the info table: numpy scalars and arrays."""
        table = self._table.copy()
        return {key: value[0] for key, value in info_arrays(table, self.max_nodes, self.info_keys).items()}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """One slot of the move and node scores ``action``: Gymnasium's (observation, reward,
        terminated, truncated (never), ``info``)."""
        ended = self._started and self._rows.state[0, 2] >= self._rows.episode[0, 3]
        a = self.checked_action(action, self._started, ended)
        self._action[0] = a
        self._norm[0] = math.hypot(a[0], a[1])  # (Python's hypot: see multi_kernels.move_norms)
        outputs = (self._obs, self._reward, self._terminated, self._table)
        self.prepare_slot(self._rows, 0)
        self._rows.step(self._action, self._active, outputs, self._norm, serial=True)
        self.observe_slot(self._rows, 0, self._obs[0])
        terminated = bool(self._terminated[0])
        if terminated and not self.best_schedule:
            self._table[0, BEST] = np.nan  # (as the batched env's best_schedule=False)
        elif terminated:
            start = time.perf_counter()
            self._table[0, BEST] = reported_maxmin_rate(
                self.config, self.trajectory, self.truth, track_kernels(self.track)
            )
            self.score_seconds = time.perf_counter() - start
        return self._obs[0].copy(), float(self._reward[0]), terminated, False, self._info()

    @property
    def trajectory(self) -> np.ndarray:
        """The way-points so far, (n + 1, 2) m."""
        if not self._started:
            return np.zeros((0, 2))
        return self._rows.path[0, : int(self._rows.state[0, 2]) + 1].copy()

    @property
    def shares(self) -> np.ndarray:
        """The shares so far, (K, n + 1): slot 1's equal shares, then one column per step."""
        if not self._started:
            return np.zeros((self.config.K, 0))
        return self._rows.schedule(0, self.config.K)

    def render(self) -> np.ndarray | None:
        """The trajectory so far over the best node's rate map, an (H, W, 3) uint8 array."""
        if self.render_mode is None:
            gym.logger.warn('render() needs render_mode="rgb_array" at construction; returning None')
            return None
        from ios_uav_env.plotting import figure_image, plot_multinode_map, plot_served_trajectories

        def draw(ax: Any) -> None:
            plot_multinode_map(ax, self.config, resolution=(120, 60))
            if self._started:
                plot_served_trajectories(ax, self.config, {"UAV": self.trajectory}, {"UAV": self.shares})
                slot, low = len(self.trajectory), self._rows.state[0, 4]  # (min_rate so far)
                ax.set_title(f"slot {slot}/{self.config.N}, min rate so far {low:.3f} bps/Hz", fontsize=9)

        return figure_image(draw)

    def close(self) -> None:
        """Nothing to close (each frame is drawn on a figure of its own)."""
