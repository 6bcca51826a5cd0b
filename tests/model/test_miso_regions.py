"""The multi-antenna UAV over a flight (``model.miso_regions``): never below TDMA, above it with an
array, a certified bound; the weighted WMMSE and the weighted-sum bound it rests on."""

from __future__ import annotations

import numpy as np
import pytest

from ios_uav_env import ScenarioConfig, node_rates
from ios_uav_env.model.array import ArrayConfig
from ios_uav_env.model.miso import slot_bounds, slot_channel, tdma_rates, weighted_sum_bound
from ios_uav_env.model.miso_regions import miso_maxmin
from ios_uav_env.model.miso_slot import alternate, optimise_slot
from ios_uav_env.model.schedule import maxmin_schedule

CONFIG = ScenarioConfig(T=40.0, ios_shape=(10, 6), ground_nodes=((-100.0, -20.0), (60.0, 30.0)))
SLOTS = np.linspace(CONFIG.q0, CONFIG.qF, CONFIG.N)[::10]  # 4 positions across the scene


def _tdma(array: ArrayConfig) -> float:
    return maxmin_schedule(np.array([tdma_rates(slot_channel(CONFIG, array, q)) for q in SLOTS]).T).value


def test_one_antenna_is_the_frames_tdma_schedule_at_least():
    got = miso_maxmin(CONFIG, ArrayConfig(n_t=1), SLOTS, max_iter=20, max_columns=30)
    frame = maxmin_schedule(node_rates(CONFIG, SLOTS)).value  # the single-antenna frame's schedule
    assert _tdma(ArrayConfig(n_t=1)) == pytest.approx(frame, rel=1e-9)
    assert got.value >= frame * (1 - 1e-9) and got.upper >= got.value


def test_an_array_serves_the_users_at_once_above_tdma():
    array = ArrayConfig(n_t=4)
    got = miso_maxmin(CONFIG, array, SLOTS, max_iter=20, max_columns=30)
    assert got.value > 1.02 * _tdma(array)  # simultaneous beams, time-shared with TDMA's vertices
    assert got.upper >= got.value and got.gap < 0.05


@pytest.mark.parametrize("weights", [(0.5, 0.5), (0.9, 0.1), (0.2, 0.8)])
def test_the_weighted_sum_bound_is_the_water_filling_maximum(weights):
    gains = np.array([30.0, 4.0])
    w = np.array(weights)
    p = np.linspace(0.0, 1.0, 200_001)
    brute = np.max(w[0] * np.log2(1 + p * gains[0]) + w[1] * np.log2(1 + (1 - p) * gains[1]))
    bound = weighted_sum_bound(gains, w)
    assert bound >= brute * (1 - 1e-12) and bound == pytest.approx(brute, rel=1e-8)


def test_the_weighted_ao_never_loses_and_stays_below_the_bound():
    channel = slot_channel(CONFIG, ArrayConfig(n_t=4), SLOTS[1])
    w = np.array([0.8, 0.2])
    best = optimise_slot(channel, "sum", random_starts=0, max_iter=30, weights=w)
    assert np.all(np.diff(best.history) >= -1e-9)  # WMMSE with weights: monotone
    assert float(w @ best.rates) <= weighted_sum_bound(slot_bounds(channel).gains, w) * (1 + 1e-9)
    plain = optimise_slot(channel, "sum", random_starts=0, max_iter=30)
    ones = optimise_slot(channel, "sum", random_starts=0, max_iter=30, weights=np.ones(2))
    assert np.array_equal(plain.rates, ones.rates)  # unit weights are the sum rate, bit for bit


def test_bad_weights_and_trajectories_are_refused():
    channel = slot_channel(CONFIG, ArrayConfig(n_t=2), SLOTS[0])
    psi, beams = np.zeros(channel.M), np.full((2, 2), 0.5, dtype=complex)
    with pytest.raises(ValueError, match="weights must be K = 2"):
        alternate(channel, "sum", psi, beams, weights=np.array([1.0, -1.0]))
    with pytest.raises(ValueError, match="need objective 'sum'"):
        alternate(channel, "maxmin", psi, beams, weights=np.ones(2))
    with pytest.raises(ValueError, match="trajectory must be"):
        miso_maxmin(CONFIG, ArrayConfig(n_t=2), SLOTS[:, :1])
