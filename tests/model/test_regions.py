"""The max-min rate over per-slot rate regions: TDMA as a case (equal to the schedule's LP), the
two-user broadcast region (NOMA), the certificate, and bad pricers and arguments."""

from __future__ import annotations

import numpy as np
import pytest

from ios_uav_env.model.regions import (
    broadcast_pricer,
    maxmin_regions,
    tdma_pricer,
    weighted_noma,
    weighted_noma_array,
)
from ios_uav_env.model.schedule import maxmin_schedule


@pytest.mark.parametrize("seed", range(6))
def test_tdma_is_the_schedule_of_the_frame(seed):
    rng = np.random.default_rng(seed)
    k, n = int(rng.integers(2, 6)), int(rng.integers(5, 40))
    rates = rng.uniform(0.0, 3.0, (k, n)) * rng.uniform(0.2, 1.0, (k, 1))
    got = maxmin_regions(tdma_pricer(rates), k)
    want = maxmin_schedule(rates).value
    assert got.value == pytest.approx(want, rel=1e-9) and got.upper == pytest.approx(want, rel=1e-9)
    assert got.value <= got.upper and got.gap <= 1e-9
    np.testing.assert_allclose(got.mix.sum(), 1.0, rtol=1e-12)
    np.testing.assert_allclose(got.rates, got.mix @ got.points, rtol=1e-12)


def _tdma_rates(snr):
    return np.log2(1.0 + snr)


@pytest.mark.parametrize("seed", range(6))
def test_superposition_serves_two_users_at_least_as_well_as_tdma(seed):
    rng = np.random.default_rng(seed)
    snr = rng.lognormal(2.0, 1.5, (2, 30))
    noma = maxmin_regions(broadcast_pricer(snr), 2)
    tdma = maxmin_regions(tdma_pricer(_tdma_rates(snr)), 2)
    assert noma.gap <= 1e-8  # the pricer is exact: the bound closes
    assert noma.value >= tdma.value * (1 - 1e-12)


def test_superposition_gains_where_the_channels_differ():
    # a strong user (SNR 100) and a weak one (SNR 1) every slot: TDMA gives each its time alone,
    # max-min 1 / (1 / log2(101) + 1 / log2(2)); superposition meets at (1 + 100 p)(1 + p) = 2
    snr = np.tile([[100.0], [1.0]], (1, 10))
    tdma = maxmin_regions(tdma_pricer(_tdma_rates(snr)), 2).value
    p = (-101 + np.sqrt(101**2 + 400)) / 200
    assert tdma == pytest.approx(1 / (1 / np.log2(101) + 1), rel=1e-9)
    assert maxmin_regions(broadcast_pricer(snr), 2).value == pytest.approx(np.log2(1 + 100 * p), rel=1e-8)
    assert np.log2(1 + 100 * p) > 1.1 * tdma


def test_one_slot_against_a_brute_force_of_the_power_split():
    snr = np.array([[40.0], [3.0]])
    got = maxmin_regions(broadcast_pricer(snr), 2)
    # the superposition region of the degraded broadcast channel is convex (its capacity region),
    # so the max-min is where the two rates meet: (1 + 40 p)(1 + 3 p) = 4, 120 p^2 + 43 p - 3 = 0
    p = (-43 + np.sqrt(43**2 + 4 * 120 * 3)) / 240
    meet = np.log2(1 + 40 * p)
    assert meet == pytest.approx(np.log2(4 / (1 + 3 * p)), rel=1e-12)
    assert got.value == pytest.approx(meet, rel=1e-8) and got.upper >= meet * (1 - 1e-12)


@pytest.mark.parametrize(
    ("w", "g_r", "g_t"), [(0.5, 10.0, 2.0), (0.2, 50.0, 1.0), (0.9, 4.0, 4.0), (0.7, 1.0, 30.0)]
)
def test_the_weighted_sum_split_is_the_best_power_share(w, g_r, g_t):
    x = np.linspace(0.0, 1.0, 100_001)  # the power share of user r
    if g_r >= g_t:  # the stronger user decodes the weaker's signal first
        r_r, r_t = np.log2(1 + x * g_r), np.log2((1 + g_t) / (1 + x * g_t))
    else:
        r_r, r_t = np.log2((1 + g_r) / (1 + (1 - x) * g_r)), np.log2(1 + (1 - x) * g_t)
    value, rate_r, rate_t, split = weighted_noma(g_r, g_t, w)
    assert value == pytest.approx(np.max(w * r_r + (1 - w) * r_t), rel=1e-9, abs=1e-12)
    assert value == pytest.approx(w * rate_r + (1 - w) * rate_t, rel=1e-12) and 0.0 <= split <= 1.0


def test_the_array_form_is_the_scalar_weighted_sum_elementwise():
    rng = np.random.default_rng(3)
    g_r, g_t, w = np.exp(rng.uniform(-6, 7, 500)), np.exp(rng.uniform(-6, 7, 500)), rng.uniform(0, 1, 500)
    g_r[:20], g_t[10:30], g_t[40:50], w[60:70], w[70:80] = 0.0, 0.0, g_r[40:50], 0.5, 1.0  # the edge cases
    value, rate_r, rate_t = weighted_noma_array(g_r.reshape(20, 25), g_t.reshape(20, 25), w.reshape(20, 25))
    want = np.array([weighted_noma(a, b, c)[:3] for a, b, c in zip(g_r, g_t, w, strict=True)])
    got = np.column_stack([value.ravel(), rate_r.ravel(), rate_t.ravel()])
    np.testing.assert_allclose(got, want, rtol=1e-14, atol=1e-15)  # math.log2 against numpy's


def test_a_pricer_whose_bound_is_not_one_is_refused():
    def liar(w):
        return np.array([1.0, 1.0]), 0.5  # w . point = 1 > 0.5

    with pytest.raises(ValueError, match="not a bound of g"):
        maxmin_regions(liar, 2)
    with pytest.raises(ValueError, match="K = 2 finite rates"):
        maxmin_regions(lambda w: (np.array([1.0, -1.0]), 2.0), 2)


def test_an_inexact_pricer_stops_with_an_honest_bound():
    rates = np.array([[2.0, 0.0, 1.0], [0.0, 2.0, 1.0]])
    exact = tdma_pricer(rates)

    def loose(w):
        point, bound = exact(w)
        return point, bound + 0.1  # a certified but loose bound of g(w)

    got = maxmin_regions(loose, 2)
    assert got.value == pytest.approx(maxmin_schedule(rates).value, rel=1e-9)
    assert got.upper >= got.value + 0.1 - 1e-12  # the looseness stays in the bound, never hidden


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [({"k": 0}, "k must"), ({"k": 2, "tol": 0.0}, "tol"), ({"k": 2, "max_columns": 2}, "max_columns"),
     ({"k": 2, "start": np.array([0.7, 0.7])}, "start")],
)  # fmt: skip
def test_bad_arguments_name_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        maxmin_regions(tdma_pricer(np.ones((2, 3))), **kwargs)


def test_bad_snr_is_refused():
    with pytest.raises(ValueError, match="snr"):
        broadcast_pricer(np.ones((3, 4)))
    with pytest.raises(ValueError, match="snr"):
        broadcast_pricer(np.array([[1.0, np.nan], [1.0, 1.0]]))
