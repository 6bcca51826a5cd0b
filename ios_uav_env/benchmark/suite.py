"""Frozen, versioned benchmark suites: scenarios and their reference values, checked at load.

A suite is one JSON file in ``ios_uav_env/benchmark/suites/`` named after the suite
(``single-node-v1.json``) and registered in :data:`SUITES` with the SHA-256 of its content
(:func:`content_hash`: the canonical JSON of everything in the file). :func:`load_suite`
recomputes the hash and raises ``ValueError`` on a mismatch: a suite never changes under its
name; a change (new scenarios, new reference values) is a new version, a new name.

Each scenario holds its full ``ScenarioConfig`` and its reference values, rates in bps/Hz
(eq. (9), ``ios_uav_env.average_rate`` of the reference's own trajectory):

- ``dp``: the DP optimum over a grid (``rate``, ``resolution`` in m; ``baselines.dp`` in a
  checkout), the normaliser of the score (:attr:`Suite.normalizer`);
- ``sca``: the paper's SCA plan (``rate``, ``feasible``, ``seconds``: its wall time to plan);
- ``hover_peak`` / ``hover_ground``: ``ios_uav_env.envs.policies.HoverAt("peak")`` /
  ``HoverAt("ground")`` rolled out in the suite's env (``rate``, ``feasible``).

A multi-node suite (``"kind": "multi-node"``, e.g. ``multi-node-v1``; frozen by
``python -m baselines.references`` in a checkout) holds, per scenario, max-min rates
(``ios_uav_env.maxmin_rate``, bps/Hz) of :data:`MULTI_REFERENCES`:

- ``sca``: the SCA plan inside BCD (``baselines.sca.solve``, K > 1), the normaliser
  (``rate``, ``feasible``, ``seconds``);
- ``tour``: the tour heuristic (``baselines.tour.solve``: ``rate``, ``feasible``, ``seconds``);
- ``bound``: the certified upper bound (``baselines.dp_bound.solve_multinode``:
  ``upper_bound``, ``resolution``, and the DP-bound plan's ``plan_rate``).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ios_uav_env.model.config import ScenarioConfig

FORMAT = "ios_uav_env benchmark suite"
#: Folder of the shipped suite files (package data).
SUITE_DIR = Path(__file__).resolve().parent / "suites"
#: Reference values every scenario of a single-node suite holds.
REFERENCES = ("dp", "sca", "hover_peak", "hover_ground")
#: Reference values every scenario of a multi-node suite holds.
MULTI_REFERENCES = ("sca", "tour", "bound")
SINGLE_NODE, MULTI_NODE = "single-node", "multi-node"


@dataclass(frozen=True)
class RegisteredSuite:
    """A shipped suite: its file in :data:`SUITE_DIR` and the SHA-256 of its content."""

    file: str
    sha256: str


#: The shipped suites by name. Never edit an entry: add a new name (version) instead.
SUITES: dict[str, RegisteredSuite] = {
    "single-node-v1": RegisteredSuite(
        "single-node-v1.json", "9706ed92525a331800c09efba281aa265393308eab700c62599761fd2df0ece3"
    ),
    "multi-node-v1": RegisteredSuite(
        "multi-node-v1.json", "7d30ec3c73ac4f8d82c7256f3e8cb274e3a3872dfba1c81c941ccaf164ab2f98"
    ),
}
DEFAULT_SUITE = "single-node-v1"


@dataclass(frozen=True)
class SuiteScenario:
    """One scenario of a suite: its index, its config and its reference values by name."""

    index: int
    config: ScenarioConfig
    reference: Mapping[str, Mapping[str, Any]]

    def rate(self, reference: str) -> float:
        """The rate (bps/Hz) of ``reference`` (one of the suite's references) on this scenario;
        for a multi-node suite's ``"bound"``, the certified upper bound."""
        if reference not in self.reference:
            raise KeyError(
                f"scenario {self.index} has no reference {reference!r}; it has {sorted(self.reference)}"
            )
        return float(self.reference[reference]["upper_bound" if reference == "bound" else "rate"])

    @property
    def dp_rate(self) -> float:
        return self.rate("dp")

    @property
    def sca_rate(self) -> float:
        return self.rate("sca")


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
    kind: str = SINGLE_NODE  # "single-node" (eq. (9), % of DP) or "multi-node" (max-min, % of SCA)
    references: tuple[str, ...] = REFERENCES

    @property
    def multi_node(self) -> bool:
        return self.kind == MULTI_NODE

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


def content_hash(data: Mapping[str, Any]) -> str:
    """SHA-256 (hex) of the canonical JSON of a suite's content (sorted keys, no spaces)."""
    blob = json.dumps(data, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()


def suite_text(data: Mapping[str, Any]) -> str:
    """A suite's content as its file's text: the header indented, then one line per scenario."""
    head = {k: v for k, v in data.items() if k != "scenarios"}
    lines = ["  " + json.dumps(s, sort_keys=True, separators=(",", ":")) for s in data["scenarios"]]
    text = json.dumps(head, indent=1)
    return text[: text.rindex("}")].rstrip() + ',\n "scenarios": [\n' + ",\n".join(lines) + "\n ]\n}\n"


def suite_path(name: str) -> Path:
    """The file of the shipped suite ``name`` (``KeyError`` listing the names if unknown)."""
    if name not in SUITES:
        raise KeyError(f"no suite named {name!r}; the suites are {sorted(SUITES)}")
    return SUITE_DIR / SUITES[name].file


def load_suite(suite: str | Path = DEFAULT_SUITE) -> Suite:
    """Load a suite by name (:data:`SUITES`) or from a file, checking its content hash.

    A file whose ``name`` is registered must hash to the registered value, wherever it lies
    (``ValueError`` otherwise: the file was modified); a file with an unregistered name (a
    suite being built) loads with its own hash.
    """
    path = Path(suite) if isinstance(suite, Path) or str(suite).endswith(".json") else suite_path(str(suite))
    data = json.loads(path.read_text(encoding="utf-8"))
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ValueError(f"{path} is not a benchmark suite file (format {FORMAT!r})")
    name, digest = str(data["name"]), content_hash(data)
    registered = SUITES.get(name)
    if registered is not None and digest != registered.sha256:
        raise ValueError(
            f"suite {name!r} at {path} has sha256 {digest}, not the registered {registered.sha256}: "
            "the file was modified. A suite never changes under its name; a change is a new version "
            "(a new name and a new entry in ios_uav_env.benchmark.SUITES)."
        )
    scenarios = []
    for rec in data["scenarios"]:
        missing = [r for r in data["references"] if r not in rec]
        if missing:
            raise ValueError(f"{path}: scenario {rec.get('index')} lacks the reference values {missing}")
        reference = {r: dict(rec[r]) for r in data["references"]}
        scenarios.append(SuiteScenario(int(rec["index"]), ScenarioConfig(**rec["config"]), reference))
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
        kind=str(data.get("kind", SINGLE_NODE)),
        references=tuple(data["references"]),
    )


def list_suites() -> list[dict[str, Any]]:
    """Name, version, size, env id and hash of every shipped suite."""
    rows = []
    for name in SUITES:
        s = load_suite(name)
        rows.append({"name": name, "version": s.version, "n": len(s), "env_id": s.env_id,
                     "normalizer": s.normalizer, "sha256": s.sha256})  # fmt: skip
    return rows
