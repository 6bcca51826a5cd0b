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

An energy suite (``"kind": "energy"``, e.g. ``energy-v1``; frozen by ``python -m
baselines.references energy``) runs in an energy id (``ios_uav_env.envs.registration.ENERGY_IDS``)
and holds, per scenario (objective ``"energy_efficiency"``), energy efficiencies EE = B T R / E
(bits/J, ``ios_uav_env.score_plan(...).energy_efficiency``) of :data:`ENERGY_REFERENCES`:

- ``dp``: the energy DP's plan (``baselines.dp_energy.solve_ee``: ``energy_efficiency``,
  ``rate``, ``energy``, ``resolution``, ``seconds``), the normaliser;
- ``sca``: SCA-EE started from that plan (``baselines.sca_energy.solve``: the same fields and
  ``feasible``);
- ``bound``: the certified upper bound on the EE of every feasible plan
  (``baselines.energy_bound.solve``: ``upper_bound``, ``resolution``, ``seconds``);
- ``loiter`` / ``hover``: the loiter and fly-to-the-peak-and-hover heuristics
  (``baselines.loiter``), as ``dp``.

Every EE is > 0 and none exceeds the bound (:func:`load_suite` refuses the file otherwise).

A mobile suite (``"kind": "mobile"``, e.g. ``mobile-v1``; frozen by ``python -m
baselines.references mobile``) runs in a moving-node id (``ios_uav_env.envs.registration.MOBILE_IDS``).
Each scenario (one node with a motion model) holds an episode ``seed``: the env reset with it
on the pinned scenario (``reset(seed=seed, options={"config": config})``) draws the node's true
path, its reports and its measured-rate noise exactly as ``baselines.mpc.run_online(config,
planner, seed)`` does, so every row faces the same truth and the same noise. Rates (bps/Hz, on
the true path: ``score_plan(config, q, paths=...)``) of :data:`MOBILE_REFERENCES`:

- ``bound``: the clairvoyant bound (``baselines.dp_bound.clairvoyant_bound`` on the true path:
  ``upper_bound``, ``resolution``, ``seconds``), the normaliser: no online policy exceeds it;
- ``clairvoyant``: the tour planner given the true path (``baselines.tour.solve(paths=...)``);
- ``mpc_k1`` / ``mpc_k10`` / ``plan_once``: ``baselines.mpc.MPC(k=1)``, ``MPC(k=10)`` and
  ``MPC(k=None)`` online (``rate``, ``feasible``, ``seconds``: planning time per episode);
- ``track_exact`` / ``track_reports``: ``HoverAt("ground")`` in the env on the true position /
  on the reports (fly to the node at full speed and follow it).

No reference exceeds the bound (:func:`load_suite` refuses the file otherwise).

A mobile suite whose ``normalizer`` is ``"optimum"`` (``mobile-v2``: :data:`MOBILE_V2_REFERENCES`)
adds ``optimum``, the clairvoyant DP on the true path (``baselines.dp_moving.solve``, planner
``dp-clairvoyant``: ``rate``, ``feasible``, ``resolution``, ``seconds``), its normaliser, and
``mpc_dp_k1`` / ``mpc_dp_k10``, ``MPC(k=1 / 10, planner="dp")`` online; its scores are % of the
optimum and % of the bound (:data:`NORMALISERS`). A multi-node mobile suite (``"kind":
"multi-node-mobile"``, ``multi-node-mobile-v1``) runs in ``ios_uav_env/IOSUAV-MultiNode-Mobile-v0``:
2 to 4 walking, reported nodes per scenario with its episode ``seed``, max-min rates with each
row's own shares on the true paths (:data:`MULTI_MOBILE_REFERENCES`: ``optimum`` and ``bound``
from ``dp_moving.solve(paths=...)``, i.e. ``dp_bound.solve_multinode``'s plan and certified
bound; the MPC rows; ``straight``, ``StraightEqualShares`` in the env), scored as % of the
optimum and of the bound, with the best schedule.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import unicodedata
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
#: Reference values every scenario of an energy suite holds.
ENERGY_REFERENCES = ("dp", "sca", "bound", "loiter", "hover")
#: Reference values every scenario of a mobile suite holds.
MOBILE_REFERENCES = ("bound", "clairvoyant", "mpc_k1", "mpc_k10", "plan_once", "track_exact", "track_reports")
#: Those of a mobile suite normalised by the clairvoyant optimum (mobile-v2), the optimum first.
MOBILE_V2_REFERENCES = ("optimum", "bound", "mpc_dp_k1", "mpc_dp_k10", "track_exact", "track_reports",
                        "mpc_k1", "mpc_k10", "plan_once", "clairvoyant")  # fmt: skip
#: Those of a multi-node mobile suite (no tracking heuristic: HoverAt needs one node).
MULTI_MOBILE_REFERENCES = ("optimum", "bound", "mpc_dp_k1", "mpc_dp_k10", "mpc_k1", "mpc_k10", "plan_once",
                           "clairvoyant", "straight")  # fmt: skip
SINGLE_NODE, MULTI_NODE, ENERGY, MOBILE = "single-node", "multi-node", "energy", "mobile"
MULTI_NODE_MOBILE = "multi-node-mobile"
#: The kinds whose scenarios hold an episode seed (moving nodes, scored on their true paths).
MOBILE_KINDS = (MOBILE, MULTI_NODE_MOBILE)
#: By suite kind: the references it may hold, and those its scores are percentages of (the
#: normaliser first), whose rates must be > 0 on every scenario.
KIND_REFERENCES = {
    SINGLE_NODE: REFERENCES,
    MULTI_NODE: MULTI_REFERENCES,
    ENERGY: ENERGY_REFERENCES,
    MOBILE: tuple(dict.fromkeys((*MOBILE_REFERENCES, *MOBILE_V2_REFERENCES))),
    MULTI_NODE_MOBILE: MULTI_MOBILE_REFERENCES,
}
SCORED = {
    SINGLE_NODE: ("dp", "sca"),
    MULTI_NODE: ("sca", "bound"),
    ENERGY: ("dp", "bound"),
    MOBILE: ("bound", "mpc_k1"),
    MULTI_NODE_MOBILE: ("optimum", "bound"),
}
#: By suite kind and normaliser (the file's ``normalizer``): the references scored, the normaliser
#: first. A kind's default is :data:`SCORED`'s; a mobile suite may be normalised by the optimum.
NORMALISERS: dict[str, dict[str, tuple[str, ...]]] = {kind: {refs[0]: refs} for kind, refs in SCORED.items()}
NORMALISERS[MOBILE]["optimum"] = ("optimum", "bound")
#: By suite kind: the reference whose planning time a policy's is compared with.
TIMED = {SINGLE_NODE: "sca", MULTI_NODE: "sca", ENERGY: "sca", MOBILE: "mpc_k1", MULTI_NODE_MOBILE: "mpc_k1"}
#: By suite kind: the key of a plan reference's value (a bound's is ``"upper_bound"``) and its unit.
VALUE_KEY = {SINGLE_NODE: "rate", MULTI_NODE: "rate", ENERGY: "energy_efficiency", MOBILE: "rate",
             MULTI_NODE_MOBILE: "rate"}  # fmt: skip
UNIT = {
    SINGLE_NODE: "bps/Hz",
    MULTI_NODE: "bps/Hz",
    ENERGY: "bits/J",
    MOBILE: "bps/Hz",
    MULTI_NODE_MOBILE: "bps/Hz",
}


def scored_references(kind: str, normalizer: str) -> tuple[str, ...]:
    """The references a ``kind`` suite normalised by ``normalizer`` is scored against (the
    normaliser first; :data:`NORMALISERS`); ``ValueError`` for a normaliser the kind has not."""
    if normalizer not in NORMALISERS.get(kind, {}):
        raise ValueError(
            f"normalizer of a {kind} suite must be one of {list(NORMALISERS.get(kind, {}))}, "
            f"got {normalizer!r}"
        )
    return NORMALISERS[kind][normalizer]


#: Relative slack of the energy and mobile suites' check that no reference exceeds the bound
#: (float rounding of two float64 computations of the same kind of sum; a real excess is far larger).
BOUND_REL = 1e-9


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
    "energy-v1": RegisteredSuite(
        "energy-v1.json", "08cba48a6aecf24dc29debc83c5beb6dc3ce29eeb3a2552e054c7decb6c6dec7"
    ),
    "mobile-v1": RegisteredSuite(
        "mobile-v1.json", "f3b2712dd4b82c0ce6bfc9bb941a930ad571db086c071d97f496f64cf18578e7"
    ),
    "mobile-v2": RegisteredSuite(
        "mobile-v2.json", "a20d796bb79315b07bb072d961092fae9accb88fcc24a911873b0a5ba9d06944"
    ),
}
DEFAULT_SUITE = "single-node-v1"
#: A suite's name: words of lowercase ASCII letters and digits joined by one "-", "." or "_"
#: (``single-node-v1``): no spaces, no capitals, no look-alike characters.
NAME_PATTERN = re.compile(r"[a-z0-9]+(?:[-._][a-z0-9]+)*")


def _name_key(name: str) -> str:
    """What a reader sees of a name: its letters and digits, case and width folded (NFKC)."""
    return "".join(c for c in unicodedata.normalize("NFKC", name).casefold() if c.isalnum())


def check_suite_name(name: Any, where: str) -> str:
    """``name`` if it is a canonical suite name (:data:`NAME_PATTERN`) that cannot be taken for
    another registered suite's; ``ValueError`` naming ``where``, the name and the rule otherwise.

    A name that differs from a registered one only by case, spacing, separators or look-alike
    characters (``" mobile-v1"``, ``"Mobile-V1"``, ``"mobile_v1"``) would print as that suite
    while holding other content: it is refused (the registered name itself is checked against
    its hash by :func:`load_suite`)."""
    twin = None
    if isinstance(name, str):
        twin = next((r for r in SUITES if r != name and _name_key(r) == _name_key(name)), None)
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        like = f" (it looks like the registered suite {twin!r})" if twin else ""
        raise ValueError(
            f"{where}: name must be lowercase ASCII letters and digits in words joined by one '-', '.' "
            f"or '_' (e.g. 'single-node-v1'), got {name!r}{like}"
        )
    if twin is not None:
        raise ValueError(
            f"{where}: name {name!r} differs from the registered suite {twin!r} only by its separators: "
            "it would be read as that suite; a new suite needs a name of its own"
        )
    return name


@dataclass(frozen=True)
class SuiteScenario:
    """One scenario of a suite: its index, its config and its reference values by name."""

    index: int
    config: ScenarioConfig
    reference: Mapping[str, Mapping[str, Any]]
    kind: str = SINGLE_NODE  # the suite's kind: what value() reads (VALUE_KEY)
    seed: int | None = None  # a mobile suite's episode seed: the node's path and the reports' noise

    def paths(self) -> Any:
        """(N, 1, 2) m: the node's true path of a mobile scenario (drawn from ``seed`` as the env
        and ``run_online`` draw it); None for a static suite."""
        if self.seed is None:
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
    suite being built) loads with its own hash if the name is canonical and cannot be taken for
    a registered one (:func:`check_suite_name`). Every file is checked (``ValueError`` naming
    the file, the field and, for a scenario, its index): a non-empty ``name``, a ``version``
    >= 1, a ``kind`` of :data:`KIND_REFERENCES`, an ``env_id`` of this package for that kind,
    the kind's ``normalizer`` and references (:data:`KIND_REFERENCES`, :data:`SCORED`), and per
    scenario a valid config (one node for a single-node suite) and finite reference values
    (rates >= 0, the scored references' > 0, times >= 0); JSON's NaN and Infinity are refused.
    An energy suite's scenarios have one node and the objective ``"energy_efficiency"``, every
    reference's EE (bits/J) > 0, and none above the bound (by more than :data:`BOUND_REL`).
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
    scenarios = [_scenario(path, kind, references, scored, i, rec) for i, rec in enumerate(records)]
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


def _scenario(
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
    if kind == MULTI_NODE_MOBILE and config.K < 2:
        raise ValueError(f"{path}: scenario {index}: a {kind} suite's config has K >= 2 nodes, got K = 1")
    seed = rec.get("seed")
    if kind in MOBILE_KINDS:
        if config.motion is None:
            raise ValueError(
                f"{path}: scenario {index}: a mobile suite's config needs a motion model, got None"
            )
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise ValueError(
                f"{path}: scenario {index}: seed must be an integer >= 0 (the episode's), got {seed!r}"
            )
    elif seed is not None:
        raise ValueError(f"{path}: scenario {index}: only a mobile suite's scenarios have a seed")
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
    if kind in (ENERGY, *MOBILE_KINDS) and "bound" in reference:
        bound = float(reference["bound"]["upper_bound"])
        above = [f"{r} {reference[r][VALUE_KEY[kind]]!r}" for r in references if r != "bound"
                 and float(reference[r][VALUE_KEY[kind]]) > bound * (1.0 + BOUND_REL)]  # fmt: skip
        if above:
            what = "EE" if kind == ENERGY else "rate"
            raise ValueError(
                f"{path}: scenario {index}: the certified bound.upper_bound {bound!r} {UNIT[kind]} is below "
                f"{', '.join(above)}: no plan's {what} may exceed it"
            )
    return SuiteScenario(index, config, reference, kind, seed if kind in MOBILE_KINDS else None)


def _number(value: Any, where: str, above: float | None) -> None:
    """``value`` must be a finite number >= 0 (> ``above`` when given)."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or value < 0 or (above is not None and value <= above):
        bound = f"> {above:g}" if above is not None else ">= 0"
        raise ValueError(f"{where} must be a finite number {bound}, got {value!r}")


def list_suites() -> list[dict[str, Any]]:
    """Name, version, size, env id and hash of every shipped suite."""
    rows = []
    for name in SUITES:
        s = load_suite(name)
        rows.append({"name": name, "version": s.version, "n": len(s), "env_id": s.env_id,
                     "normalizer": s.normalizer, "sha256": s.sha256})  # fmt: skip
    return rows
