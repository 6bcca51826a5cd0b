"""Families of scenarios: documented ranges of the scenario fields, and draws from them.

``ScenarioRanges`` is a family (ranges of G, T, the surface's size and kind, and the start and
end points; every other field is its ``base`` config's); :func:`sample_scenario` draws one
``ScenarioConfig`` from it, :func:`sample_multinode` one with several ground nodes (the
multi-node family :data:`MULTINODE_RANGES`). A fixed scenario is the family whose ranges have equal ends
(:meth:`ScenarioRanges.from_config`), so the observation bounds of every env are built one
way (``ios_uav_env.envs.observation.space_bounds``). Pure numpy: no Gymnasium.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ios_uav_env.model.config import SURFACE_KINDS, ScenarioConfig, as_config

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


def _off_plane(ground: tuple[float, float], base: ScenarioConfig, surface: str) -> tuple[float, float]:
    """``ground``, or, when ``base`` has a motion model, ``surface`` is one and the node lies
    within ``plane_margin`` of the IOS plane (where no node walks), the point at that margin on
    its side (a node on the plane goes to the transmissive side, x > x_c)."""
    motion = base.motion
    if motion is None or surface == "none":
        return ground
    plane, gap = float(base.ios_center[0]), motion.plane_margin
    if abs(ground[0] - plane) >= gap:
        return ground
    return (plane - gap if ground[0] < plane else plane + gap, ground[1])


def _variant(base: ScenarioConfig, **changes: Any) -> ScenarioConfig:
    """``base.replace(**changes)`` (validated), or ``base`` itself when every change keeps its
    value (a one-node base: the replace would give an equal config, and ``base`` is valid): a
    one-scenario family (``ScenarioRanges.from_config``, built at every check of a drawn or
    pinned scenario) makes no config."""
    if base.K == 1 and all(getattr(base, name) == value for name, value in changes.items()):
        return base
    return base.replace(**changes)


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
        if not surfaces or len(set(surfaces)) != len(surfaces) or not set(surfaces) <= set(SURFACE_KINDS):
            raise ValueError(f"surfaces must be distinct values of {SURFACE_KINDS}, got {self.surfaces!r}")
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
            _variant(
                self.base,
                T=lo * self.base.dt,
                q0=(sx, sy),
                qF=(ex, ey),
                ios_shape=self.shape(self.ios_rows[1]),
            )
            ground = _off_plane((self.ground_x[0], self.ground_y[0]), self.base, self.surfaces[0])
            _variant(self.base, ground_node=ground, surface=self.surfaces[0])
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

    @classmethod
    def from_config(cls, config: ScenarioConfig) -> ScenarioRanges:
        """The family of one scenario: every range's ends equal ``config``'s values."""
        (gx, gy), (x0, y0), (xf, yf) = config.ground_node, config.q0, config.qF
        return cls(
            ground_x=(gx, gx), ground_y=(gy, gy), T=(config.T, config.T),
            ios_rows=(config.ios_shape[1],) * 2, ios_columns=config.ios_shape[0],
            surfaces=(config.surface,), start_x=(x0, x0), start_y=(y0, y0), end_x=(xf, xf),
            end_y=(yf, yf), base=config,
        )  # fmt: skip

    def with_surface(self, surface: str) -> ScenarioRanges:
        """The family with every scenario's surface ``surface`` (one of ``SURFACE_KINDS``): the
        ``surfaces`` drawn from narrowed to it, and ``base`` on it (so the fields that need the
        surface, a STAR surface's ``star_*``, can be set on ``base``)."""
        if not (isinstance(surface, str) and surface in SURFACE_KINDS):
            raise ValueError(f"surface must be one of {SURFACE_KINDS}, got {surface!r}")
        return dataclasses.replace(self, surfaces=(surface,), base=_variant(self.base, surface=surface))

    @property
    def fixed_ground(self) -> bool:
        """Whether every scenario of the family has the same ground node."""
        return self.ground_x[0] == self.ground_x[1] and self.ground_y[0] == self.ground_y[1]

    def configs_per_surface(self) -> list[ScenarioConfig]:
        """One scenario per (surface, IOS rows) of the family, at the family's first ground node
        (``base`` otherwise): what the rate bound of the observation is taken over."""
        ground = (self.ground_x[0], self.ground_y[0])
        return [
            _variant(self.base, surface=s, ios_shape=self.shape(rows), ground_node=ground)
            for s in self.surfaces
            for rows in range(self.ios_rows[0], self.ios_rows[1] + 1)
        ]

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


#: The default family (the ranges of ``ios_uav_env/IOSUAV-Random-v0``).
DEFAULT_RANGES = ScenarioRanges()


def sample_scenario(
    rng: np.random.Generator | int | None = None, ranges: ScenarioRanges = DEFAULT_RANGES
) -> ScenarioConfig:
    """Draw one scenario of ``ranges`` with ``rng`` (a Generator, or a seed for ``default_rng``).

    The draws, in this order: x_G, y_G (uniform), N (integer, uniform over
    ``ranges.slot_range``; T = N dt), M_z (integer, uniform), the surface (uniform over
    ``ranges.surfaces``), then q0's x and y and qF's x and y (uniform). A fixed real value (a
    uniform range of one point) still takes its draw; a fixed integer (one N, one M_z, a single
    surface) takes none, as numpy draws nothing from a one-value integer range, so narrowing
    ``surfaces`` to one surface changes the later draws of the same seed. With a
    motion model on ``ranges.base`` and a surface, a node drawn within ``plane_margin`` of the
    IOS plane (where it may not walk) is moved out to that margin on its side: no extra draw.
    """
    if not isinstance(rng, np.random.Generator):
        rng = np.random.default_rng(rng)
    return ranges.base.replace(**_draw(rng, ranges))


def _draw(rng: np.random.Generator, r: ScenarioRanges) -> dict[str, Any]:
    """:func:`sample_scenario`'s draws, in its order, as the changes of ``r.base``."""
    ground = (float(rng.uniform(*r.ground_x)), float(rng.uniform(*r.ground_y)))
    n_lo, n_hi = r.slot_range
    slots = int(rng.integers(n_lo, n_hi, endpoint=True))
    rows = int(rng.integers(r.ios_rows[0], r.ios_rows[1], endpoint=True))
    surface = r.surfaces[int(rng.integers(len(r.surfaces)))]
    x0, y0, xf, yf = (float(rng.uniform(*pair)) for pair in (r.start_x, r.start_y, r.end_x, r.end_y))
    return drawn_changes(r, _off_plane(ground, r.base, surface), slots, rows, surface, (x0, y0), (xf, yf))


def drawn_changes(
    r: ScenarioRanges,
    ground: tuple[float, float],
    slots: int,
    rows: int,
    surface: str,
    q0: tuple[float, float],
    qF: tuple[float, float],
) -> dict[str, Any]:
    """The changes of ``r.base`` that :func:`sample_scenario`'s draws make: G at ``ground`` (m,
    already off the IOS plane), N = ``slots`` (T = N dt), ``rows`` rows of the IOS, ``surface``,
    q0 and qF (m). A batched env that draws the numbers in compiled code builds its rows' configs
    with it."""
    return {
        "ground_node": ground,
        "T": slots * r.base.dt,
        "ios_shape": r.shape(rows),
        "surface": surface,
        "q0": q0,
        "qF": qF,
    }


#: The multi-node family (the ranges of ``ios_uav_env/IOSUAV-MultiNode-Random-v0``): G's ranges
#: of the single-node family for every node, T in [100, 200] s, IOS or RIS, q0 and qF as in the
#: single-node family.
#: The default multi-node scenario: three nodes, two on the reflecting side of the IOS and one
#: across it, every other parameter at the paper's defaults (the multi-node env's and the fleet's).
DEFAULT_NODES = ((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0))

MULTINODE_RANGES = ScenarioRanges(T=(100.0, 200.0))


def sample_multinode(
    rng: np.random.Generator, ranges: ScenarioRanges = MULTINODE_RANGES, nodes: tuple[int, int] = (2, 4)
) -> ScenarioConfig:
    """A scenario of ``ranges`` with K nodes, K uniform in ``nodes``, each node uniform in the
    ranges of G (draws: K, the nodes, then ``sample_scenario``'s own draws, whose G the nodes
    replace). One config is made: the one ``sample_scenario(rng, ranges).replace(ground_nodes=...)``
    would give (tested)."""
    k = int(rng.integers(nodes[0], nodes[1], endpoint=True))
    points = [(float(rng.uniform(*ranges.ground_x)), float(rng.uniform(*ranges.ground_y))) for _ in range(k)]
    changes = _draw(rng, ranges)
    # (a walking node drawn next to the IOS plane starts at its margin: sample_scenario's rule)
    nodes_off = tuple(_off_plane(p, ranges.base, changes["surface"]) for p in points)
    return ranges.base.replace(**multinode_changes(changes, nodes_off))


def multinode_changes(changes: dict[str, Any], nodes: tuple[tuple[float, float], ...]) -> dict[str, Any]:
    """:func:`sample_multinode`'s changes of ``r.base``: ``changes`` (:func:`drawn_changes`' of the
    scenario's draws) with the ground nodes ``nodes`` (m, already off the IOS plane) instead of G. A
    batched env that draws the numbers in compiled code builds its rows' configs with it."""
    out = {name: value for name, value in changes.items() if name != "ground_node"}
    out["ground_nodes"] = nodes
    return out
