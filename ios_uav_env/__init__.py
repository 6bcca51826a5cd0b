"""ios_uav_env: Gymnasium environment and system model for IOS-aided UAV communications.

The model follows Liu et al., "Full-Dimensional Rate Enhancement for UAV-Enabled
Communications via Intelligent Omni-Surface", IEEE WCL 11(9), 2022 (the model:
``docs/model.md``). Importing the package registers the env ids (idempotently):

>>> import gymnasium as gym
>>> import ios_uav_env
>>> env = gym.make("ios_uav_env/IOSUAV-v0")
>>> generalist_env = gym.make("ios_uav_env/IOSUAV-Random-v0")  # a new scenario at every reset

The system model (``config``, ``surface``, ``channel``, ``trajectory``, ``scenarios``) needs
only numpy; the env needs Gymnasium; rendering imports matplotlib lazily.
"""

from ios_uav_env.channel import (
    RateKernel,
    channel,
    direct_amplitude,
    element_amplitudes,
    faded_rates,
    los_channel,
    phase_shifts,
    radiation_patterns,
    rate_kernel,
    side_factor,
    slot_rates,
    surface_amplitude,
    surface_terms,
    zeta,
)
from ios_uav_env.config import FEASIBILITY_TOL, SURFACES, ScenarioConfig, moves_needed, scene_box
from ios_uav_env.multinode import (
    Schedule,
    best_schedule,
    maxmin_rate,
    maxmin_schedule,
    node_rates,
    schedule,
    scheduled_rates,
)
from ios_uav_env.peak import Peak, rate_peak
from ios_uav_env.scenarios import DEFAULT_RANGES, ScenarioRanges, sample_scenario
from ios_uav_env.surface import element_positions, surface_nodes
from ios_uav_env.trajectory import TrajectoryReport, average_rate, check_trajectory

__version__ = "0.1.0"

__all__ = [
    "DEFAULT_RANGES",
    "FEASIBILITY_TOL",
    "Peak",
    "RateKernel",
    "SURFACES",
    "ScenarioConfig",
    "ScenarioRanges",
    "Schedule",
    "TrajectoryReport",
    "average_rate",
    "best_schedule",
    "channel",
    "check_trajectory",
    "direct_amplitude",
    "element_amplitudes",
    "element_positions",
    "faded_rates",
    "los_channel",
    "maxmin_rate",
    "maxmin_schedule",
    "moves_needed",
    "node_rates",
    "phase_shifts",
    "radiation_patterns",
    "rate_kernel",
    "rate_peak",
    "sample_scenario",
    "scene_box",
    "schedule",
    "scheduled_rates",
    "side_factor",
    "slot_rates",
    "surface_amplitude",
    "surface_nodes",
    "surface_terms",
    "zeta",
]

try:  # the env needs Gymnasium; the model does not
    import gymnasium as _gymnasium  # noqa: F401
except ImportError:  # pragma: no cover - exercised in a subprocess test
    _HAS_GYMNASIUM = False
else:
    _HAS_GYMNASIUM = True

if _HAS_GYMNASIUM:
    from ios_uav_env.env import INFO_KEYS, IOSUAVEnv
    from ios_uav_env.multinode_env import MultiNodeEnv
    from ios_uav_env.options import EnvOptions
    from ios_uav_env.random_env import RandomIOSUAVEnv
    from ios_uav_env.registration import ENV_IDS, MULTINODE_IDS, RANDOM_ENV_ID, register_envs

    register_envs()
    __all__ += [
        "ENV_IDS",
        "INFO_KEYS",
        "EnvOptions",
        "IOSUAVEnv",
        "MULTINODE_IDS",
        "MultiNodeEnv",
        "RANDOM_ENV_ID",
        "RandomIOSUAVEnv",
        "register_envs",
    ]
