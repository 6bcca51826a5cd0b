"""A multi-antenna UAV serving several users at once over a flight (``model.miso_sdma``): the lattice
settings, the exact max-min over them, the certified bound, and ``score_plan`` on SDMA scenarios."""

from __future__ import annotations

import numpy as np
import pytest

from ios_uav_env import ScenarioConfig, score_plan
from ios_uav_env.model.lp import solve_lp
from ios_uav_env.model.miso import tdma_rates, weighted_sum_bound
from ios_uav_env.model.miso_runs import _power_level
from ios_uav_env.model.miso_sdma import (
    MAX_ELEMENTS,
    lattice_index,
    sdma_maxmin,
    slot_channel_at,
    slot_points,
    slot_setting,
    weight_lattice,
)
from ios_uav_env.model.schedule import maxmin_schedule

#: A short flight past an 8 x 8 IOS: user 0 behind it, user 1 on the UAV's side far along the
#: array's axis x, so that the four antennas see them at different angles (5 slots of 20 m).
CONFIG = ScenarioConfig(
    ios_center=(0.0, 0.0, 5.0), ios_shape=(8, 8), noise_dbm=-110.0, T=5.0, antennas=4,
    ground_nodes=((10.0, -10.0), (-120.0, -10.0)), q0=(-250.0, -40.0), qF=(-250.0, 40.0),
)  # fmt: skip
FLIGHT = np.linspace(CONFIG.q0, CONFIG.qF, CONFIG.N)


@pytest.fixture(scope="module")
def slots() -> tuple[np.ndarray, np.ndarray]:
    return slot_points(CONFIG, FLIGHT)


def test_the_weight_lattice_covers_the_simplex():
    for k, size in ((2, 9), (3, 15), (4, 10)):
        lattice = weight_lattice(k)
        assert lattice.shape == (size, k) and np.allclose(lattice.sum(axis=1), 1.0) and np.all(lattice >= 0)
    assert weight_lattice(2)[0].tolist() == [1.0, 0.0] and weight_lattice(2)[-1].tolist() == [0.0, 1.0]
    assert lattice_index(np.array([0.6, 0.4]), weight_lattice(2)) == 3  # w_0 = 5/8 is nearest
    with pytest.raises(ValueError, match="k must be an integer >= 2"):
        weight_lattice(1)


def test_every_setting_is_a_users_alone_at_least_and_below_the_bound(slots):
    points, gains = slots
    lattice = weight_lattice(2)
    for n, p in enumerate(FLIGHT):
        solo = tdma_rates(slot_channel_at(CONFIG, p))
        assert np.array_equal(points[n, len(lattice) :], np.diag(solo))
        for j, w in enumerate(lattice):
            value = float(w @ points[n, j])
            assert value >= float(np.max(w * solo)) and value <= weighted_sum_bound(gains[n], w) * (1 + 1e-12)
    # the env's setting at a lattice weight is the scorer's own, bit for bit
    channel = slot_channel_at(CONFIG, FLIGHT[2])
    assert np.array_equal(slot_setting(channel, lattice[3]), points[2, 3])


def test_the_score_is_the_exact_max_min_over_the_settings(slots):
    points, _ = slots
    got = sdma_maxmin(CONFIG, FLIGHT)
    # the LP over every slot's settings: max t s.t. (1/N) sum_n sum_j lam_nj P_nj >= t, sum_j lam_nj = 1
    n, j, k = points.shape
    c = np.zeros(n * j + 1)
    c[-1] = -1.0
    a_ub = np.hstack([-points.transpose(2, 0, 1).reshape(k, n * j) / n, np.ones((k, 1))])
    a_eq = np.hstack([np.kron(np.eye(n), np.ones((1, j))), np.zeros((n, 1))])
    sol = solve_lp(c, a_ub, np.zeros(k), np.full(n * j + 1, np.inf), a_eq=a_eq, b_eq=np.ones(n))
    # 1e-7: HiGHS' default primal feasibility tolerance bounds the LP's own error
    assert sol.optimal and got.value == pytest.approx(-sol.value, rel=1e-7)
    assert got.upper >= got.value and np.all(got.schedule.rates >= got.value * (1 - 1e-12))


def test_serving_both_at_once_beats_tdma_and_the_bound_holds(slots):
    points, _ = slots
    got = sdma_maxmin(CONFIG, FLIGHT)
    tdma = maxmin_schedule(points[:, -2:].sum(axis=1).T).value  # each user alone, time-shared
    assert got.value > 1.05 * tdma
    assert got.upper >= got.value and 0 < got.gap < 1


@pytest.mark.slow_without_numba
def test_score_plan_scores_an_sdma_flight_deterministically():
    got = score_plan(CONFIG, FLIGHT)
    assert got.rate == sdma_maxmin(CONFIG, FLIGHT).value == score_plan(CONFIG, FLIGHT).rate
    assert got.best_schedule_rate == got.rate and not got.own_shares and got.feasible


def test_score_plan_refuses_what_sdma_does_not_score():
    with pytest.raises(ValueError, match="shares are TDMA shares"):
        score_plan(CONFIG, FLIGHT, np.full((2, CONFIG.N), 0.5))
    with pytest.raises(ValueError, match="paths"):
        score_plan(CONFIG, FLIGHT, paths=np.zeros((CONFIG.N, 2, 2)))
    with pytest.raises(ValueError, match=rf"ios_shape must have M = M_y M_z in \[1, {MAX_ELEMENTS}\]"):
        score_plan(CONFIG.replace(ios_shape=(20, 20)), FLIGHT)
    five = tuple((-10.0 * i - 10.0, 0.0) for i in range(5))
    with pytest.raises(ValueError, match=r"ground_nodes must be K in \[2, 4\]"):
        score_plan(CONFIG.replace(ground_nodes=five), FLIGHT)


def test_the_compiled_power_level_is_numpys_bisection_bit_for_bit():
    rng = np.random.default_rng(0)
    for _ in range(2000):
        n = int(rng.integers(1, 8))
        energy = rng.exponential(size=n) * 10 ** rng.uniform(-3, 3)
        lam = rng.exponential(size=n) * 10 ** rng.uniform(-3, 3)
        lam[0] = 0.0 if rng.random() < 0.2 else lam[0]
        lo, hi = 0.0, float(np.sqrt(energy.sum()))
        start = hi
        for _ in range(200):  # wmmse_beams' own loop, with numpy's sums
            mu = 0.5 * (lo + hi)
            lo, hi = (mu, hi) if float(np.sum(energy / (lam + mu) ** 2)) > 1.0 else (lo, mu)
            if hi - lo <= 1e-15 * hi:
                break
        assert _power_level(energy, lam, start) == hi
