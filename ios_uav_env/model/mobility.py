"""The Gauss-Markov motion model's parameters and its walls (``ios_uav_env.model.motion``).

This module knows nothing of a scenario (``ScenarioConfig`` holds a :class:`GaussMarkov` in its
``motion`` field and checks its nodes with :func:`rectangles`); the paths of a scenario's nodes
are :func:`ios_uav_env.model.motion.node_paths`.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

#: m, how far the default box reaches beyond the nodes and the IOS centre on every side.
BOX_MARGIN = 100.0

__all__ = ["BOX_MARGIN", "MOTIONS", "GaussMarkov", "as_motion", "rectangles", "reflect"]


def _real(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


@dataclass(frozen=True)
class GaussMarkov:
    """Gauss-Markov node motion (Liang and Haas 1999; module docstring). Defaults: pedestrians.

    Bad values raise ``ValueError`` naming the field and its allowed range.
    """

    memory: float = 0.9  # a in [0, 1): memory of the velocity from slot to slot
    speed: float = 1.5  # m/s, mean speed s = |m_k| >= 0
    heading: float | None = None  # rad, mean heading theta of every node; None: drawn per node in [0, 2 pi)
    sigma: float = 0.5  # m/s, stationary std of each velocity component about m_k (assumption)
    # m, ((x_min, x_max), (y_min, y_max)) where the nodes reflect; None: the scene box of the nodes
    # and the IOS centre widened by BOX_MARGIN
    box: tuple[tuple[float, float], tuple[float, float]] | None = None
    plane_margin: float = 1.0  # m, > 0: half-width of the strip about the IOS plane that no node enters

    def __post_init__(self) -> None:
        a = self.memory
        if not (_real(a) and 0.0 <= a < 1.0):
            raise ValueError(f"GaussMarkov.memory must be a number in [0, 1), got {a!r}")
        for name in ("speed", "sigma"):
            value = getattr(self, name)
            if not (_real(value) and value >= 0):
                raise ValueError(f"GaussMarkov.{name} must be a finite number >= 0, got {value!r}")
        if not (_real(self.plane_margin) and self.plane_margin > 0):  # a node on the plane is refused
            margin = self.plane_margin
            raise ValueError(f"GaussMarkov.plane_margin must be a finite number > 0 (m), got {margin!r}")
        if self.heading is not None and not _real(self.heading):
            raise ValueError(
                f"GaussMarkov.heading must be None or a finite number (rad), got {self.heading!r}"
            )
        for name in ("memory", "speed", "sigma", "plane_margin"):
            object.__setattr__(self, name, float(getattr(self, name)))
        if self.heading is not None:
            object.__setattr__(self, "heading", float(self.heading))
        if self.box is not None:
            object.__setattr__(self, "box", _box(self.box))

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON dictionary (round-trips through ``GaussMarkov(**d)``); ``kind`` names the model."""
        out: dict[str, Any] = {"kind": "gauss_markov", **dataclasses.asdict(self)}
        if self.box is not None:
            out["box"] = [list(side) for side in self.box]
        return out


def _box(value: Any) -> tuple[tuple[float, float], tuple[float, float]]:
    message = f"GaussMarkov.box must be ((x_min, x_max), (y_min, y_max)) in m with min < max, got {value!r}"
    try:
        (x0, x1), (y0, y1) = value
        out = ((float(x0), float(x1)), (float(y0), float(y1)))
    except (TypeError, ValueError) as exc:
        raise ValueError(message) from exc
    if not all(math.isfinite(v) for side in out for v in side) or not (x0 < x1 and y0 < y1):
        raise ValueError(message)
    return out


#: The motion models ``as_motion`` knows, by the ``kind`` of their dict.
MOTIONS: tuple[str, ...] = ("gauss_markov",)


def as_motion(value: Any) -> GaussMarkov | None:
    """``value`` as a motion model: None (static), a :class:`GaussMarkov`, or the dict of one
    (``to_dict()``, its ``kind`` optional); anything else raises ``ValueError``."""
    if value is None or isinstance(value, GaussMarkov):
        return value
    if isinstance(value, Mapping):
        fields = dict(value)
        kind = fields.pop("kind", "gauss_markov")
        if kind not in MOTIONS:
            raise ValueError(f"motion kind must be one of {MOTIONS}, got {kind!r}")
        allowed = {f.name for f in dataclasses.fields(GaussMarkov)}
        unknown = set(fields) - allowed
        if unknown:
            raise ValueError(f"motion has unknown fields {sorted(unknown)}; allowed: {sorted(allowed)}")
        return GaussMarkov(**fields)
    raise ValueError(f"motion must be None (static), a GaussMarkov or a dict of one, got {value!r}")


def rectangles(
    motion: GaussMarkov, nodes: np.ndarray, ios_center: tuple[float, ...], surface: str
) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi), each (K, 2) m: the rectangle each of the (K, 2) ``nodes`` moves in: the box
    (default: the nodes and the IOS centre widened by ``BOX_MARGIN``), cut, unless ``surface``
    is "none", to the node's side of the IOS plane x = ios_center[0], ``plane_margin`` away from
    it. ``ValueError`` naming the node when it starts outside its rectangle or that is empty."""
    points = np.asarray(nodes, dtype=float).tolist()  # (scalar Python: a few nodes, once per episode)
    if motion.box is None:
        xs = [p[0] for p in points] + [float(ios_center[0])]
        ys = [p[1] for p in points] + [float(ios_center[1])]
        box = ((min(xs) - BOX_MARGIN, max(xs) + BOX_MARGIN), (min(ys) - BOX_MARGIN, max(ys) + BOX_MARGIN))
    else:
        box = motion.box
    (x0, x1), (y0, y1) = box
    plane, gap = float(ios_center[0]), motion.plane_margin
    lo, hi = np.empty((len(points), 2)), np.empty((len(points), 2))
    for k, (x, y) in enumerate(points):
        low_x, high_x = x0, x1
        if surface != "none":  # the node's side of the IOS plane, plane_margin away from it
            if x < plane:
                high_x = min(high_x, plane - gap)
            else:
                low_x = max(low_x, plane + gap)
        lo[k], hi[k] = (low_x, y0), (high_x, y1)
        empty = not (low_x < high_x and y0 < y1)
        if empty or not (low_x <= x <= high_x and y0 <= y <= y1):  # (the message formatted only here)
            name = "ground_node" if len(points) == 1 else f"ground_nodes[{k}]"
            where = f"x in [{low_x:g}, {high_x:g}], y in [{y0:g}, {y1:g}] m"
            if empty:
                raise ValueError(
                    f"{name}={(x, y)}: its motion rectangle {where} (the box on its side of the IOS "
                    f"plane, plane_margin={motion.plane_margin:g} m) is empty: widen motion.box"
                )
            raise ValueError(
                f"{name}={(x, y)} starts outside its motion rectangle {where} (motion.box, and at "
                f"least plane_margin={motion.plane_margin:g} m from the IOS plane x = {ios_center[0]:g} m)"
            )
    return lo, hi


def reflect(positions: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions folded into [lo, hi] per component (mirrored at the edges as often as needed),
    and whether each component's direction is reversed (an odd number of mirrorings)."""
    p = np.asarray(positions, dtype=float)
    width = hi - lo
    u = p - lo
    times = np.floor(u / width)
    flip = (times % 2) != 0
    r = u - times * width  # in [0, width)
    inside = (p >= lo) & (p <= hi)
    folded = np.where(flip, hi - r, lo + r)
    return np.where(inside, p, folded), np.where(inside, False, flip)
