"""Frozen, versioned benchmark suites: scenarios and their reference values, checked at load.

A suite is one JSON file in ``ios_uav_env/benchmark/suites/`` named after the suite
(``single-node-v1.json``) and registered in :data:`SUITES` with the SHA-256 of its content
(:func:`content_hash`: the canonical JSON of everything in the file). :func:`load_suite`
recomputes the hash and raises ``ValueError`` on a mismatch: a suite never changes under its
name; a change (new scenarios, new reference values) is a new version, a new name.

The suite kinds, the references each holds and what they mean, the registry and the name and
identity checks: :mod:`ios_uav_env.benchmark.suite_registry`; a suite's scenario and the check of
its record: :mod:`ios_uav_env.benchmark.suite_scenario` (both re-exported here).
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ios_uav_env.benchmark.suite_registry import (  # noqa: F401 (the registry, re-exported)
    BOUND_REL,
    DEFAULT_SUITE,
    ENERGY,
    ENERGY_REFERENCES,
    FLEET_ENV_ID,
    FLEET_REFERENCES,
    FORMAT,
    KIND_REFERENCES,
    MISO_CONTROL,
    MISO_ENV_ID,
    MOBILE,
    MOBILE_KINDS,
    MOBILE_REFERENCES,
    MOBILE_V2_REFERENCES,
    MULTI_MOBILE_REFERENCES,
    MULTI_NODE,
    MULTI_NODE_MOBILE,
    MULTI_REFERENCES,
    MULTI_UAV,
    NAME_PATTERN,
    NORMALISERS,
    REFERENCES,
    SCORED,
    SINGLE_NODE,
    STAR_CONTROL,
    STAR_ENV_ID,
    STAR_REFERENCES,
    SUITE_DIR,
    SUITES,
    TIMED,
    UNIT,
    VALUE_KEY,
    RegisteredSuite,
    check_suite_name,
    content_hash,
    scored_references,
    suite_path,
    suite_text,
)
from ios_uav_env.benchmark.suite_scenario import (  # noqa: F401 (the scenarios, re-exported)
    SURFACE_CONTROL,
    SuiteScenario,
    scenario_from_record,
)


@dataclass(frozen=True)
class Suite:
    """A loaded, hash-checked suite."""

    name: str
    version: int
    env_id: str  # the env the scenarios are run in (pinned with reset(options={"config": cfg}))
    env_kwargs: Mapping[str, Any]  # its arguments (a policy may add its own, e.g. peak_hint)
    normalizer: str  # the reference the score is a percentage of ("dp")
    description: str
    scenarios: tuple[SuiteScenario, ...]
    sha256: str
    path: Path
    kind: str = SINGLE_NODE  # "single-node" (eq. (9), % of DP), "multi-node" (max-min, % of SCA), "energy"
    references: tuple[str, ...] = REFERENCES

    @property
    def multi_node(self) -> bool:
        return self.kind == MULTI_NODE

    @property
    def energy(self) -> bool:
        """Scores are of the energy efficiency (bits/J), not of the rate."""
        return self.kind == ENERGY

    @property
    def mobile(self) -> bool:
        """The nodes move: each scenario's episode seed fixes their paths and the reports' noise."""
        return self.kind in MOBILE_KINDS

    @property
    def fleets(self) -> bool:
        """Several UAVs: each scenario flies its fleet in ``ios_uav_env.parallel_env``."""
        return self.kind == MULTI_UAV

    @property
    def star_control(self) -> bool:
        """The surface as the agent's control: each scenario's episode in ``STARControl-v0``, or
        the beams and the surface in ``MISOControl-v0`` (:attr:`miso_control`)."""
        return self.kind in SURFACE_CONTROL

    @property
    def miso_control(self) -> bool:
        """The UAV's beams and the surface's phases as the agent's control (``MISOControl-v0``)."""
        return self.kind == MISO_CONTROL

    @property
    def schedules(self) -> bool:
        """K > 1 nodes: plans carry TDMA shares (a multi-node or multi-node mobile suite)."""
        return self.kind in (MULTI_NODE, MULTI_NODE_MOBILE)

    @property
    def scores(self) -> tuple[str, ...]:
        """The references the scores are percentages of, the normaliser first (:func:`scored_references`)."""
        return scored_references(self.kind, self.normalizer)

    def __len__(self) -> int:
        return len(self.scenarios)

    def __iter__(self) -> Iterator[SuiteScenario]:
        return iter(self.scenarios)

    def __getitem__(self, i: int) -> SuiteScenario:
        return self.scenarios[i]

    def subset(self, n: int | None = None) -> tuple[SuiteScenario, ...]:
        """The first ``n`` scenarios (all for None): a fixed subset, e.g. for a quick check."""
        if n is None:
            return self.scenarios
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise ValueError(f"n must be an integer >= 1 or None, got {n!r}")
        return self.scenarios[:n]


def load_suite(suite: str | Path = DEFAULT_SUITE) -> Suite:
    """Load a suite by name (:data:`SUITES`) or from a file, checking its content hash.

    A file whose ``name`` is registered must hash to the registered value, wherever it lies
    (``ValueError`` otherwise: the file was modified); a file with an unregistered name (a
    suite being built) loads with its own hash if the name is canonical and cannot be taken for
    a registered one (:func:`check_suite_name`). Every file is checked (``ValueError`` naming
    the file, the field and, for a scenario, its index): a non-empty ``name``, a ``version``
    >= 1, a ``kind`` of :data:`KIND_REFERENCES`, an ``env_id`` of this package for that kind,
    the kind's ``normalizer`` and references (:data:`KIND_REFERENCES`, :data:`SCORED`), and per
    scenario a valid config (one node for a single-node suite) and finite reference values
    (rates >= 0, the scored references' > 0, times >= 0); JSON's NaN and Infinity are refused.
    An energy suite's scenarios have one node and the objective ``"energy_efficiency"``, every
    reference's EE (bits/J) > 0, and none above the bound (by more than :data:`BOUND_REL`).
    A STAR-control suite's scenarios hold the env's keywords, an episode seed and the episode's
    config (``star_suite.check_star``), and no value above the bound.
    """
    path = Path(suite) if isinstance(suite, Path) or str(suite).endswith(".json") else suite_path(str(suite))
    data = _read_json(path)
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ValueError(f"{path} is not a benchmark suite file (format {FORMAT!r})")
    name = data.get("name")
    if not isinstance(name, str) or not name.strip():
        raise ValueError(f"{path}: name must be a non-empty string (the suite's name), got {name!r}")
    check_suite_name(name, str(path))
    digest = content_hash(data)
    registered = SUITES.get(name)
    if registered is not None and digest != registered.sha256:
        raise ValueError(
            f"suite {name!r} at {path} has sha256 {digest}, not the registered {registered.sha256}: "
            "the file was modified. A suite never changes under its name; a change is a new version "
            "(a new name and a new entry in ios_uav_env.benchmark.SUITES)."
        )
    kind, references = _check_header(path, data)
    records = data.get("scenarios")
    if not isinstance(records, list) or not records:
        raise ValueError(f"{path}: scenarios must be a non-empty list of scenario objects")
    scored = scored_references(kind, data["normalizer"])
    scenarios = [
        scenario_from_record(path, kind, references, scored, i, rec) for i, rec in enumerate(records)
    ]
    if [s.index for s in scenarios] != list(range(len(scenarios))):
        raise ValueError(f"{path}: scenario indices must be 0 .. n-1 in order")
    return Suite(
        name=name,
        version=int(data["version"]),
        env_id=str(data["env_id"]),
        env_kwargs=dict(data.get("env_kwargs", {})),
        normalizer=str(data["normalizer"]),
        description=str(data.get("description", "")),
        scenarios=tuple(scenarios),
        sha256=digest,
        path=path,
        kind=kind,
        references=references,
    )


def suite_of(suite: Suite | str | Any) -> Suite:
    """``suite`` itself if loaded, else :func:`load_suite` of it."""
    return suite if isinstance(suite, Suite) else load_suite(suite)


def _read_json(path: Path) -> Any:
    """The JSON content of ``path`` (``ValueError`` naming it if it is not JSON of finite numbers)."""

    def constant(word: str) -> Any:
        raise ValueError(f"{path}: {word} is not a number a suite may hold (finite numbers only)")

    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as err:
        raise ValueError(f"{path} is not a benchmark suite file (not UTF-8 text: {err})") from None
    try:
        return json.loads(text, parse_constant=constant)
    except json.JSONDecodeError as err:
        raise ValueError(f"{path} is not a benchmark suite file (not JSON: {err})") from None


def _check_header(path: Path, data: Mapping[str, Any]) -> tuple[str, tuple[str, ...]]:
    """Check a suite file's fields other than its scenarios; its kind and references (a
    normaliser of :data:`NORMALISERS`, whose scored references the file must hold)."""
    from ios_uav_env.envs.registration import (
        ENERGY_IDS,
        ENV_IDS,
        MOBILE_IDS,
        MULTINODE_IDS,
        MULTINODE_MOBILE_IDS,
        RANDOM_ENV_ID,
    )

    version = data.get("version")
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise ValueError(f"{path}: version must be an integer >= 1, got {version!r}")
    kind = data.get("kind", SINGLE_NODE)
    if kind not in KIND_REFERENCES:
        raise ValueError(f"{path}: kind must be one of {list(KIND_REFERENCES)}, got {kind!r}")
    ids = {
        MULTI_NODE: MULTINODE_IDS,
        ENERGY: ENERGY_IDS,
        MOBILE: MOBILE_IDS,
        MULTI_NODE_MOBILE: MULTINODE_MOBILE_IDS,
        MULTI_UAV: {FLEET_ENV_ID: {}},
        STAR_CONTROL: {STAR_ENV_ID: {}},
        MISO_CONTROL: {MISO_ENV_ID: {}},
    }
    env_ids = list(ids[kind]) if kind in ids else [*ENV_IDS, RANDOM_ENV_ID]
    if data.get("env_id") not in env_ids:
        raise ValueError(
            f"{path}: env_id of a {kind} suite must be one of {env_ids}, got {data.get('env_id')!r}"
        )
    if not isinstance(data.get("env_kwargs", {}), dict):
        raise ValueError(f"{path}: env_kwargs must be an object of env arguments, got {data['env_kwargs']!r}")
    try:
        scored = scored_references(kind, data.get("normalizer"))
    except ValueError as err:
        raise ValueError(f"{path}: {err}") from None
    references = data.get("references")
    allowed = KIND_REFERENCES[kind]
    if (
        not isinstance(references, list)
        or len(set(map(str, references))) != len(references)
        or not set(scored) <= set(references) <= set(allowed)
    ):
        raise ValueError(
            f"{path}: references of a {kind} suite must be distinct names of {list(allowed)} including "
            f"{list(scored)}, got {references!r}"
        )
    return str(kind), tuple(references)


def list_suites() -> list[dict[str, Any]]:
    """Name, version, size, env id and hash of every shipped suite."""
    rows = []
    for name in SUITES:
        s = load_suite(name)
        rows.append({"name": name, "version": s.version, "n": len(s), "env_id": s.env_id,
                     "normalizer": s.normalizer, "sha256": s.sha256})  # fmt: skip
    return rows
