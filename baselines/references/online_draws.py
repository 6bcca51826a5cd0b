"""The online suites' draws and rows (``baselines.references.online``): ``multi-node-mobile-v1``'s
scenarios and episode seeds, and the online rows each scenario's record holds.

:func:`multi_mobile_tasks` draws the multi-node mobile tasks (``online``'s module docstring,
"Draws": :data:`MULTI_MOBILE_RANGES` from a spawned key of their own,
:data:`MULTI_MOBILE_SPAWN_KEY`); :func:`online_rows` names the online rows of a scenario of K
nodes: MPC's (:data:`ONLINE`, :data:`MULTI_ONLINE` for K > 1) and the env's (:data:`TRACKS`,
:data:`MULTI_ENV_ROWS`). Every name here is importable from ``baselines.references.online`` too.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from baselines.references.mobile import draw_tasks
from ios_uav_env import MULTINODE_RANGES, ScenarioRanges, sample_multinode
from ios_uav_env.model.mobility import GaussMarkov

#: The multi-node mobile suite's spawn key (its entropy is ``draws.ENTROPY`` unless given) and size.
MULTI_MOBILE_SPAWN_KEY = (23,)
MULTI_MOBILE_SIZE = 24
#: The family of ``ios_uav_env/IOSUAV-MultiNode-Mobile-v0``: the multi-node ranges, nodes walking.
MULTI_MOBILE_RANGES = dataclasses.replace(
    MULTINODE_RANGES, base=MULTINODE_RANGES.base.replace(motion=GaussMarkov())
)
#: The online rows by name: MPC's k (None: plan once) and inner planner.
ONLINE = {"mpc_dp_k1": (1, "dp"), "mpc_dp_k10": (10, "dp"), "mpc_k1": (1, "tour"), "mpc_k10": (10, "tour"),
          "plan_once": (None, "tour")}  # fmt: skip
#: Those of K > 1: MPC over the tour re-planned every slot (``mpc_k1``) is left out, the costliest
#: row (a tour on the predicted paths in every one of up to 197 slots: 916 CPU s on the 24
#: scenarios of ``multi-node-mobile-v1``, against 1470 for all the other rows); the tour's MPC keeps
#: ``mpc_k10`` and plan once.
MULTI_ONLINE = tuple(name for name in ONLINE if name != "mpc_k1")
#: The env rows by name: one node's (the knowledge HoverAt("ground") flies on), K > 1's.
TRACKS = {"track_exact": "exact", "track_reports": "reports"}
MULTI_ENV_ROWS = ("straight",)


def online_rows(k: int) -> tuple[str, ...]:
    """The online rows of a scenario with ``k`` nodes (the MPC rows, then the env rows)."""
    return (*ONLINE, *TRACKS) if k == 1 else (*MULTI_ONLINE, *MULTI_ENV_ROWS)


def multi_mobile_tasks(
    n: int, seed: int, ranges: ScenarioRanges = MULTI_MOBILE_RANGES
) -> list[dict[str, Any]]:
    """The first ``n`` multi-node mobile tasks ``{"index", "config", "seed"}`` (module docstring,
    "Draws"); ``ranges.base`` must have a motion model (``ValueError`` otherwise)."""
    return draw_tasks(n, seed, ranges, MULTI_MOBILE_SPAWN_KEY, sample_multinode)
