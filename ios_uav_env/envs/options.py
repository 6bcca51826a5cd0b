"""The env's own options (how it steps and observes), kept apart from the scenario (what it simulates).

An env is made from a scenario (``ScenarioConfig``: the physics, the paper's parameters) and
:class:`EnvOptions` (the channel sample, the arrival guard, the reward weights, the
observation's scale and extra features). Both can be given as keywords to ``gym.make``;
:func:`split_kwargs` sorts them by name, so the two namespaces never mix, and refuses any
other keyword with Python's own ``TypeError`` wording (which libraries such as TorchRL
rely on to retry without their own keywords). A setting that another one makes do nothing is
refused, naming what it needs: ``report_sigma`` and ``filter_estimate`` need
``knowledge="reports"``, and ``reach_weight`` / ``terminal_weight`` other than their defaults need
``arrival_guard=False`` (the guard keeps both penalties at 0).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ios_uav_env.model.config import SCENARIO_FIELDS
from ios_uav_env.model.reports import REPORT_SIGMA

#: Values of the ``channel`` option: the expected-gain rate (the paper's objective) or a
#: Rician faded-rate sample per slot.
CHANNELS: tuple[str, ...] = ("expected", "rician")
#: Values of the ``knowledge`` option: what the UAV is told of the ground node each slot (its
#: true position, a noisy position report and the measured rate, or the measured rate only;
#: ``ios_uav_env.envs.knowledge``).
KNOWLEDGE: tuple[str, ...] = ("exact", "reports", "rates")


def _flag(value: Any, name: str) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def _number(value: Any, name: str, *, positive: bool) -> float:
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or (value <= 0 if positive else value < 0):
        raise ValueError(f"{name} must be a finite number {'> 0' if positive else '>= 0'}, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class EnvOptions:
    """How the env steps and what it observes (the scenario is a ``ScenarioConfig``)."""

    channel: str = "expected"  # "expected" (deterministic) or "rician" (one faded sample per slot)
    arrival_guard: bool = True  # project every move onto the set that still reaches qF in time
    reach_weight: float = 1.0  # weight of the reach penalty (moves out of reach of qF; no guard only)
    terminal_weight: float = 2.0  # weight of the terminal penalty (final miss, in moves; no guard only)
    length_scale: float = 400.0  # m, L: lengths in the observation are divided by it
    instance_features: bool = False  # append the 6 features of the instance
    peak_hint: bool = False  # append the 3 features of the reachable rate peak
    # bits/J, lambda_ref of the energy reward (objective "energy_efficiency" only); None: the
    # scenario's own reference, the EE of its hover plan (observation.reference_efficiency);
    # "loiter": the better EE of its loiter and hover flights (observation.loiter_efficiency)
    energy_reference: float | str | None = None
    # what the UAV is told of the node each slot (KNOWLEDGE; "exact": its true position)
    knowledge: str = "exact"
    report_sigma: float = REPORT_SIGMA  # m, s: std of each component of a report's error (reports only)
    # knowledge "reports": the node features are the Kalman filter's estimate, not the raw report
    filter_estimate: bool = False

    def __post_init__(self) -> None:
        if self.channel not in CHANNELS:
            raise ValueError(f"channel must be one of {CHANNELS}, got {self.channel!r}")
        if self.knowledge not in KNOWLEDGE:
            raise ValueError(f"knowledge must be one of {KNOWLEDGE}, got {self.knowledge!r}")
        object.__setattr__(
            self, "report_sigma", _number(self.report_sigma, "report_sigma (m)", positive=False)
        )
        for name in ("arrival_guard", "instance_features", "peak_hint", "filter_estimate"):
            object.__setattr__(self, name, _flag(getattr(self, name), name))
        if self.filter_estimate and self.knowledge != "reports":
            raise ValueError(
                "filter_estimate is the Kalman filter of the position reports: it needs knowledge='reports', "
                f"got knowledge={self.knowledge!r}"
            )
        if self.report_sigma != REPORT_SIGMA and self.knowledge != "reports":
            raise ValueError(
                f"report_sigma is the std of the position reports: it needs knowledge='reports', got "
                f"knowledge={self.knowledge!r} (where report_sigma={self.report_sigma!r} would do nothing)"
            )
        for name in ("reach_weight", "terminal_weight"):
            object.__setattr__(self, name, _number(getattr(self, name), name, positive=False))
            if self.arrival_guard and getattr(self, name) != _DEFAULT_WEIGHTS[name]:
                raise ValueError(
                    f"{name} weighs a penalty for missing qF, which the arrival guard keeps at 0: it needs "
                    f"arrival_guard=False (with the guard {name}={getattr(self, name)!r} would do nothing)"
                )
        object.__setattr__(
            self, "length_scale", _number(self.length_scale, "length_scale (m)", positive=True)
        )
        if self.energy_reference is not None and self.energy_reference != "loiter":
            if isinstance(self.energy_reference, str):
                got = self.energy_reference
                raise ValueError(
                    f"energy_reference must be None, 'loiter' or a number > 0 (bits/J), got {got!r}"
                )
            reference = _number(self.energy_reference, "energy_reference (bits/J)", positive=True)
            object.__setattr__(self, "energy_reference", reference)


#: The penalty weights' defaults: another weight needs ``arrival_guard=False`` (with the guard both
#: penalties are always 0).
_DEFAULT_WEIGHTS = {"reach_weight": 1.0, "terminal_weight": 2.0}

#: The names of the ``EnvOptions`` fields.
OPTION_FIELDS: frozenset[str] = frozenset(f.name for f in dataclasses.fields(EnvOptions))


def split_kwargs(kwargs: Mapping[str, Any], owner: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """(options, scenario fields) of ``kwargs``; any other name raises ``TypeError`` as Python
    would for ``owner`` (e.g. ``"IOSUAVEnv.__init__"``)."""
    options, scenario = {}, {}
    for name, value in kwargs.items():
        if name in OPTION_FIELDS:
            options[name] = value
        elif name in SCENARIO_FIELDS:
            scenario[name] = value
        else:
            raise TypeError(f"{owner}() got an unexpected keyword argument {name!r}")
    return options, scenario


class EnvViews:
    """What a stepper reads through its env and its options (the steppers' common read-only
    views): ``np_random``, the env's generator (``gym.Env.np_random``, the one every draw of the
    episode uses), the options every view has, from ``self.options``, and the check of a step's
    action."""

    env: Any
    options: EnvOptions
    config: Any
    action_space: Any

    @property
    def np_random(self) -> np.random.Generator:
        """The env's generator, the one every draw of the episode uses."""
        return self.env.np_random

    def checked_action(self, action: Any, started: bool, ended: bool) -> np.ndarray:
        """``action`` as float64 for a step: ``RuntimeError`` before a reset (``started`` False) or
        after the episode's end (``ended``), ``ValueError`` unless it is finite and of the action
        space's shape."""
        if not started:
            raise RuntimeError("call reset() before step()")
        if ended:
            raise RuntimeError(f"the episode ended at slot N = {self.config.N}; call reset()")
        a = np.asarray(action, dtype=np.float64)
        if a.shape != self.action_space.shape:
            raise ValueError(f"action must have shape {self.action_space.shape}, got {a.shape}")
        if not np.isfinite(a).all():
            raise ValueError(f"action must be finite (no NaN or inf), got {action!r}")
        return a

    channel = property(lambda self: self.options.channel)
    arrival_guard = property(lambda self: self.options.arrival_guard)
    length_scale = property(lambda self: self.options.length_scale)
