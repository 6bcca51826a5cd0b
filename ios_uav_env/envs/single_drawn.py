"""The single-node stepper on a new scenario at every reset, drawn from ``ScenarioRanges``.

:class:`DrawnSingleNodeStepper` is :class:`~ios_uav_env.envs.single_node.SingleNodeStepper` whose
``begin_episode`` draws each episode's scenario (``sample_scenario``, from its env's ``np_random``;
with ``focus``, from narrower ranges with probability ``focus_prob``) and whose observation space
holds every scenario of the ranges. ``UAVEnv`` runs it for the view ``"v0"`` with ``draws=True``:
the ids of ``RandomIOSUAVEnv`` (``ios_uav_env.envs.random_env``, whose docstring is the contract).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

from ios_uav_env.envs.settings import (
    check_config_keywords,
    check_ranges_surface,
    several_nodes_error,
    single_node_id,
)
from ios_uav_env.envs.single_node import SingleNodeStepper
from ios_uav_env.model.config import SCENARIO_FIELDS, ScenarioConfig, as_config
from ios_uav_env.model.scenarios import (
    DEFAULT_RANGES,
    RANGED_FIELDS,
    ScenarioRanges,
    _as_ranges,
    sample_scenario,
)

__all__ = ["DrawnSingleNodeStepper"]


def _check_focus(focus: Any, focus_prob: float, config: Any) -> None:
    """Refuse a ``focus`` that would never be drawn (``focus_prob`` 0, or ``config`` pinning every
    episode) and a ``focus_prob`` without a ``focus`` to draw from."""
    if focus is None:
        if focus_prob != 0.0:
            raise ValueError(
                f"focus_prob={focus_prob!r} is the probability of drawing from focus: it needs focus=..."
            )
    elif config is not None:
        raise ValueError("focus is never drawn when config pins every episode: drop focus or config")
    elif focus_prob == 0.0:
        raise ValueError("focus is drawn with probability focus_prob: it needs focus_prob > 0 (0: never)")


class DrawnSingleNodeStepper(SingleNodeStepper):
    """The single-node stepper drawing a scenario at every reset (module docstring; the arguments:
    ``RandomIOSUAVEnv``'s)."""

    def __init__(
        self,
        env: Any,
        ranges: ScenarioRanges | Mapping[str, Any] | None = None,
        *,
        config: ScenarioConfig | Mapping[str, Any] | None = None,
        instance_features: bool = True,
        focus: ScenarioRanges | Mapping[str, Any] | None = None,
        focus_prob: float = 0.0,
        **kwargs: Any,
    ) -> None:
        ranges = _as_ranges(DEFAULT_RANGES if ranges is None else ranges, "ranges")
        overrides = {k: kwargs.pop(k) for k in list(kwargs) if k in SCENARIO_FIELDS}
        surface, chosen = overrides.pop("surface", None), ranges  # every drawn scenario's surface
        if surface is not None:  # (before the overrides: a STAR surface's fields need it on base)
            ranges = ranges.with_surface(surface)
        drawn = sorted(set(overrides) & RANGED_FIELDS)
        if drawn:
            raise ValueError(
                f"{drawn} are drawn from the ranges at every reset: pass ranges=ScenarioRanges(...) "
                "to change them, config=... to pin every episode, or reset(options={'config': ...})"
            )
        if overrides:
            base = ranges.base.replace(**overrides)
            if base.K != 1:  # (the ranges draw one node)
                knowledge = kwargs.get("knowledge", "exact")
                raise several_nodes_error(single_node_id(base, knowledge, random=True), base, "ground_nodes")
            ranges = dataclasses.replace(ranges, base=base)
        self.ranges: ScenarioRanges = ranges
        knowledge = kwargs.get("knowledge", "exact")
        own = single_node_id(ranges.base, knowledge, random=True)
        if surface is not None:
            check_ranges_surface(own, chosen, surface, DEFAULT_RANGES.surfaces)
        if not (isinstance(focus_prob, (int, float)) and 0.0 <= focus_prob <= 1.0):
            raise ValueError(f"focus_prob must be a probability in [0, 1], got {focus_prob!r}")
        _check_focus(focus, focus_prob, config)
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
        if surface is not None and self.pinned is not None:  # the keyword's surface, as IOSUAVEnv's
            other = single_node_id(self.pinned, knowledge, random=True)
            check_config_keywords(own, self.pinned, {"surface": surface}, other if other != own else None)
            self.pinned = self.pinned.replace(surface=surface)
        super().__init__(env, self.pinned or ranges.base, instance_features=instance_features, **kwargs)
        self._check_overrides(overrides, ranges.surfaces)
        if self.pinned is not None:
            self.check_scenario(self.pinned, "config")

    _draws = True

    def _ranges(self) -> ScenarioRanges:
        """The observation space holds every scenario of the ranges (focus lies inside them)."""
        return self.ranges

    def _episode_config(self, pinned: ScenarioConfig | None) -> ScenarioConfig:
        if pinned is not None:
            return pinned
        if self.pinned is not None:
            return self.pinned
        if self.focus_prob > 0.0 and self.np_random.random() < self.focus_prob:
            return sample_scenario(self.np_random, self.focus)
        return sample_scenario(self.np_random, self.ranges)
