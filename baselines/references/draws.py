"""The held-out draws of the shipped suites: scenarios no training seed reproduces.

- single-node (``single-node-v1``): :data:`HELDOUT_SEED` draws :data:`DEFAULT_SIZE` scenarios
  with ``sample_scenario(np.random.default_rng(seed), DEFAULT_RANGES)`` (training seeds are small
  integers);
- multi-node (``multi-node-v1``): ``n`` draws in turn of ``ios_uav_env.sample_multinode``
  (the distribution of ``ios_uav_env/IOSUAV-MultiNode-Random-v0``: 2 to 4 nodes) from
  ``np.random.default_rng(np.random.SeedSequence(entropy=20261130, spawn_key=(17,)))``. A spawned
  key gives a stream independent of every ``default_rng(seed)`` / ``env.reset(seed=seed)``
  stream (those have an empty spawn key);
- energy (``energy-v1``): ``n`` draws in turn of ``sample_scenario(rng, ENERGY_RANGES)``, the
  distribution of ``ios_uav_env/IOSUAV-Energy-Random-v0`` (the random id's ranges, both
  surfaces, with the objective ``"energy_efficiency"``), from ``default_rng(SeedSequence(
  entropy=seed, spawn_key=ENERGY_SPAWN_KEY))``: another spawned key, so a stream that neither
  a reset seed nor the multi-node suite's draws reproduce.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ios_uav_env import DEFAULT_RANGES, ScenarioConfig, ScenarioRanges, sample_multinode, sample_scenario

#: The seed of the single-node held-out suite: never a training seed (those are small integers).
HELDOUT_SEED = 20261122
#: Scenarios in the single-node suite.
DEFAULT_SIZE = 60
#: The held-out generator's seed sequence: entropy and spawn key (documented in the suite).
ENTROPY = 2026_1130
SPAWN_KEY = (17,)
MULTI_ENV_ID = "ios_uav_env/IOSUAV-MultiNode-Random-v0"
#: The energy suite's spawn key (its entropy is :data:`ENTROPY` unless given) and size.
ENERGY_SPAWN_KEY = (5,)
ENERGY_SIZE = 40
#: The scenarios of ``ios_uav_env/IOSUAV-Energy-Random-v0``: the random id's ranges (both
#: surfaces) with the objective "energy_efficiency" on the base scenario, as that id's env sets it.
ENERGY_RANGES = dataclasses.replace(
    DEFAULT_RANGES, base=DEFAULT_RANGES.base.replace(objective="energy_efficiency")
)


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
    rng = heldout_rng()
    return [sample_multinode(rng) for _ in range(int(n))]


def energy_rng(seed: int = ENTROPY) -> np.random.Generator:
    """The energy suite's held-out generator: ``default_rng(SeedSequence(entropy=seed,
    spawn_key=ENERGY_SPAWN_KEY))`` (a fresh one at every call)."""
    return np.random.default_rng(np.random.SeedSequence(entropy=int(seed), spawn_key=ENERGY_SPAWN_KEY))


def energy_configs(
    n: int = ENERGY_SIZE, seed: int = ENTROPY, ranges: ScenarioRanges = ENERGY_RANGES
) -> list[ScenarioConfig]:
    """The first ``n`` energy held-out scenarios: ``sample_scenario(rng, ranges)`` drawn in turn
    from :func:`energy_rng` of ``seed``. ``ranges`` must keep the objective "energy_efficiency"
    (``ValueError`` otherwise); a narrower family (e.g. short horizons) is for quick checks."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be an integer >= 1 (scenarios), got {n!r}")
    if ranges.base.objective != "energy_efficiency":
        raise ValueError(
            "ranges.base.objective must be 'energy_efficiency' for energy scenarios, "
            f"got {ranges.base.objective!r}"
        )
    rng = energy_rng(seed)
    return [sample_scenario(rng, ranges) for _ in range(int(n))]
