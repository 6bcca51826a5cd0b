"""The base of every component and the registry of names each family keeps.

A component is a small frozen dataclass: one choice of the world's surface, link, objective,
motion or knowledge, with its parameters validated on construction (a bad value raises
``ValueError`` naming the field and its allowed range). Each family keeps a :class:`Registry`
from names to classes, so a world can be written as plain data: a name (``"ios"``), a dict
with a ``kind`` (``{"kind": "gauss_markov", "speed": 3.0}``) or the object itself.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable, Mapping
from typing import Any, ClassVar, Generic, TypeVar

__all__ = ["Component", "Registry", "finite_number"]


def finite_number(value: Any, name: str, *, positive: bool, unit: str) -> float:
    """``value`` as a float, or ``ValueError`` naming the field ``name`` and its range (a finite
    number > 0 when ``positive``, else >= 0; ``unit`` as the message writes it)."""
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or (value <= 0 if positive else value < 0):
        raise ValueError(
            f"{name} must be a finite number {'> 0' if positive else '>= 0'} ({unit}), got {value!r}"
        )
    return float(value)


@dataclasses.dataclass(frozen=True)
class Component:
    """A choice of one family of the world (subclasses set ``family`` and ``kind``)."""

    family: ClassVar[str] = ""
    kind: ClassVar[str] = ""

    @classmethod
    def variants(cls) -> tuple[Component, ...]:
        """The instances of this kind that the combination matrix runs (default: its defaults)."""
        return (cls(),)

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON form: ``kind``, then the parameters (``Registry.make`` reads it back)."""
        return {"kind": self.kind, **dataclasses.asdict(self)}


C = TypeVar("C")


class Registry(Generic[C]):
    """The names of one family of components (``family``: e.g. ``"surface"``) and their classes."""

    def __init__(self, family: str) -> None:
        self.family = family
        self._classes: dict[str, type[C]] = {}

    def register(self, kind: str) -> Callable[[type[C]], type[C]]:
        """Class decorator: register the class under ``kind`` (a name not taken yet)."""

        def add(cls: type[C]) -> type[C]:
            if kind in self._classes:
                raise ValueError(f"{self.family} {kind!r} is registered already ({self._classes[kind]!r})")
            self._classes[kind] = cls
            return cls

        return add

    def names(self) -> tuple[str, ...]:
        """The registered kinds, in registration order."""
        return tuple(self._classes)

    def get(self, kind: str) -> type[C]:
        """The class registered as ``kind``; ``ValueError`` naming the registered ones otherwise."""
        try:
            return self._classes[kind]
        except (KeyError, TypeError):
            raise ValueError(f"{self.family} must be one of {self.names()}, got {kind!r}") from None

    def make(self, value: Any) -> C:
        """``value`` as a component of this family: an instance of a registered class, a kind's
        name (its defaults), or a mapping with ``kind`` and the parameters."""
        if isinstance(value, tuple(self._classes.values())):
            return value
        if isinstance(value, str):
            return self.get(value)()
        if isinstance(value, Mapping):
            params = dict(value)
            if "kind" not in params:
                raise ValueError(f"{self.family} given as a dict needs a 'kind' (one of {self.names()})")
            cls = self.get(params.pop("kind"))
            allowed = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
            unknown = sorted(set(params) - allowed)
            if unknown:
                raise ValueError(
                    f"{self.family} {cls.kind!r} has no parameters {unknown}; allowed: {sorted(allowed)}"  # type: ignore[attr-defined]
                )
            return cls(**params)
        raise ValueError(
            f"{self.family} must be a name in {self.names()}, a dict with 'kind', or a component, "
            f"got {value!r}"
        )
