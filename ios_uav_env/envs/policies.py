"""Simple policies on the observation alone: fly to a point at full speed and hover there.

They are the baselines that an RL policy must beat (and the demo's policy): with the arrival
guard (the env's default) hovering anywhere still ends at qF at slot N, so "where to hover"
is the whole plan. :class:`HoverAt` reads the point from the observation, so it runs on any
scenario of an id without knowing the config:

>>> import gymnasium as gym
>>> import ios_uav_env
>>> from ios_uav_env.envs.rollout import run_episode
>>> policy = HoverAt("peak")
>>> env = gym.make("ios_uav_env/IOSUAV-v0", T=60, **policy.env_kwargs)
>>> round(run_episode(env, policy).average_rate, 4)
1.9149

Each policy reads the observation by feature name (:class:`FeatureReader`): it declares the
features it needs (``observation_features``), and ``policy.bind(env.unwrapped.observation_names)``
checks them against the env's published layout (``ValueError`` naming each missing feature and
the env argument that provides it, e.g. ``peak_hint=True``) and reads them where that layout has
them. ``envs.rollout.run_episode`` / ``run_episodes`` and ``benchmark.evaluate`` bind it before the
episode. Unbound, it takes the single-node layout of the observation's length
(``observation_layout.SINGLE_LAYOUTS``) and refuses one that lacks its features.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ios_uav_env.envs.observation_layout import (
    ENERGY_NAMES,
    OBS_NAMES,
    PEAK_NAMES,
    SINGLE_LAYOUTS,
    require_features,
)
from ios_uav_env.model.config import moves_needed
from ios_uav_env.model.propulsion import PropulsionModel, max_range_speed

__all__ = ["TARGETS", "FeatureReader", "HoverAt", "Loiter", "full_speed_move", "move_toward", "moves_left"]


def _single_layout_columns(needed: tuple[str, ...], width: int, who: str) -> tuple[int, ...]:
    """The positions of ``needed`` in the single-node layout of ``width`` components."""
    layout = SINGLE_LAYOUTS.get(width)
    if layout is None:
        raise ValueError(
            f"{who} reads the features {needed} by name, and an observation of {width} components is none of "
            f"the single-node layouts (lengths {sorted(SINGLE_LAYOUTS)}): bind it to its env's layout first, "
            "policy.bind(env.unwrapped.observation_names) (run_episode and evaluate do)"
        )
    return require_features(needed, layout, who, f"a single-node observation of {width} components")


#: (features, width) -> their positions in the single-node layout of that width (found once).
_UNBOUND: dict[tuple[tuple[str, ...], int], tuple[int, ...]] = {}


class FeatureReader:
    """A policy that reads the observation by feature name (the module's docstring).

    A subclass sets :attr:`observation_features` (per instance or class) and reads feature j of
    an observation ``obs`` at ``self._columns(obs)[j]``.
    """

    #: The names of the observation features the policy reads, in the order it reads them.
    observation_features: tuple[str, ...] = ()
    _layout: tuple[str, ...] | None = None  # the layout it is bound to
    _bound: tuple[int, ...] = ()  # the positions of its features there

    def bind(self, names: Sequence[str]) -> Any:
        """A copy of the policy that reads the layout ``names`` (an env's ``observation_names``);
        ``ValueError`` (``observation_layout.require_features``) unless it has every feature needed."""
        layout = tuple(names)
        env = f"the env ({len(layout)} features)"
        columns = require_features(self.observation_features, layout, repr(self), env)
        bound = copy.copy(self)
        bound._layout, bound._bound = layout, columns
        return bound

    @property
    def layout(self) -> tuple[str, ...] | None:
        """The layout the policy is bound to (None: unbound)."""
        return self._layout

    def _columns(self, obs: np.ndarray) -> tuple[int, ...]:
        """Where each of :attr:`observation_features` is in ``obs`` (..., width)."""
        width = obs.shape[-1]
        if self._layout is None:
            key = (tuple(self.observation_features), width)
            columns = _UNBOUND.get(key)
            if columns is None:
                columns = _UNBOUND[key] = _single_layout_columns(*key, repr(self))
            return columns
        if width != len(self._layout):
            bound = len(self._layout)
            raise ValueError(f"{self!r} is bound to a layout of {bound} features, got {width} features")
        return self._bound


#: Observation slices of the offsets (P - q) / L that :class:`HoverAt` can fly to. The
#: peak hint is always the last 3 components (``PEAK_NAMES``), whatever precedes it.
TARGETS: dict[str, tuple[int, int]] = {
    "ground": (OBS_NAMES.index("dx_ground"), OBS_NAMES.index("dy_ground") + 1),
    "peak": (-len(PEAK_NAMES), -len(PEAK_NAMES) + 2),
}


def full_speed_move(offset: np.ndarray, D: Any) -> np.ndarray:
    """The move in units of D (in the unit disk, float64) that goes ``offset`` (m) in one step if
    it is at most D long, else D along it: full speed towards the point, then stop on it.
    ``offset`` (2,) or a batch (B, 2); ``D`` a number or one per row, (B, 1)."""
    move = np.asarray(offset, dtype=np.float64) / D
    norm = np.hypot(move[..., 0], move[..., 1])[..., None]
    return move / np.maximum(norm, 1.0)


def move_toward(offset: np.ndarray, D: float) -> np.ndarray:
    """:func:`full_speed_move` as an action of the envs' float32 action space."""
    return full_speed_move(offset, D).astype(np.float32)


class HoverAt(FeatureReader):
    """Fly at full speed towards a point given by the observation and hover there.

    ``target``: ``"peak"`` (the reachable rate peak of the scenario, the ``peak_hint``
    features ``dx_peak``, ``dy_peak``; make the env with :attr:`env_kwargs`) or ``"ground"``
    (the ground node G as the UAV is told it: ``dx_ground``, ``dy_ground``; refused where the
    position is hidden, ``knowledge="rates"``). ``D`` (m) and ``length_scale`` (m) must be the
    env's D = v_max dt and L.
    """

    #: It takes a batch of observations too ((B, obs_dim) -> (B, 2)).
    batched = True

    def __init__(self, target: str = "peak", D: float = 25.0, length_scale: float = 400.0) -> None:
        if target not in TARGETS:
            raise ValueError(f"target must be one of {sorted(TARGETS)}, got {target!r}")
        for name, value in (("D", D), ("length_scale", length_scale)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0 (m), got {value!r}")
        self.target, self.D, self.length_scale = target, float(D), float(length_scale)
        self.observation_features = (f"dx_{target}", f"dy_{target}")

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """The env arguments this policy needs (the peak hint for ``"peak"``)."""
        return {"peak_hint": True} if self.target == "peak" else {}

    @property
    def name(self) -> str:
        what = "the reachable rate peak" if self.target == "peak" else "G"
        return f"fly to {what} and hover (heuristic)"

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float64)
        x, y = self._columns(obs)
        offset = (obs[..., x : x + 2] if y == x + 1 else obs[..., [x, y]]) * self.length_scale
        return move_toward(offset, self.D)

    def act(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
        """SB3-style alias of ``__call__`` (the policy is deterministic)."""
        return self(obs)

    def __repr__(self) -> str:
        return f"HoverAt({self.target!r}, D={self.D:g}, length_scale={self.length_scale:g})"


#: Observation indices the loiter policy reads: the final point's offset, the slack, and (counted
#: from the end, the peak hint being last) the minimum-power move and the peak's offset.
_FINAL = slice(OBS_NAMES.index("dx_final"), OBS_NAMES.index("dy_final") + 1)
_SLACK = OBS_NAMES.index("slack")
_MIN_POWER_MOVE = ENERGY_NAMES.index("min_power_move") - len(ENERGY_NAMES) - len(PEAK_NAMES)


def moves_left(obs: np.ndarray, D: float, length_scale: float) -> np.ndarray:
    """The moves left (N - 1 at the start, 0 at slot N) read off the observation: the slack
    s = moves_left - d_F / D is told squashed as y = s / (1 + |s|), so s = y / (1 - |y|) and
    moves_left = s + d_F / D, rounded to the nearest whole move (float64, one per row)."""
    obs = np.asarray(obs, dtype=np.float64)
    return _moves_left(obs, _SLACK, _FINAL.start, _FINAL.start + 1, D, length_scale)


def _moves_left(obs: np.ndarray, slack: int, fx: int, fy: int, D: float, length_scale: float) -> np.ndarray:
    """:func:`moves_left` with the slack and qF - q read at the positions ``slack``, ``fx``, ``fy``."""
    y = obs[..., slack]
    s = y / np.maximum(1.0 - np.abs(y), 1e-12)
    d_final = np.hypot(obs[..., fx], obs[..., fy]) * length_scale
    return np.maximum(np.rint(s + d_final / D), 0.0)


class Loiter(FeatureReader):
    """Loiter around the reachable rate peak at the minimum-power speed, from the observation:
    the energy objective's counterpart of ``HoverAt("peak")`` (a rotary-wing UAV spends less
    power cruising slowly than hovering).

    It flies the flight of ``ios_uav_env.model.flights.loiter_path`` from whatever state it
    is in, reading everything from the observation of an energy env with ``peak_hint=True``
    (:attr:`env_kwargs`): the peak P (the hint), the chord V_mp dt of the circle (the
    ``min_power_move`` feature) and the moves left (:func:`moves_left`). Off the circle it
    heads for the circle's point nearest to it, at one constant speed of at most the cruise
    speed per leg; on the circle it goes on to the next corner of the regular ``sides``-gon
    inscribed in it (one chord per slot); it leaves for qF, at one constant speed over the moves
    left, when the cruise speed would otherwise no longer bring it there in time. The env's
    arrival guard keeps every flight feasible. Unlike ``baselines.loiter`` it does not pick the
    best of several cruise speeds (it needs no rate map), so it can fall short of it on short
    horizons, where faster legs pay.

    ``D`` (m) and ``length_scale`` (m) must be the env's D = v_max dt and L; ``cruise`` (m per
    move) is the legs' speed times dt, default the maximum-range speed V_mr of the default
    propulsion model at dt = 1 s, capped at D.
    """

    #: It takes a batch of observations too ((B, obs_dim) -> (B, 2)).
    batched = True
    observation_features = ("dx_final", "dy_final", "slack", "min_power_move", "dx_peak", "dy_peak")

    def __init__(
        self, D: float = 25.0, length_scale: float = 400.0, sides: int = 3, cruise: float | None = None
    ) -> None:
        if cruise is None:
            cruise = min(max_range_speed(PropulsionModel()), D)
        for name, value in (("D", D), ("length_scale", length_scale), ("cruise", cruise)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0 (m), got {value!r}")
        if isinstance(sides, bool) or not isinstance(sides, int) or sides < 2:
            raise ValueError(f"sides must be an integer >= 2 (way-points per lap), got {sides!r}")
        self.D, self.length_scale, self.sides = float(D), float(length_scale), sides
        self.cruise = min(float(cruise), self.D)

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """The env arguments this policy needs: the peak hint."""
        return {"peak_hint": True}

    @property
    def name(self) -> str:
        return "loiter around the reachable rate peak (heuristic, from the observation)"

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        o = np.atleast_2d(np.asarray(obs, dtype=np.float64))
        fx, fy, slack, power_move, px, py = self._columns(o)
        L, D = self.length_scale, self.D
        peak = o[:, [px, py]] * L  # P - q (m)
        final = o[:, [fx, fy]] * L  # qF - q (m)
        left = _moves_left(o, slack, fx, fy, D, L)
        radius = o[:, power_move] * D / (2.0 * math.sin(math.pi / self.sides))
        away = -peak  # q - P
        dist = np.hypot(away[:, 0], away[:, 1])
        unit = np.where(dist[:, None] > 0.0, away / np.maximum(dist, 1e-300)[:, None], [1.0, 0.0])
        to_circle = peak + radius[:, None] * unit  # the circle's nearest point, from q (m)
        gap = np.hypot(to_circle[:, 0], to_circle[:, 1])
        legs = np.maximum(moves_needed(gap, self.cruise), 1.0)
        move = to_circle / legs[:, None]  # one constant speed over the leg
        on_circle = gap <= 1e-6 * D
        angle = np.arctan2(unit[:, 1], unit[:, 0]) + 2.0 * math.pi / self.sides
        corner = peak + radius[:, None] * np.column_stack([np.cos(angle), np.sin(angle)])
        move = np.where(on_circle[:, None], corner, move)
        late = moves_needed(np.hypot(*(final - move).T), self.cruise) > left - 1.0
        move = np.where(late[:, None], final / np.maximum(left, 1.0)[:, None], move)
        action = full_speed_move(move, D).astype(np.float32)
        return action if np.ndim(obs) == 2 else action[0]

    def act(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
        """SB3-style alias of ``__call__`` (the policy is deterministic)."""
        return self(obs)

    def __repr__(self) -> str:
        return (
            f"Loiter(D={self.D:g}, length_scale={self.length_scale:g}, sides={self.sides}, "
            f"cruise={self.cruise:g})"
        )
