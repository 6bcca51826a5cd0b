"""Randomised scenarios: one policy for every instance of a family, drawn at each reset.

``ScenarioRanges`` is the family (documented ranges of G, T, the surface's size and kind,
and the start and end points; every other field is its ``base`` config's),
:func:`sample_scenario` draws one ``ScenarioConfig`` from it, and ``RandomIOSUAVEnv``
(registered as ``ios_uav_env/IOSUAV-Random-v0``) draws a new one at every reset from its
``np_random``, observing the instance through the 6 instance features of ``IOSUAVEnv``.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ios_uav_env.config import SURFACES, ScenarioConfig, as_config
from ios_uav_env.env import IOSUAVEnv
from ios_uav_env.observation import (
    M_SCALE,
    T_SCALE,
    assemble_bounds,
    check_fits,
    ground_free_rate_bound,
    length_bounds,
)

#: ``ScenarioConfig`` fields that the ranges draw (the others come from ``ScenarioRanges.base``).
RANGED_FIELDS: frozenset[str] = frozenset({"ground_node", "T", "ios_shape", "surface", "q0", "qF"})


def _interval(value: Any, name: str, integer: bool = False) -> tuple[Any, Any]:
    try:
        lo, hi = value
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a (low, high) pair, got {value!r}") from None
    ok = all(
        isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) for v in (lo, hi)
    )
    if not ok or not (math.isfinite(lo) and math.isfinite(hi)) or lo > hi:
        raise ValueError(
            f"{name} must be a (low, high) pair of finite numbers with low <= high, got {value!r}"
        )
    if integer:
        if lo != int(lo) or hi != int(hi) or lo < 1:
            raise ValueError(f"{name} must be a (low, high) pair of integers >= 1, got {value!r}")
        return int(lo), int(hi)
    return float(lo), float(hi)


@dataclass(frozen=True)
class ScenarioRanges:
    """The family of randomised scenarios, drawn by :func:`sample_scenario`.

    Each (low, high) pair is drawn uniformly (low == high fixes the value): positions and G
    continuously, T over its whole slots, M_z over the integers, the surface among
    ``surfaces``. Every other ``ScenarioConfig`` field is ``base``'s (the paper's defaults:
    v_max = 25 m/s, dt = 1 s, the IOS centred at (0, 0, 40) m, ...), and ``base`` itself is a
    scenario of the default ranges. Construction checks that every scenario of the ranges is
    valid (in particular that the shortest horizon reaches the farthest end point).
    """

    ground_x: tuple[float, float] = (-250.0, 250.0)  # m, x_G of the ground node G
    ground_y: tuple[float, float] = (-150.0, 150.0)  # m, y_G
    T: tuple[float, float] = (60.0, 200.0)  # s, horizon, uniform over the whole slots in it
    ios_rows: tuple[int, int] = (20, 60)  # M_z, IOS rows (M = ios_columns x M_z = 2000 ... 6000)
    ios_columns: int = 100  # M_y, IOS columns (fixed)
    surfaces: tuple[str, ...] = ("ios", "ris")  # surface kinds, uniform
    start_x: tuple[float, float] = (-400.0, -400.0)  # m, x of q0
    start_y: tuple[float, float] = (-100.0, 100.0)  # m, y of q0
    end_x: tuple[float, float] = (400.0, 400.0)  # m, x of qF
    end_y: tuple[float, float] = (-100.0, 100.0)  # m, y of qF
    base: ScenarioConfig = ScenarioConfig()  # every field not drawn

    def __post_init__(self) -> None:
        for name in ("ground_x", "ground_y", "T", "start_x", "start_y", "end_x", "end_y"):
            object.__setattr__(self, name, _interval(getattr(self, name), name))
        object.__setattr__(self, "ios_rows", _interval(self.ios_rows, "ios_rows", integer=True))
        if isinstance(self.ios_columns, bool) or not (
            isinstance(self.ios_columns, (int, np.integer)) and self.ios_columns >= 1
        ):
            raise ValueError(f"ios_columns must be an integer >= 1, got {self.ios_columns!r}")
        object.__setattr__(self, "ios_columns", int(self.ios_columns))
        surfaces = (self.surfaces,) if isinstance(self.surfaces, str) else tuple(self.surfaces)
        if not surfaces or len(set(surfaces)) != len(surfaces) or not set(surfaces) <= set(SURFACES):
            raise ValueError(f"surfaces must be distinct values of {SURFACES}, got {self.surfaces!r}")
        object.__setattr__(self, "surfaces", surfaces)
        object.__setattr__(self, "base", as_config(self.base, "base"))
        lo, hi = self.slot_range
        if lo > hi:
            raise ValueError(f"T={self.T} s holds no whole number of slots dt={self.base.dt:g} s")
        # the worst case: the shortest horizon, the farthest end points and the tallest surface
        (sx, ex), (sy, ey) = (
            max(((s, e) for s in pair_s for e in pair_e), key=lambda p: abs(p[1] - p[0]))
            for pair_s, pair_e in ((self.start_x, self.end_x), (self.start_y, self.end_y))
        )
        try:
            self.base.replace(
                T=lo * self.base.dt, q0=(sx, sy), qF=(ex, ey), ios_shape=self.shape(self.ios_rows[1])
            )
            self.base.replace(ground_node=(self.ground_x[0], self.ground_y[0]), surface=self.surfaces[0])
        except ValueError as exc:
            raise ValueError(f"these ranges allow an invalid scenario: {exc}") from None

    @property
    def slot_range(self) -> tuple[int, int]:
        """(N_min, N_max): the slot counts N = T / dt that T is drawn from."""
        dt = self.base.dt
        return max(2, math.ceil(self.T[0] / dt - 1e-9)), math.floor(self.T[1] / dt + 1e-9)

    @property
    def max_moves(self) -> int:
        """N_max - 1: the longest episode, in steps."""
        return self.slot_range[1] - 1

    def shape(self, rows: int) -> tuple[int, int]:
        """``ios_shape`` (M_y, M_z) for ``rows`` rows."""
        return (self.ios_columns, int(rows))

    def contains(self, other: ScenarioRanges) -> bool:
        """Whether every scenario of ``other`` is a scenario of these ranges."""
        intervals = ("ground_x", "ground_y", "T", "ios_rows", "start_x", "start_y", "end_x", "end_y")
        inside = all(
            getattr(self, n)[0] <= getattr(other, n)[0] and getattr(other, n)[1] <= getattr(self, n)[1]
            for n in intervals
        )
        same = other.ios_columns == self.ios_columns and other.base == self.base
        return inside and same and set(other.surfaces) <= set(self.surfaces)

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON dictionary (round-trips through :meth:`from_dict`)."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            out[f.name] = (
                value.to_dict() if f.name == "base" else list(value) if isinstance(value, tuple) else value
            )
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ScenarioRanges:
        """Inverse of :meth:`to_dict` (unknown keys raise ``TypeError``)."""
        data = dict(data)
        if "base" in data:
            data["base"] = as_config(data["base"], "base")
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in data.items()})


def _as_ranges(value: Any, name: str) -> ScenarioRanges:
    if isinstance(value, ScenarioRanges):
        return value
    if isinstance(value, Mapping):
        return ScenarioRanges.from_dict(value)
    raise TypeError(f"{name} must be a ScenarioRanges, a dict of its fields or None, got {value!r}")


#: The ranges of issue #6 (and of ``ios_uav_env/IOSUAV-Random-v0``).
DEFAULT_RANGES = ScenarioRanges()


def sample_scenario(
    rng: np.random.Generator | int | None = None, ranges: ScenarioRanges = DEFAULT_RANGES
) -> ScenarioConfig:
    """Draw one scenario of ``ranges`` with ``rng`` (a Generator, or a seed for ``default_rng``).

    The draws, in this order: x_G, y_G (uniform), N (integer, uniform over
    ``ranges.slot_range``; T = N dt), M_z (integer, uniform), the surface (uniform over
    ``ranges.surfaces``), then q0's x and y and qF's x and y (uniform); a fixed value still
    takes its draw, so the stream does not depend on which ranges are degenerate.
    """
    if not isinstance(rng, np.random.Generator):
        rng = np.random.default_rng(rng)
    r = ranges
    ground = (float(rng.uniform(*r.ground_x)), float(rng.uniform(*r.ground_y)))
    n_lo, n_hi = r.slot_range
    slots = int(rng.integers(n_lo, n_hi, endpoint=True))
    rows = int(rng.integers(r.ios_rows[0], r.ios_rows[1], endpoint=True))
    surface = r.surfaces[int(rng.integers(len(r.surfaces)))]
    x0, y0, xf, yf = (float(rng.uniform(*pair)) for pair in (r.start_x, r.start_y, r.end_x, r.end_y))
    return r.base.replace(
        ground_node=ground,
        T=slots * r.base.dt,
        ios_shape=r.shape(rows),
        surface=surface,
        q0=(x0, y0),
        qF=(xf, yf),
    )


#: ``IOSUAVEnv``'s keyword arguments (the rest of ``**kwargs`` are ``ScenarioConfig`` overrides).
_ENV_ARGS = frozenset(
    name
    for name, p in inspect.signature(IOSUAVEnv.__init__).parameters.items()
    if p.kind is inspect.Parameter.KEYWORD_ONLY
)


class RandomIOSUAVEnv(IOSUAVEnv):
    r"""``IOSUAVEnv`` on a new scenario at every reset, drawn from documented ranges.

    ## Description

    On the paper's single scenario a planner solves the problem in seconds and an agent only
    memorises one trajectory; here every episode is a new instance of the family
    ``ranges`` (a :class:`ScenarioRanges`, default :data:`DEFAULT_RANGES`), so a policy has
    to plan for scenarios it has never seen. Default ranges (uniform): G at x in
    [-250, 250] m, y in [-150, 150] m; T in [60, 200] s (whole slots); M_z in [20, 60] IOS
    rows of M_y = 100 columns (M = 2000 ... 6000); surface "ios" or "ris"; q0 = (-400, y0),
    qF = (400, yF) with y0, yF in [-100, 100] m; every other field at the paper's default.
    Everything else (the model, the arrival guard, the rewards, ``info``, the trajectory
    checks) is ``IOSUAVEnv``'s, on the episode's scenario ``env.unwrapped.config``.

    ## Action Space

    As ``IOSUAVEnv``: ``Box(-1, 1, (2,), float32)``, the displacement of the slot in units
    of D = v_max dt (projected onto the unit disk, then by the arrival guard).

    ## Observation Space

    A float32 ``ndarray`` of shape (17,): ``IOSUAVEnv``'s 11 components (names in
    ``OBS_NAMES``) and, with ``instance_features=True`` (the default here), the 6 instance
    features (names in ``INSTANCE_NAMES``). L = ``length_scale`` (400 m), q the UAV
    position, m the moves left, d_F = |qF - q|, N the episode's slot count.

    | Num | Observation                                            | Min | Max   |
    |-----|--------------------------------------------------------|-----|-------|
    | 0-1 | UAV position q / L                                     | -B  | B     |
    | 2-3 | final point, (qF - q) / L                              | -B  | B     |
    | 4-5 | ground node, (w_G - q) / L                             | -B  | B     |
    | 6-7 | IOS centre, (x_c - x, y_c - y) / L                     | -B  | B     |
    | 8   | time left, m / (N - 1)                                 | 0   | 1     |
    | 9   | slack s / (1 + abs(s)), s = m - d_F / D                | -1  | 1     |
    | 10  | expected-gain rate r(q) (bps/Hz)                       | 0   | r_max |
    | 11  | elements, M / 6000 (0 without a surface)               | 0   | 1     |
    | 12  | surface is the IOS (0 or 1)                            | 0   | 1     |
    | 13  | surface is a RIS (0 or 1)                              | 0   | 1     |
    | 14  | transmissive factor t / (1 + t) (IOS: epsilon, else 0) | 0   | 1     |
    | 15  | horizon, T / 200 s                                     | 0   | 1     |
    | 16  | seconds left, m dt / 200 s                             | 0   | 1     |

    Every point is relative to the UAV, so the values are O(1) on every scenario (with the
    guard the UAV stays within its reach of q0 and qF). The bounds hold for every scenario
    of the ranges: B is the largest value at q0 over the ranges plus (N_max - 1) D / L (no
    UAV gets farther, guard or not); r_max bounds the rate for any G
    (:func:`~ios_uav_env.observation.ground_free_rate_bound`, over the ranges' surfaces and
    sizes); the maxima of 11, 15, 16 are those of the ranges, at least 1 (with margins of
    1e-6). Both env checkers pass; the observation's shape does not depend on the scenario.

    ## Rewards

    As ``IOSUAVEnv``: the rate at the new position, minus the reach and terminal penalties
    (0 with the guard). The return is N R - r(q0); N varies per episode, so compare
    episodes by ``info["average_rate"]`` (eq. (9)).

    ## Starting State

    A scenario drawn by :func:`sample_scenario` from ``np_random`` (so ``reset(seed=s)``
    fixes it; the same seed gives the same scenarios), the UAV at its q0, slot 1.
    ``reset(options={"config": cfg})`` pins that episode to ``cfg`` instead (a
    ``ScenarioConfig`` or a dict of its fields; no other key); a ``cfg`` whose observations
    could leave the space (e.g. T > 200 s, G far outside the ranges) is refused with
    ``ValueError``. ``config=cfg`` at construction pins every episode (still observed in
    the ranges' space: a trained generalist evaluated on ``cfg``). Before the first reset
    ``config`` is ``ranges.base``.

    ## Episode End

    ``terminated=True`` at slot N of the episode's scenario (60 to 200 slots by default):
    after N - 1 steps, 59 to 199. The registered ``max_episode_steps`` is ``ranges.max_moves``
    (199), so the ``TimeLimit`` never cuts an episode; a shorter one is refused at reset.

    ## Arguments

    - ``ranges``: a :class:`ScenarioRanges` or a dict of its fields (default: the above).
    - ``config``: None (draw at every reset) or a scenario that every episode runs on.
    - ``focus`` (None) and ``focus_prob`` (0): narrower ranges inside ``ranges`` (a dict of
      the fields that differ, e.g. ``{"ground_x": (-150, 150), "ground_y": (-60, 60)}``),
      drawn instead with probability ``focus_prob``: a training distribution that visits
      more often the scenarios where the surface changes the best plan. The observation
      space stays that of ``ranges``; with ``focus_prob = 0`` the draws are unchanged.
    - ``instance_features`` (True), ``peak_hint`` (False: with True, 3 more components,
      the reachable rate peak; see ``IOSUAVEnv``), ``channel``, ``arrival_guard``, ``reach_weight``,
      ``terminal_weight``, ``length_scale``, ``render_mode``: as ``IOSUAVEnv``.
    - ``**overrides``: ``ScenarioConfig`` fields that the ranges do not draw (e.g.
      ``v_max``, ``alpha``), applied to ``ranges.base``; a drawn field (``T``,
      ``ground_node``, ``q0``, ``qF``, ``ios_shape``, ``surface``) raises ``ValueError``:
      change ``ranges`` instead.

    ```python
    >>> import gymnasium as gym
    >>> import ios_uav_env
    >>> env = gym.make("ios_uav_env/IOSUAV-Random-v0")
    >>> obs, info = env.reset(seed=0)
    >>> obs.shape, env.unwrapped.config.N >= 60
    ((17,), True)
    >>> cfg = ios_uav_env.ScenarioConfig(T=100)
    >>> obs, info = env.reset(options={"config": cfg})
    >>> env.unwrapped.config == cfg
    True

    ```

    ## Version History

    * v0: Initial version.
    """

    def __init__(
        self,
        ranges: ScenarioRanges | Mapping[str, Any] | None = None,
        *,
        config: ScenarioConfig | Mapping[str, Any] | None = None,
        instance_features: bool = True,
        focus: ScenarioRanges | Mapping[str, Any] | None = None,
        focus_prob: float = 0.0,
        **kwargs: Any,
    ) -> None:
        ranges = _as_ranges(DEFAULT_RANGES if ranges is None else ranges, "ranges")
        overrides = {k: kwargs.pop(k) for k in list(kwargs) if k not in _ENV_ARGS}
        drawn = sorted(set(overrides) & RANGED_FIELDS)
        if drawn:
            raise ValueError(
                f"{drawn} are drawn from the ranges at every reset: pass ranges=ScenarioRanges(...) "
                "to change them, config=... to pin every episode, or reset(options={'config': ...})"
            )
        if overrides:
            ranges = dataclasses.replace(ranges, base=ranges.base.replace(**overrides))
        self.ranges: ScenarioRanges = ranges
        if not (isinstance(focus_prob, (int, float)) and 0.0 <= focus_prob <= 1.0):
            raise ValueError(f"focus_prob must be a probability in [0, 1], got {focus_prob!r}")
        self.focus: ScenarioRanges | None = None
        if focus is not None:
            # narrower ranges (filled in from ``ranges``), drawn with probability focus_prob:
            # a training distribution that visits the scenarios where the decision matters
            fields = focus if isinstance(focus, Mapping) else focus.to_dict()
            self.focus = _as_ranges({**ranges.to_dict(), **dict(fields)}, "focus")
            if not ranges.contains(self.focus):
                raise ValueError(f"focus must lie inside ranges, got {dict(fields)!r}")
        self.focus_prob = float(focus_prob) if self.focus is not None else 0.0
        self.pinned: ScenarioConfig | None = None if config is None else as_config(config)
        super().__init__(self.pinned or ranges.base, instance_features=instance_features, **kwargs)
        if self.pinned is not None:
            check_fits(
                self.pinned, self.length_scale, self.instance_features, self.observation_space, self.peak_hint
            )

    def _space_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) over every scenario of the ranges."""
        r, base = self.ranges, self.ranges.base
        q0 = (r.start_x, r.start_y)
        points = [
            (r.end_x, r.end_y),
            (r.ground_x, r.ground_y),
            ((base.ios_center[0],) * 2, (base.ios_center[1],) * 2),
        ]
        lengths = length_bounds(q0, points, r.max_moves * base.D, self.length_scale)
        rate_high = max(
            ground_free_rate_bound(base.replace(surface=s, ios_shape=r.shape(rows)))
            for s in r.surfaces
            for rows in range(r.ios_rows[0], r.ios_rows[1] + 1)
        )
        largest = (r.ios_columns * r.ios_rows[1] / M_SCALE, r.slot_range[1] * base.dt / T_SCALE)
        reach = r.max_moves * base.D / self.length_scale if self.peak_hint else None
        return assemble_bounds(lengths, rate_high, largest if self.instance_features else None, reach)

    def _episode_config(self, pinned: ScenarioConfig | None) -> ScenarioConfig:
        if pinned is not None:
            return pinned
        if self.pinned is not None:
            return self.pinned
        if self.focus_prob > 0.0 and self.np_random.random() < self.focus_prob:
            return sample_scenario(self.np_random, self.focus)
        return sample_scenario(self.np_random, self.ranges)

    def _horizon_moves(self, pinned: ScenarioConfig | None) -> int:
        pinned = pinned if pinned is not None else self.pinned
        return self.ranges.max_moves if pinned is None else pinned.N - 1
