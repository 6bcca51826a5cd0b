"""Row envs whose episode a batched env drew: the episode's attributes built when first read.

A batched env that draws its resetting rows' episodes together in compiled code
(``mobile_draws.DrawnEpisodes``, ``node_draws.DrawnNodeEpisodes``) makes no ``ScenarioConfig`` per
reset: each row env's stepper takes the row instead (:func:`defer`), and the attributes that its
reset would have set (its scenario, its track, ...) are built from the batch's draw when someone
first reads or sets one (the stepper's ``_resume_episode``). Only the steppers of such a batch take
the deferring class (:func:`deferring`): every other env reads plain attributes.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache
from typing import Any

import gymnasium as gym
import numpy as np

__all__ = ["defer", "deferring", "drawn_rows"]


def drawn_rows(
    envs: Sequence[Any], rows: np.ndarray, seeds: Sequence[int | None], options: Sequence[Any]
) -> tuple[np.ndarray, np.ndarray]:
    """(rest, mine) of a batch's reset of ``rows``: the mask of the rows whose envs reset
    themselves (a row with options: e.g. its pinned scenario) and the others (int64), whose envs
    are seeded with their ``seeds`` (``gym.Env.reset``: the seeding of ``begin_episode``; None:
    none) for the batch to draw their episodes from their generators."""
    rest = np.array([o is not None for o in options], dtype=np.bool_)
    for i, seed, own in zip(rows.tolist(), seeds, rest.tolist(), strict=True):
        if not own and seed is not None:
            gym.Env.reset(envs[i], seed=seed)
    return rest, rows[~rest].astype(np.int64)


def defer(stepper: Any, source: Any, i: int, names: tuple[str, ...], views: tuple[str, ...]) -> None:
    """Make ``stepper`` take the episode of row ``i`` of ``source`` (built by its ``_resume_episode``
    when one of ``names`` is first read or set). A track the last episode built on the batch's
    buffers (``_track_views``) first gets copies of its arrays ``views``: the new draw rewrites them."""
    state = stepper.__dict__
    if state.get("_deferral") is None and state.pop("_track_views", False):
        track = state["_track"]
        for name in views:
            setattr(track, name, getattr(track, name).copy())
    cls = type(stepper)
    if not getattr(cls, "_defers", False):
        stepper.__class__ = deferring(cls, names)
    state["_deferral"] = (source, i)


def _deferred_attribute(name: str) -> property:
    """A data descriptor for ``name``: reading or setting it first builds a deferred episode."""

    def get(self: Any) -> Any:
        state = self.__dict__
        if state.get("_deferral") is not None:
            self._resume_episode()
        try:
            return state[name]
        except KeyError:
            raise AttributeError(name) from None

    def put(self: Any, value: Any) -> None:
        state = self.__dict__
        if state.get("_deferral") is not None:
            self._resume_episode()
        state[name] = value

    return property(get, put)


@cache
def deferring(cls: type, names: tuple[str, ...]) -> type:
    """``cls`` with ``names`` read through :func:`_deferred_attribute`."""
    namespace = {name: _deferred_attribute(name) for name in names}
    # (a name of its own: pickle refuses it rather than rebuild the plain class on a deferred state)
    return type(f"Deferring{cls.__name__}", (cls,), {**namespace, "_defers": True})
