"""Registration of the namespaced, versioned env ids (idempotent; called on import)."""

from __future__ import annotations

import inspect
from typing import Any

import gymnasium as gym

#: The STAR id: the paper's scenario with a STAR surface (``star_protocol``, ``star_phases`` and
#: ``star_access`` at their defaults: energy splitting, independent phases, TDMA).
STAR_ID = "ios_uav_env/STARUAV-v0"

#: id -> keyword arguments of the fixed single-node ids (``IOSUAVEnv``'s: the view ``"v0"``).
ENV_IDS: dict[str, dict[str, Any]] = {
    "ios_uav_env/IOSUAV-v0": {"surface": "ios"},  # the paper's scenario (IA)
    "ios_uav_env/RISUAV-v0": {"surface": "ris"},  # the IOS replaced by a reflect-only RIS (RA)
    "ios_uav_env/UAV-v0": {"surface": "none"},  # no surface: direct link only (CUC)
    STAR_ID: {"surface": "star"},  # the IOS replaced by a STAR surface, one node per slot share (TDMA)
}

#: The randomised id: every reset draws a scenario from ``scenarios.DEFAULT_RANGES``.
RANDOM_ENV_ID = "ios_uav_env/IOSUAV-Random-v0"
#: The randomised STAR id: scenarios drawn as :data:`RANDOM_ENV_ID`'s, every one with the STAR
#: surface (``RandomIOSUAVEnv``'s ``surface`` keyword narrows the ranges' surfaces to it).
STAR_RANDOM_ID = "ios_uav_env/STARUAV-Random-v0"
#: id -> keyword arguments of the randomised single-node ids of the rate objective (``RandomIOSUAVEnv``).
RANDOM_IDS: dict[str, dict[str, Any]] = {RANDOM_ENV_ID: {}, STAR_RANDOM_ID: {"surface": "star"}}

#: Several ground nodes (``multinode_env.MultiNodeEnv``): id -> its keyword arguments.
MULTINODE_IDS: dict[str, dict[str, Any]] = {
    "ios_uav_env/IOSUAV-MultiNode-v0": {},  # the 3 nodes of multinode_env.DEFAULT_NODES
    "ios_uav_env/IOSUAV-MultiNode-Random-v0": {"random_nodes": (2, 4)},  # 2 to 4 nodes per reset
}

#: The energy-efficiency ids (objective "energy_efficiency": the reward, observation and score of
#: ``IOSUAVEnv``'s "Energy"): the paper's scenario, and scenarios drawn as the randomised id's.
ENERGY_ID = "ios_uav_env/IOSUAV-Energy-v0"
ENERGY_RANDOM_ID = "ios_uav_env/IOSUAV-Energy-Random-v0"
#: id -> keyword arguments of the energy ids (``ENERGY_ID``: ``IOSUAVEnv``; ``ENERGY_RANDOM_ID``:
#: ``RandomIOSUAVEnv``).
ENERGY_IDS: dict[str, dict[str, Any]] = {
    ENERGY_ID: {"surface": "ios", "objective": "energy_efficiency"},
    ENERGY_RANDOM_ID: {"objective": "energy_efficiency"},
}

#: The moving-node id: scenarios drawn as the randomised id's, the node walking a Gauss-Markov
#: path (pedestrian defaults of ``ios_uav_env.model.mobility.GaussMarkov``) and known to the UAV
#: through noisy position reports and measured rates (``ios_uav_env.envs.knowledge``).
MOBILE_ID = "ios_uav_env/IOSUAV-Mobile-v0"
#: id -> keyword arguments of the moving-node ids (``RandomIOSUAVEnv``).
MOBILE_IDS: dict[str, dict[str, Any]] = {
    MOBILE_ID: {"motion": {"kind": "gauss_markov"}, "knowledge": "reports"},
}
#: Several moving, roughly known nodes: 2 to 4 nodes per reset as the randomised multi-node id's,
#: each walking and reported as the moving-node id's (``MultiNodeEnv``).
MULTINODE_MOBILE_ID = "ios_uav_env/IOSUAV-MultiNode-Mobile-v0"
MULTINODE_MOBILE_IDS: dict[str, dict[str, Any]] = {
    MULTINODE_MOBILE_ID: {"random_nodes": (2, 4), "motion": {"kind": "gauss_markov"}, "knowledge": "reports"},
}

#: A STAR surface serving a user on each side at once (NOMA; ``ios_uav_env.envs.star_noma``): the
#: agent flies and weighs the two users, the env sets the slot's weighted-sum optimum; scored by
#: ``score_plan`` as ``dp-star``'s plans. The Random id draws the line's x at every reset.
STAR_NOMA_ID = "ios_uav_env/STARUAV-NOMA-v0"
STAR_NOMA_RANDOM_ID = "ios_uav_env/STARUAV-NOMA-Random-v0"
STAR_NOMA_IDS: dict[str, dict[str, Any]] = {STAR_NOMA_ID: {}, STAR_NOMA_RANDOM_ID: {"random_line": True}}

#: The multi-antenna UAV that flies (``UAVEnv``, the v0 view): the paper's scenario with an
#: N_t-antenna UAV (the scenario field ``antennas``, 4 here), the agent flying as in ``IOSUAV-v0``
#: and the env setting the beam and the surface's phases at their closed-form joint optimum for the
#: node (aligned phases and MRT, ``ios_uav_env.model.miso``); ``antennas=1`` is ``IOSUAV-v0``.
MISO_ID = "ios_uav_env/MISOUAV-v0"
MISO_IDS: dict[str, dict[str, Any]] = {MISO_ID: {"antennas": 4}}

#: The multi-antenna UAV serving two users at once (SDMA; ``ios_uav_env.envs.miso_sdma``): the agent
#: flies and weighs the users, the env sets the beams and the surface's phases by the per-slot
#: weighted-sum AO; scored by ``score_plan`` as ``dp-miso-sdma``'s plans. The Random id draws the
#: line's x at every reset. The K3 and K4 ids serve three and four users (the keyword ``users``,
#: which the Random id draws its lines with too: ``gym.make(MISO_SDMA_RANDOM_ID, users=3)``).
MISO_SDMA_ID = "ios_uav_env/MISOUAV-SDMA-v0"
MISO_SDMA_RANDOM_ID = "ios_uav_env/MISOUAV-SDMA-Random-v0"
MISO_SDMA_K3_ID = "ios_uav_env/MISOUAV-SDMA-K3-v0"
MISO_SDMA_K4_ID = "ios_uav_env/MISOUAV-SDMA-K4-v0"
MISO_SDMA_IDS: dict[str, dict[str, Any]] = {
    MISO_SDMA_ID: {}, MISO_SDMA_RANDOM_ID: {"random_line": True},
    MISO_SDMA_K3_ID: {"users": 3}, MISO_SDMA_K4_ID: {"users": 4},
}  # fmt: skip

#: The surface as the agent's control (``ios_uav_env.envs.star_control``): the UAV flies a given
#: line past a small STAR surface and the agent sets the surface's coefficients in every slot; its
#: batched form is ``ios_uav_env.envs.star_control_vector.STARControlVectorEnv``.
STAR_CONTROL_ID = "ios_uav_env/STARControl-v0"
STAR_CONTROL_IDS: dict[str, dict[str, Any]] = {STAR_CONTROL_ID: {}}

#: The multi-antenna UAV's beams and the surface's phases as the agent's control
#: (``ios_uav_env.envs.miso_control``): the UAV flies a given line past a small IOS and the agent
#: sets the K beams and the M phases in every slot. Batched form: ``miso_control_vector``.
MISO_CONTROL_ID = "ios_uav_env/MISOControl-v0"
MISO_CONTROL_IDS: dict[str, dict[str, Any]] = {MISO_CONTROL_ID: {}}


def _vector(entry_point: str) -> dict[str, str]:
    """The ``vector_entry_point`` argument where Gymnasium has it (1.0 and later)."""
    has_vector = "vector_entry_point" in inspect.signature(gym.register).parameters
    return {"vector_entry_point": entry_point} if has_vector else {}


#: The presets of the views (``ios_uav_env.envs.core.stepper.VIEWS``, each read with its action
#: type): each id is ``UAVEnv`` (and ``UAVVectorEnv``) with its view's preset and its own keywords.
#: The v0 view is ``UAVEnv``'s default, so the fixed single-node ids register their world only.
V0: dict[str, Any] = {}
V0_DRAWN: dict[str, Any] = {"draws": True}
NODE_BLOCKS: dict[str, Any] = {"view": "node_blocks"}
STAR_NOMA: dict[str, Any] = {"view": "star_noma"}
MISO_SDMA: dict[str, Any] = {"view": "miso_sdma"}

#: The one env class and the one vector class of every single- and multi-node id.
ENTRY_POINT = "ios_uav_env.envs.core.env:UAVEnv"
VECTOR_ENTRY_POINT = "ios_uav_env.envs.core.vector:UAVVectorEnv"


def presets() -> dict[str, dict[str, Any]]:
    """id -> the keywords ``UAVEnv`` is registered with for each single- and multi-node id: its
    view's preset (:data:`V0`, :data:`V0_DRAWN`, :data:`NODE_BLOCKS`, :data:`STAR_NOMA`,
    :data:`MISO_SDMA`), then its
    own (the world's scenario fields and options, ``random_nodes``, ``random_line``, ``antennas``,
    ``users``)."""
    families = (
        (ENV_IDS, V0),
        ({ENERGY_ID: ENERGY_IDS[ENERGY_ID]}, V0),
        (RANDOM_IDS, V0_DRAWN),
        ({ENERGY_RANDOM_ID: ENERGY_IDS[ENERGY_RANDOM_ID]}, V0_DRAWN),
        (MOBILE_IDS, V0_DRAWN),
        ({**MULTINODE_IDS, **MULTINODE_MOBILE_IDS}, NODE_BLOCKS),
        (STAR_NOMA_IDS, STAR_NOMA),
        (MISO_IDS, V0),
        (MISO_SDMA_IDS, MISO_SDMA),
    )
    return {env_id: {**view, **kwargs} for ids, view in families for env_id, kwargs in ids.items()}


def register_envs() -> None:
    """Register every id of :data:`ENV_IDS`, :data:`RANDOM_IDS`, :data:`MULTINODE_IDS`,
    :data:`ENERGY_IDS`, :data:`MOBILE_IDS`, :data:`MULTINODE_MOBILE_IDS`, :data:`STAR_NOMA_IDS`,
    :data:`MISO_IDS`, :data:`MISO_SDMA_IDS`,
    :data:`STAR_CONTROL_IDS` and :data:`MISO_CONTROL_IDS` not registered yet: each single- and
    multi-node id as ``UAVEnv`` with its keywords (:func:`presets`) and ``UAVVectorEnv`` as its
    batched env.

    No ``max_episode_steps``: the env ends every episode itself at slot N of its scenario
    (``terminated=True``), whatever T is, so no ``TimeLimit`` can cut a mission short. Each id
    also names its natively batched env (``gym.make_vec(id, num_envs=B,
    vectorization_mode="vector_entry_point")``, Gymnasium >= 1.0).
    """
    for env_id, kwargs in presets().items():
        if env_id not in gym.registry:
            gym.register(
                id=env_id, entry_point=ENTRY_POINT, kwargs=dict(kwargs), **_vector(VECTOR_ENTRY_POINT)
            )
    for env_id, kwargs in STAR_CONTROL_IDS.items():
        if env_id not in gym.registry:
            entry_point = "ios_uav_env.envs.star_control:STARControlEnv"
            vector = _vector("ios_uav_env.envs.star_control_vector:STARControlVectorEnv")
            gym.register(id=env_id, entry_point=entry_point, kwargs=dict(kwargs), **vector)
    for env_id, kwargs in MISO_CONTROL_IDS.items():
        if env_id not in gym.registry:
            gym.register(
                id=env_id,
                entry_point="ios_uav_env.envs.miso_control:MISOControlEnv",
                kwargs=dict(kwargs),
                **_vector("ios_uav_env.envs.miso_control_vector:MISOControlVectorEnv"),
            )
