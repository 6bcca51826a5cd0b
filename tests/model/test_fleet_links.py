"""The fleet's link gains and their per-slot cache: the cache returns link_gains_batch's values bit for
bit, computes only the rows it has not seen, and stays within its bounds."""

from __future__ import annotations

import numpy as np
import pytest

from ios_uav_env import ScenarioConfig
from ios_uav_env.model import fleet_links
from ios_uav_env.model.fleet_links import cached_link_gains, link_gains_batch

CONFIG = ScenarioConfig(ground_nodes=((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0)), ios_shape=(20, 12))


@pytest.fixture(autouse=True)
def empty_cache(monkeypatch):
    monkeypatch.setattr(fleet_links, "_GAINS", type(fleet_links._GAINS)())


def _positions(rows: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-300.0, 300.0, (rows, 2, 2))


def test_the_cache_returns_the_batch_values_bit_for_bit_for_new_and_seen_rows():
    q = _positions(12)
    q[5] = q[2]  # a row twice in one call
    first = cached_link_gains(CONFIG, q)
    assert np.array_equal(first, link_gains_batch(CONFIG, q))
    again = cached_link_gains(CONFIG, q[::-1])
    assert np.array_equal(again, link_gains_batch(CONFIG, q[::-1]))


def test_only_unseen_rows_are_computed(monkeypatch):
    counted = []

    def counting(config, positions):
        counted.append(len(positions))
        return link_gains_batch(config, positions)

    monkeypatch.setattr(fleet_links, "link_gains_batch", counting)
    q = _positions(10)
    cached_link_gains(CONFIG, q)
    moved = q.copy()
    moved[3:5, 1] += 5.0  # one UAV moved in two slots
    cached_link_gains(CONFIG, moved)
    cached_link_gains(CONFIG, moved)
    assert counted == [10, 2]
    other = CONFIG.replace(T=90.0)  # another scenario: its own rows
    cached_link_gains(other, q)
    assert counted == [10, 2, 10]


def test_the_cache_keeps_at_most_its_slots_and_scenarios(monkeypatch):
    monkeypatch.setattr(fleet_links, "GAIN_CACHE_SLOTS", 7)
    monkeypatch.setattr(fleet_links, "GAIN_CACHE_SCENARIOS", 2)
    for t in (60.0, 70.0, 80.0):
        config = CONFIG.replace(T=t)
        for seed in range(3):
            cached_link_gains(config, _positions(5, seed))
    assert len(fleet_links._GAINS) == 2
    assert all(len(table) == 7 for table in fleet_links._GAINS.values())
    assert [c.T for c in fleet_links._GAINS] == [70.0, 80.0]


@pytest.mark.parametrize("bad", [np.zeros((3, 2)), np.full((2, 2, 2), np.nan), np.zeros((2, 2, 3))])
def test_bad_positions_are_refused(bad):
    with pytest.raises(ValueError, match=r"positions must be a finite \(B, U, 2\) array"):
        cached_link_gains(CONFIG, bad)
