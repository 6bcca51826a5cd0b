"""The suite registry: the shipped suites (:data:`SUITES`, their files and hashes), the suite
kinds and the references each holds, and the name and identity checks (:func:`check_suite_name`,
:func:`content_hash`, :func:`suite_text`, :func:`suite_path`). Loading a suite and checking its
content: :mod:`ios_uav_env.benchmark.suite`.

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
row's own shares on the true paths (:data:`MULTI_MOBILE_REFERENCES`: ``optimum``, the best plan
clairvoyant planners found, ``dp_bound.solve_multinode``'s or ``baselines.sca_multi``'s polished
from it and from the tour, with its ``source``; ``bound``, the same ``solve_multinode``'s certified
bound; the MPC rows but MPC over the tour at k = 1; ``straight``, ``StraightEqualShares`` in the
env), scored as % of the optimum and of the bound, with the best schedule.

A several-UAV suite (``"kind": "multi-uav"``, ``multi-uav-v1``; frozen by ``python -m
baselines.references multi-uav``) runs in ``ios_uav_env.parallel_env`` (:data:`FLEET_ENV_ID`):
each scenario holds its fleet (``uavs``, ``starts``, ``finals``, ``speeds``, ``access``,
``min_separation``) and the team's max-min rates (``fleet_maxmin``) of :data:`FLEET_REFERENCES`:
``planner`` (``baselines.fleet.solve``, the normaliser), ``bound`` (its certified upper bound),
``tour``, ``dual`` and ``straight`` (:mod:`ios_uav_env.benchmark.fleet_suite`).

A STAR-control suite (``"kind": "star-control"``, ``star-v1``; frozen by ``python -m
baselines.references star``) runs in ``ios_uav_env/STARControl-v0``, the agent setting a small STAR
surface in every slot: each scenario holds the env's keywords (``star``: ``elements``, ``bits``,
``group``, ``protocol``, ``access``, ``direct_link``), its episode ``seed`` and the episode's
``config`` (the line that seed draws, checked at every rollout), and episode values (the mean slot
value, bps/Hz: the return / N) of :data:`STAR_REFERENCES`: ``optimum`` (the per-slot optima, the
normaliser), ``bound`` (their certified upper bounds), ``quantised``, ``aligned``, ``phases`` and
``random`` (:mod:`ios_uav_env.benchmark.star_suite`).

A MISO-control suite (``"kind": "miso-control"``, ``miso-v1``; frozen by ``python -m
baselines.references miso``) runs in ``ios_uav_env/MISOControl-v0``, the agent setting a
multi-antenna UAV's beams and a small IOS's phases in every slot: each scenario holds the env's
keywords (``miso``: ``antennas``, ``users``, ``elements``, ``objective``), its episode ``seed`` and
the episode's ``config``, and episode values (the mean slot objective, bps/Hz) of
:data:`MISO_REFERENCES` (:mod:`ios_uav_env.benchmark.miso_suite`).
"""

from __future__ import annotations

import hashlib
import json
import re
import unicodedata
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

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
#: Those of a multi-node mobile suite (no tracking heuristic: HoverAt needs one node; no MPC over the
#: tour re-planned every slot, the costliest row: its k = 10 stands for it).
MULTI_MOBILE_REFERENCES = ("optimum", "bound", "mpc_dp_k1", "mpc_dp_k10", "mpc_k10", "plan_once",
                           "clairvoyant", "straight")  # fmt: skip
#: Those of a several-UAV suite: the centralised planner's plan (the normaliser), the certified
#: bound, and the planner's best tour cover before its polishing, its best dual DP flights and
#: the straight flights along the UAVs' lanes.
FLEET_REFERENCES = ("planner", "bound", "tour", "dual", "straight")
#: Those of a STAR-control suite: the per-slot optimum (the normaliser), its certified bound, the
#: continuous optimum's setting on the env's phase grid, the aligned closed form, the channel-phase
#: heuristic policy and uniform random actions.
STAR_REFERENCES = ("optimum", "bound", "quantised", "aligned", "phases", "random")
#: Those of a MISO-control suite: the per-slot AO optimum (the normaliser), the certified bound,
#: MRT and ZF with the best user's aligned phases (ZF only where N_t >= K: else 0, ``feasible``
#: false), MRT with uniformly random phases and the ``DirectMRT`` heuristic on the observation.
MISO_REFERENCES = ("optimum", "bound", "mrt_aligned", "zf_aligned", "mrt_random", "direct")
MISO_CONTROL = "miso-control"
#: The env a MISO-control suite runs in (``ios_uav_env.envs.registration.MISO_CONTROL_ID``).
MISO_ENV_ID = "ios_uav_env/MISOControl-v0"
SINGLE_NODE, MULTI_NODE, ENERGY, MOBILE = "single-node", "multi-node", "energy", "mobile"
MULTI_NODE_MOBILE, MULTI_UAV, STAR_CONTROL = "multi-node-mobile", "multi-uav", "star-control"
#: The env a STAR-control suite runs in (``ios_uav_env.envs.registration.STAR_CONTROL_ID``).
STAR_ENV_ID = "ios_uav_env/STARControl-v0"
#: The env a several-UAV suite runs in: PettingZoo's parallel env of the package (not a
#: Gymnasium id), ``ios_uav_env.parallel_env``.
FLEET_ENV_ID = "ios_uav_env.parallel_env"
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
    MULTI_UAV: FLEET_REFERENCES,
    STAR_CONTROL: STAR_REFERENCES,
    MISO_CONTROL: MISO_REFERENCES,
}
SCORED = {
    SINGLE_NODE: ("dp", "sca"),
    MULTI_NODE: ("sca", "bound"),
    ENERGY: ("dp", "bound"),
    MOBILE: ("bound", "mpc_k1"),
    MULTI_NODE_MOBILE: ("optimum", "bound"),
    MULTI_UAV: ("planner", "bound"),
    STAR_CONTROL: ("optimum", "bound"),
    MISO_CONTROL: ("optimum", "bound"),
}
#: By suite kind and normaliser (the file's ``normalizer``): the references scored, the normaliser
#: first. A kind's default is :data:`SCORED`'s; a mobile suite may be normalised by the optimum.
NORMALISERS: dict[str, dict[str, tuple[str, ...]]] = {kind: {refs[0]: refs} for kind, refs in SCORED.items()}
NORMALISERS[MOBILE]["optimum"] = ("optimum", "bound")
#: By suite kind: the reference whose planning time a policy's is compared with.
TIMED = {SINGLE_NODE: "sca", MULTI_NODE: "sca", ENERGY: "sca", MOBILE: "mpc_k1",
         MULTI_NODE_MOBILE: "mpc_dp_k1", MULTI_UAV: "planner", STAR_CONTROL: "optimum",
         MISO_CONTROL: "optimum"}  # fmt: skip
#: By suite kind: the key of a plan reference's value (a bound's is ``"upper_bound"``) and its unit.
VALUE_KEY = {SINGLE_NODE: "rate", MULTI_NODE: "rate", ENERGY: "energy_efficiency", MOBILE: "rate",
             MULTI_NODE_MOBILE: "rate", MULTI_UAV: "rate", STAR_CONTROL: "rate",
             MISO_CONTROL: "rate"}  # fmt: skip
UNIT = {
    SINGLE_NODE: "bps/Hz",
    MULTI_NODE: "bps/Hz",
    ENERGY: "bits/J",
    MOBILE: "bps/Hz",
    MULTI_NODE_MOBILE: "bps/Hz",
    MULTI_UAV: "bps/Hz",
    STAR_CONTROL: "bps/Hz",
    MISO_CONTROL: "bps/Hz",
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
    "multi-node-mobile-v1": RegisteredSuite(
        "multi-node-mobile-v1.json", "08f72c968b77a6021e8e0a2217ffefdd6520ede4e1ad437bf847f9f329c3d8d3"
    ),
    "multi-uav-v1": RegisteredSuite(
        "multi-uav-v1.json", "f91bfffa79084d1d9a6723050209a3a840c32cf908fd8c4632a4bb3473be7999"
    ),
    "star-v1": RegisteredSuite(
        "star-v1.json", "18ca1f8e909449fa879528d00d6896762ad752f2b702aa979800a6ed7deb671f"
    ),
    "miso-v1": RegisteredSuite(
        "miso-v1.json", "3b6ac90413b9424948719af34fc434ed2d75844eb7518e7d4815747365dd5ab2"
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
