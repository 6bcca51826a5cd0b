"""ios_uav_env: Gymnasium environment and system model for IOS-aided UAV communications.

The model follows Liu et al., "Full-Dimensional Rate Enhancement for UAV-Enabled
Communications via Intelligent Omni-Surface", IEEE WCL 11(9), 2022 (the model:
``docs/model.md``). Importing the package registers the env ids (idempotently):

>>> import gymnasium as gym
>>> import ios_uav_env
>>> env = gym.make("ios_uav_env/IOSUAV-v0")
>>> generalist_env = gym.make("ios_uav_env/IOSUAV-Random-v0")  # a new scenario at every reset

The system model (``ios_uav_env.model``: the scenario, the channel, the scorer, the K-node schedule)
needs only numpy; the envs (``ios_uav_env.envs``) need Gymnasium; the benchmark
(``ios_uav_env.benchmark``) scores any policy or plan on frozen suites; rendering imports
matplotlib lazily.
"""

from typing import Any

from ios_uav_env.model.channel import (
    RateKernel,
    faded_rates,
    path_kernels,
    rate_kernel,
    rates_of_rows,
    slot_rates,
)
from ios_uav_env.model.config import (
    ENERGY_RTOL,
    FEASIBILITY_TOL,
    OBJECTIVES,
    SURFACES,
    ScenarioConfig,
    moves_needed,
    scene_box,
)
from ios_uav_env.model.kalman import NodeFilter
from ios_uav_env.model.motion import GaussMarkov, node_paths
from ios_uav_env.model.peak import Peak, rate_peak
from ios_uav_env.model.propulsion import PropulsionModel, max_range_speed, min_power_speed, propulsion_power
from ios_uav_env.model.reports import measured_rates, position_reports
from ios_uav_env.model.scenarios import (
    DEFAULT_RANGES,
    MULTINODE_RANGES,
    ScenarioRanges,
    sample_multinode,
    sample_scenario,
)
from ios_uav_env.model.schedule import (
    Schedule,
    best_schedule,
    maxmin_rate,
    maxmin_schedule,
    node_rates,
    schedule,
    scheduled_rates,
)
from ios_uav_env.model.score import PlanScore, energy_efficiency, score_plan
from ios_uav_env.model.trajectory import TrajectoryReport, average_rate, check_trajectory, energy

__version__ = "0.1.0"

__all__ = [
    "DEFAULT_RANGES",
    "ENERGY_RTOL",
    "FEASIBILITY_TOL",
    "GaussMarkov",
    "MULTINODE_RANGES",
    "NodeFilter",
    "OBJECTIVES",
    "Peak",
    "PlanScore",
    "PropulsionModel",
    "RateKernel",
    "SURFACES",
    "ScenarioConfig",
    "ScenarioRanges",
    "Schedule",
    "TrajectoryReport",
    "average_rate",
    "best_schedule",
    "check_trajectory",
    "energy",
    "energy_efficiency",
    "faded_rates",
    "max_range_speed",
    "maxmin_rate",
    "maxmin_schedule",
    "measured_rates",
    "min_power_speed",
    "moves_needed",
    "node_paths",
    "node_rates",
    "position_reports",
    "propulsion_power",
    "path_kernels",
    "rate_kernel",
    "rates_of_rows",
    "rate_peak",
    "sample_multinode",
    "sample_scenario",
    "scene_box",
    "schedule",
    "scheduled_rates",
    "score_plan",
    "slot_rates",
]

try:  # the env needs Gymnasium; the model does not
    import gymnasium as _gymnasium  # noqa: F401
except ImportError:  # pragma: no cover - exercised in a subprocess test
    _HAS_GYMNASIUM = False
else:
    _HAS_GYMNASIUM = True

if _HAS_GYMNASIUM:
    from ios_uav_env.envs.core.env import UAVEnv
    from ios_uav_env.envs.core.vector import UAVVectorEnv
    from ios_uav_env.envs.multi import MultiNodeEnv
    from ios_uav_env.envs.options import EnvOptions
    from ios_uav_env.envs.random_env import RandomIOSUAVEnv
    from ios_uav_env.envs.registration import (
        ENERGY_ID,
        ENERGY_IDS,
        ENERGY_RANDOM_ID,
        ENV_IDS,
        MISO_CONTROL_ID,
        MISO_CONTROL_IDS,
        MISO_ID,
        MISO_IDS,
        MISO_SDMA_ID,
        MISO_SDMA_IDS,
        MISO_SDMA_RANDOM_ID,
        MOBILE_ID,
        MOBILE_IDS,
        MULTINODE_IDS,
        MULTINODE_MOBILE_ID,
        MULTINODE_MOBILE_IDS,
        RANDOM_ENV_ID,
        RANDOM_IDS,
        STAR_CONTROL_ID,
        STAR_CONTROL_IDS,
        STAR_ID,
        STAR_NOMA_ID,
        STAR_NOMA_IDS,
        STAR_NOMA_RANDOM_ID,
        STAR_RANDOM_ID,
        register_envs,
    )
    from ios_uav_env.envs.single import INFO_KEYS, IOSUAVEnv

    register_envs()

    def parallel_env(config: Any = None, **kwargs: Any) -> Any:
        """Several UAVs on PettingZoo's Parallel API (``ios_uav_env.envs.fleet.FleetParallelEnv``;
        needs the ``marl`` extra: pettingzoo)."""
        from ios_uav_env.envs.fleet import FleetParallelEnv

        return FleetParallelEnv(config, **kwargs)

    __all__ += [
        "ENERGY_ID",
        "ENERGY_IDS",
        "ENERGY_RANDOM_ID",
        "ENV_IDS",
        "INFO_KEYS",
        "EnvOptions",
        "IOSUAVEnv",
        "MISO_CONTROL_ID",
        "MISO_CONTROL_IDS",
        "MISO_ID",
        "MISO_IDS",
        "MISO_SDMA_ID",
        "MISO_SDMA_IDS",
        "MISO_SDMA_RANDOM_ID",
        "MOBILE_ID",
        "MOBILE_IDS",
        "MULTINODE_IDS",
        "MULTINODE_MOBILE_ID",
        "MULTINODE_MOBILE_IDS",
        "MultiNodeEnv",
        "RANDOM_ENV_ID",
        "RANDOM_IDS",
        "RandomIOSUAVEnv",
        "STAR_CONTROL_ID",
        "STAR_CONTROL_IDS",
        "STAR_ID",
        "STAR_NOMA_ID",
        "STAR_NOMA_IDS",
        "STAR_NOMA_RANDOM_ID",
        "STAR_RANDOM_ID",
        "UAVEnv",
        "UAVVectorEnv",
        "parallel_env",
        "register_envs",
    ]
