"""The held-out draws of the shipped suites: scenarios no training seed reproduces.

- single-node (``single-node-v1``): :data:`HELDOUT_SEED` draws :data:`DEFAULT_SIZE` scenarios
  with ``sample_scenario(np.random.default_rng(seed), DEFAULT_RANGES)`` (training seeds are small
  integers);
- multi-node (``multi-node-v1``): ``n`` draws in turn of ``ios_uav_env.envs.multi.sample_multinode``
  (the distribution of ``ios_uav_env/IOSUAV-MultiNode-Random-v0``: 2 to 4 nodes) from
  ``np.random.default_rng(np.random.SeedSequence(entropy=20261130, spawn_key=(17,)))``. A spawned
  key gives a stream independent of every ``default_rng(seed)`` / ``env.reset(seed=seed)``
  stream (those have an empty spawn key).
"""

from __future__ import annotations

import numpy as np

from ios_uav_env import DEFAULT_RANGES, ScenarioConfig, ScenarioRanges, sample_scenario

#: The seed of the single-node held-out suite: never a training seed (those are small integers).
HELDOUT_SEED = 20261122
#: Scenarios in the single-node suite.
DEFAULT_SIZE = 60
#: The held-out generator's seed sequence: entropy and spawn key (documented in the suite).
ENTROPY = 2026_1130
SPAWN_KEY = (17,)
MULTI_ENV_ID = "ios_uav_env/IOSUAV-MultiNode-Random-v0"


def heldout_rng() -> np.random.Generator:
    """The multi-node suite's held-out generator (a fresh one at every call)."""
    return np.random.default_rng(np.random.SeedSequence(entropy=ENTROPY, spawn_key=SPAWN_KEY))


def suite_configs(
    n: int = DEFAULT_SIZE, seed: int = HELDOUT_SEED, ranges: ScenarioRanges = DEFAULT_RANGES
) -> list[ScenarioConfig]:
    """The single-node suite's scenarios: ``n`` draws of ``sample_scenario`` from ``default_rng(seed)``."""
    rng = np.random.default_rng(seed)
    return [sample_scenario(rng, ranges) for _ in range(n)]


def multinode_configs(n: int = 48) -> list[ScenarioConfig]:
    """The first ``n`` multi-node held-out scenarios: ``sample_multinode`` drawn in turn from
    :func:`heldout_rng`."""
    from ios_uav_env.envs.multi import sample_multinode

    rng = heldout_rng()
    return [sample_multinode(rng) for _ in range(int(n))]
