"""One scenario of a benchmark suite, and the check of its record in a suite file.

A :class:`SuiteScenario` is a scenario's index, config and reference values by name (with a
mobile or surface-control suite's episode seed, a several-UAV suite's fleet, a surface-control
suite's env keywords). :func:`scenario_from_record` reads one record of a suite file's
``scenarios`` into one, checked (``ValueError`` naming the file, the scenario's index and the
field): its config valid for the suite's kind, its reference values finite (the scored
references' > 0), none above the certified bound where the kind has one. ``load_suite``
(:mod:`ios_uav_env.benchmark.suite`, which re-exports these names) reads a file with it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ios_uav_env.benchmark.suite_registry import (
    BOUND_REL,
    ENERGY,
    MISO_CONTROL,
    MOBILE,
    MOBILE_KINDS,
    MULTI_NODE_MOBILE,
    MULTI_UAV,
    SINGLE_NODE,
    STAR_CONTROL,
    UNIT,
    VALUE_KEY,
)
from ios_uav_env.model.config import ScenarioConfig

#: The kinds whose policy sets a surface (and beams) every slot of a given line, scored by
#: ``star_scoring.evaluate_star``.
SURFACE_CONTROL = (STAR_CONTROL, MISO_CONTROL)


@dataclass(frozen=True)
class SuiteScenario:
    """One scenario of a suite: its index, its config and its reference values by name."""

    index: int
    config: ScenarioConfig
    reference: Mapping[str, Mapping[str, Any]]
    kind: str = SINGLE_NODE  # the suite's kind: what value() reads (VALUE_KEY)
    seed: int | None = None  # a mobile or STAR-control suite's episode seed (the node's path, the line)
    fleet: Mapping[str, Any] | None = None  # a several-UAV suite's fleet (benchmark.fleet_suite)
    star: Mapping[str, Any] | None = None  # a STAR-control suite's env keywords (benchmark.star_suite)
    miso: Mapping[str, Any] | None = None  # a MISO-control suite's env keywords (benchmark.miso_suite)

    def paths(self) -> Any:
        """(N, 1, 2) m: the node's true path of a mobile scenario (drawn from ``seed`` as the env
        and ``run_online`` draw it); None for a static suite."""
        if self.seed is None or self.kind not in MOBILE_KINDS:
            return None
        import numpy as np

        from ios_uav_env.model.motion import node_paths

        return node_paths(self.config, np.random.default_rng(self.seed))

    def rate(self, reference: str) -> float:
        """The rate (bps/Hz) of ``reference`` (one of the suite's references) on this scenario;
        for a multi-node suite's ``"bound"``, the certified upper bound. An energy suite's
        plan references hold their rate too; its bound is on EE (``KeyError`` for it here)."""
        if reference not in self.reference:
            raise KeyError(
                f"scenario {self.index} has no reference {reference!r}; it has {sorted(self.reference)}"
            )
        if self.kind == ENERGY and reference == "bound":
            raise KeyError(f"scenario {self.index}: an energy suite's bound is on EE: use value('bound')")
        return float(self.reference[reference]["upper_bound" if reference == "bound" else "rate"])

    def value(self, reference: str) -> float:
        """The value of ``reference`` that scores are percentages of: the rate (bps/Hz) on a
        rate suite, the energy efficiency (bits/J) on an energy suite; a ``"bound"``'s
        ``upper_bound``."""
        if reference not in self.reference:
            raise KeyError(
                f"scenario {self.index} has no reference {reference!r}; it has {sorted(self.reference)}"
            )
        return float(
            self.reference[reference]["upper_bound" if reference == "bound" else VALUE_KEY[self.kind]]
        )

    @property
    def dp_rate(self) -> float:
        return self.rate("dp")

    @property
    def sca_rate(self) -> float:
        return self.rate("sca")


def scenario_from_record(
    path: Path, kind: str, references: tuple[str, ...], scored: tuple[str, ...], position: int, rec: Any
) -> SuiteScenario:
    """Scenario ``position`` of a suite file, checked (``ValueError`` naming it and the field)."""
    where = f"{path}: scenario {position}"
    if not isinstance(rec, dict):
        raise ValueError(f"{where} must be an object (index, config and reference values), got {rec!r}")
    index = rec.get("index")
    if isinstance(index, bool) or not isinstance(index, int):
        raise ValueError(f"{where}: index must be an integer, got {index!r}")
    missing = [r for r in references if r not in rec]
    if missing or not isinstance(rec.get("config"), dict):
        lacks = (
            f"the reference values {missing}"
            if missing
            else "its config (an object of ScenarioConfig fields)"
        )
        raise ValueError(f"{path}: scenario {index} lacks {lacks}")
    try:
        config = ScenarioConfig(**rec["config"])
    except (TypeError, ValueError) as err:
        raise ValueError(f"{path}: scenario {index}: config: {err}") from None
    if kind in (SINGLE_NODE, ENERGY, MOBILE) and config.K != 1:
        raise ValueError(
            f"{path}: scenario {index}: a {kind} suite's config has one node, got K = {config.K}"
        )
    if kind == ENERGY and config.objective != "energy_efficiency":
        raise ValueError(
            f"{path}: scenario {index}: an energy suite's config has the objective 'energy_efficiency', "
            f"got {config.objective!r}"
        )
    if kind in (MULTI_NODE_MOBILE, MULTI_UAV) and config.K < 2:
        raise ValueError(f"{path}: scenario {index}: a {kind} suite's config has K >= 2 nodes, got K = 1")
    fleet = None
    if kind == MULTI_UAV:
        from ios_uav_env.benchmark.fleet_suite import check_fleet

        fleet = check_fleet(config, rec.get("fleet"), f"{path}: scenario {index}")
    elif "fleet" in rec:
        raise ValueError(f"{path}: scenario {index}: only a several-UAV suite's scenarios have a fleet")
    seed = rec.get("seed")
    star = miso = None
    if kind == STAR_CONTROL:
        from ios_uav_env.benchmark.star_suite import check_star

        star = check_star(config, rec.get("star"), seed, f"{path}: scenario {index}")
    elif "star" in rec:
        raise ValueError(f"{path}: scenario {index}: only a STAR-control suite's scenarios have a star")
    if kind == MISO_CONTROL:
        from ios_uav_env.benchmark.miso_suite import check_miso

        miso = check_miso(config, rec.get("miso"), seed, f"{path}: scenario {index}")
    elif "miso" in rec:
        raise ValueError(f"{path}: scenario {index}: only a MISO-control suite's scenarios have a miso")
    if kind in MOBILE_KINDS:
        if config.motion is None:
            raise ValueError(
                f"{path}: scenario {index}: a mobile suite's config needs a motion model, got None"
            )
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise ValueError(
                f"{path}: scenario {index}: seed must be an integer >= 0 (the episode's), got {seed!r}"
            )
    elif seed is not None and kind not in SURFACE_CONTROL:
        raise ValueError(
            f"{path}: scenario {index}: only a mobile suite's scenarios have a seed (and a surface-control "
            "suite's)"
        )
    reference = {}
    for r in references:
        values = rec[r]
        if not isinstance(values, dict):
            raise ValueError(
                f"{path}: scenario {index}: {r} must be an object of reference values, got {values!r}"
            )
        key = "upper_bound" if r == "bound" else VALUE_KEY[kind]
        low = 0.0 if r in scored or kind == ENERGY else None  # a score is a percentage of it: > 0
        _number(values.get(key), f"{path}: scenario {index}: {r}.{key} ({UNIT[kind]})", low)
        for field in ("seconds", "plan_rate", "resolution", *(("rate", "energy") if kind == ENERGY else ())):
            if field in values:
                _number(values[field], f"{path}: scenario {index}: {r}.{field}", None)
        for field in ("feasible", "plan_feasible"):
            if field in values and not isinstance(values[field], bool):
                raise ValueError(
                    f"{path}: scenario {index}: {r}.{field} must be true or false, got {values[field]!r}"
                )
        reference[r] = dict(values)
    if kind in (ENERGY, MULTI_UAV, *SURFACE_CONTROL, *MOBILE_KINDS) and "bound" in reference:
        bound = float(reference["bound"]["upper_bound"])
        above = [f"{r} {reference[r][VALUE_KEY[kind]]!r}" for r in references if r != "bound"
                 and float(reference[r][VALUE_KEY[kind]]) > bound * (1.0 + BOUND_REL)]  # fmt: skip
        if above:
            what = "EE" if kind == ENERGY else "rate"
            raise ValueError(
                f"{path}: scenario {index}: the certified bound.upper_bound {bound!r} {UNIT[kind]} is below "
                f"{', '.join(above)}: no plan's {what} may exceed it"
            )
    seeded = kind in (*MOBILE_KINDS, *SURFACE_CONTROL)
    return SuiteScenario(index, config, reference, kind, seed if seeded else None, fleet, star, miso)


def _number(value: Any, where: str, above: float | None) -> None:
    """``value`` must be a finite number >= 0 (> ``above`` when given)."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or value < 0 or (above is not None and value <= above):
        bound = f"> {above:g}" if above is not None else ">= 0"
        raise ValueError(f"{where} must be a finite number {bound}, got {value!r}")
