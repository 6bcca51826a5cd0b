"""The observation's layouts: the component names of every single-node layout and of the
multi-node node blocks, the single-node layouts by length, and reading an observation by feature
name (:func:`require_features`, naming the env argument that publishes a missing feature). The
space's bounds and the observation's values: :mod:`ios_uav_env.envs.observation`.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

#: Names of the observation components, in order (see ``IOSUAVEnv``'s docstring for the units).
OBS_NAMES: tuple[str, ...] = (
    "x", "y", "dx_final", "dy_final", "dx_ground", "dy_ground", "dx_ios", "dy_ios",
    "time_left", "slack", "rate",
)  # fmt: skip

#: Names of the instance features appended with ``instance_features=True``, in order.
INSTANCE_NAMES: tuple[str, ...] = ("elements", "is_ios", "is_ris", "transmit", "horizon", "seconds_left")

#: Names of the peak hint appended (after the instance features, if any) with ``peak_hint=True``:
#: the reachable rate peak P relative to the UAV, (P - q) / L, and its rate (bps/Hz).
PEAK_NAMES: tuple[str, ...] = ("dx_peak", "dy_peak", "rate_peak")

#: Names of the energy features appended (after the instance features, before the peak hint,
#: which stays last) when the scenario's objective is ``"energy_efficiency"``: the last move
#: (q[n] - q[n-1]) / D (0 at the start), the energy weight w = lambda_ref P(0) / B of the
#: reward (bps/Hz; see :func:`reference_efficiency`) and the minimum-power move V_mp dt / D.
ENERGY_NAMES: tuple[str, ...] = ("move_x", "move_y", "energy_weight", "min_power_move")

#: The names that replace ``dx_ground``, ``dy_ground`` and ``rate`` when the UAV is not told the
#: truth (``knowledge``, ``ios_uav_env.envs.knowledge``): with ``"reports"`` the node features stay
#: ``dx_ground`` / ``dy_ground`` (the node's position as the UAV is told it: a report or the
#: filter's estimate) and the rate is a measured one; with ``"rates"`` the node features are
#: always 0 (the position is hidden).
MEASURED_RATE = "measured_rate"
HIDDEN_GROUND: tuple[str, str] = ("dx_ground_hidden", "dy_ground_hidden")


def observation_names(
    instance: bool, peak: bool = False, energy: bool = False, knowledge: str = "exact"
) -> tuple[str, ...]:
    """The names of the single-node observation's components, in order (``IOSUAVEnv``'s
    ``observation_names``). ``knowledge`` other than ``"exact"``: the rate feature is
    :data:`MEASURED_RATE`, and with ``"rates"`` the node features are :data:`HIDDEN_GROUND`."""
    base = OBS_NAMES
    if knowledge != "exact":
        ground = HIDDEN_GROUND if knowledge == "rates" else OBS_NAMES[4:6]
        base = (*OBS_NAMES[:4], *ground, *OBS_NAMES[6:10], MEASURED_RATE)
    extra = (INSTANCE_NAMES if instance else ()) + (ENERGY_NAMES if energy else ())
    return base + extra + (PEAK_NAMES if peak else ())


def node_block_names(features: Sequence[str], max_nodes: int, knowledge: str = "exact") -> tuple[str, ...]:
    """The names of ``max_nodes`` node blocks of ``features`` (``MultiNodeEnv``): ``<feature>_<k>``
    for node slot k. ``knowledge`` other than ``"exact"``: ``served`` and ``rate`` are the UAV's
    measured ones (``served_measured``, ``measured_rate``), and with ``"rates"`` the position is
    hidden (``dx_node_hidden``, ``dy_node_hidden``: always 0)."""
    renamed = {}
    if knowledge != "exact":
        renamed = {"served": "served_measured", "rate": MEASURED_RATE}
        if knowledge == "rates":
            renamed.update(dx_node="dx_node_hidden", dy_node="dy_node_hidden")
    return tuple(f"{renamed.get(name, name)}_{k}" for k in range(max_nodes) for name in features)


#: Single-node layouts by length: the 8 combinations of instance features, energy features and
#: peak hint have 8 different lengths, so a policy given a bare observation (no env to ask) can
#: still tell which of them it is (``policies``); exact knowledge.
SINGLE_LAYOUTS: dict[int, tuple[str, ...]] = {
    len(names): names
    for names in (
        observation_names(i, p, e) for i in (False, True) for p in (False, True) for e in (False, True)
    )
}

_MULTI_IDS = "a multi-node id (ios_uav_env/IOSUAV-MultiNode-v0, -MultiNode-Random-v0, -MultiNode-Mobile-v0)"
_SINGLE_IDS = "a single-node id (e.g. ios_uav_env/IOSUAV-v0, -Random-v0, -Energy-v0, -Mobile-v0)"


def feature_source(name: str) -> str:
    """Which env argument (or id) publishes the observation feature ``name`` (for error messages)."""
    if name.startswith("noma_"):  # (ios_uav_env.envs.star_noma's layout)
        return "ios_uav_env/STARUAV-NOMA-v0 or ios_uav_env/STARUAV-NOMA-Random-v0"
    if name.startswith("sdma_"):  # (ios_uav_env.envs.miso_sdma's layout)
        return "ios_uav_env/MISOUAV-SDMA-v0, -Random-v0, -K3-v0 or -K4-v0 (users >= k + 1 for a user k's)"
    if name.startswith("star_"):  # (ios_uav_env.envs.star_control's layout)
        phases = name.startswith("star_phase_")
        return "ios_uav_env/STARControl-v0" + (" with channel_phases=True" if phases else "")
    node = re.fullmatch(r"(.+)_(\d+)", name)
    if node and node.group(1) in ("dx_peak", "dy_peak", "rate_peak"):
        return f"peak_hint=True on {_MULTI_IDS}"
    if node:
        feature = node.group(1)
        if feature in ("dx_node", "dy_node"):
            return f"knowledge='exact' or 'reports' on {_MULTI_IDS}"
        if feature in ("served", "rate"):
            return f"knowledge='exact' on {_MULTI_IDS}"
        return _MULTI_IDS
    if name in PEAK_NAMES:
        return f"peak_hint=True on {_SINGLE_IDS} with a static, exactly known node"
    if name in INSTANCE_NAMES:
        return f"instance_features=True on {_SINGLE_IDS}"
    if name in ENERGY_NAMES:
        return (
            "the objective 'energy_efficiency' (ios_uav_env/IOSUAV-Energy-v0, "
            "ios_uav_env/IOSUAV-Energy-Random-v0, or objective='energy_efficiency')"
        )
    if name in ("dx_ground", "dy_ground"):
        return f"knowledge='exact' or 'reports' on {_SINGLE_IDS}"
    if name == "rate":
        return f"knowledge='exact' on {_SINGLE_IDS}"
    if name == MEASURED_RATE:
        return "knowledge='reports' or 'rates'"
    if name in OBS_NAMES:
        return _SINGLE_IDS
    return "no env of ios_uav_env (unknown feature name)"


def require_features(
    needed: Sequence[str], env_names: Sequence[str] | None, who: str = "the policy", env: str = "the env"
) -> tuple[int, ...]:
    """The positions of the features ``needed`` in the layout ``env_names`` (an env's
    ``observation_names``), in the order of ``needed``.

    ``ValueError`` naming ``who``, each missing feature and the env argument (or id) that
    publishes it (:func:`feature_source`, e.g. ``peak_hint=True``), or naming ``env`` when it
    publishes no layout (``env_names`` None). For any code that reads an observation by feature
    (a heuristic policy, an expert for behaviour cloning): check once, before the episode, then
    read the positions it returns.
    """
    if env_names is None:
        raise ValueError(
            f"{who} reads the observation features {tuple(needed)}, but {env} publishes no observation_names "
            "(the envs of ios_uav_env do: env.unwrapped.observation_names)"
        )
    names = tuple(env_names)
    missing = [name for name in needed if name not in names]
    if missing:
        sources = "; ".join(f"{name}: {feature_source(name)}" for name in missing)
        raise ValueError(
            f"{who} reads the observation features {missing}, which {env} does not publish (its "
            f"{len(names)} features: {', '.join(names)}). Provided by {sources}"
        )
    return tuple(names.index(name) for name in needed)
