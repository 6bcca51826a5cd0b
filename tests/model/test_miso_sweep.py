"""The fixed-UAV power sweep: every scheme below the certified bound and AO above the aligned
baselines at every power, AO non-decreasing in P, K streams' slope for ZF at high power and MRT's
saturation, the low-power limits (TDMA and AO attain the bound, equal-power MRT's predicted share),
N_t = K = 1 as the single-antenna model's rate at every power, and bad inputs refused."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ios_uav_env import ScenarioConfig
from ios_uav_env.model import channel as ch
from ios_uav_env.model import miso, miso_sweep
from ios_uav_env.model.array import ArrayConfig

#: Rounding slack of "below the bound" and "above a start": the rates are sums of K log2 terms
#: of O(1) SINRs computed from the same channel, ~1e-15 relative; a real violation is larger.
ROUNDING = 1e-12
#: Users spread along the array's axis (cos psi about -0.6, 0.7, 0) seen from HOVER: independent rows.
SPREAD = ((-130.0, 0.0), (40.0, 20.0), (-60.0, 40.0))
HOVER = (-60.0, 0.0)


def _spread(K: int) -> ScenarioConfig:
    """A 4 x 3 surface made strong (G_m = 1e4: its paths 0.1 to 0.6 of the direct ones) and K users
    of :data:`SPREAD`; at 40 dBm their single-user gains are about 22 dB."""
    return ScenarioConfig(ios_shape=(4, 3), g_element=1e4, ground_nodes=SPREAD[:K])


def _random_setup(rng: np.random.Generator, n_t: int, K: int):
    """K users on both sides of a small, strong surface (as ``test_miso.random_slot``), a random
    array orientation and hover point."""
    nodes = [((-1.0) ** k * rng.uniform(5.0, 60.0), rng.uniform(-60.0, 60.0)) for k in range(K)]
    config = ScenarioConfig(
        surface=str(rng.choice(["ios", "ris"])), ground_nodes=tuple(nodes), ios_shape=(4, 3),
        g_element=1e3, alpha=rng.uniform(5.5, 7.0),
    )  # fmt: skip
    array = ArrayConfig(n_t=n_t, orientation_rad=rng.uniform(0, 2 * np.pi))
    return config, array, rng.uniform(-80.0, 80.0, 2)


@pytest.mark.slow_without_numba
@pytest.mark.parametrize("objective", miso.SLOT_OBJECTIVES)
@pytest.mark.parametrize(("n_t", "K"), [(2, 2), (4, 3), (1, 2)])
def test_every_scheme_is_below_the_bound_and_ao_above_the_aligned_starts(objective, n_t, K):
    rng = np.random.default_rng(10 * n_t + K + (0 if objective == "sum" else 100))
    for _ in range(2):
        config, array, q = _random_setup(rng, n_t, K)
        sweep = miso_sweep.power_sweep(
            config, array, q, [40.0, 60.0, 80.0], objective, random_starts=1, max_iter=15
        )
        assert sweep.values["AO"][-1] > 0.5  # not the noise floor: the comparisons can tell
        for name in miso_sweep.SCHEMES:
            finite = np.isfinite(sweep.values[name])
            assert np.all(sweep.values[name][finite] <= sweep.bound[finite] * (1 + ROUNDING)), name
            assert np.all(sweep.gap(name)[finite] >= -ROUNDING * sweep.bound[finite])
        for name in ("MRT aligned", "ZF aligned") + (("TDMA",) if objective == "sum" else ()):
            base = sweep.values[name]
            assert np.all(np.isnan(base) | (sweep.values["AO"] >= base * (1 - ROUNDING))), name
        assert np.isnan(sweep.values["ZF aligned"]).all() == (n_t < K)
        # the warm start from the previous power: AO never falls as P rises
        assert np.all(np.diff(sweep.values["AO"]) >= -ROUNDING * sweep.values["AO"][1:])
        for p, solution, value in zip(sweep.powers_dbm, sweep.solutions, sweep.values["AO"], strict=True):
            H = miso_sweep.sweep_channel(config, array, q, p).matrix(solution.phases)
            assert miso.objective_value(miso.user_rates(H, solution.beams), objective) == pytest.approx(
                value, rel=1e-12
            )


@pytest.mark.parametrize("objective", miso.SLOT_OBJECTIVES)
def test_the_warm_start_carries_ao_along_the_powers(objective):
    """With 2 iterations per start, the previous power's solution (already iterated) is the best
    start at the later powers (without it this fails), and AO never falls as P rises."""
    config, array = _spread(3), ArrayConfig(n_t=4)
    powers = [30.0, 30.5, 31.0, 31.5, 32.0]
    sweep = miso_sweep.power_sweep(config, array, HOVER, powers, objective, random_starts=0, max_iter=2)
    assert sum(s.start.startswith("previous power") for s in sweep.solutions[1:]) >= 2
    assert np.all(np.diff(sweep.values["AO"]) >= -ROUNDING * sweep.values["AO"][1:])


@pytest.mark.slow_without_numba
@pytest.mark.parametrize("K", [2, 3])
def test_zero_forcing_gains_k_streams_per_decade_and_mrt_saturates(K):
    """At 70 -> 80 dBm every ZF SINR is >= 1e4 (checked): the slope is within 1e-3 of
    K log2(10) / 10 per dB (the deficit is about 0.4 / SINR) and never above it; the bound and AO
    follow it; equal-power MRT is interference-limited (slope < 1 % of it)."""
    config, array = _spread(K), ArrayConfig(n_t=4)
    low = miso_sweep.sweep_channel(config, array, HOVER, 70.0)
    for j in range(K):
        H = low.matrix(miso.aligned_phases(low, j))
        assert miso.sinr(H, miso.zf_beams(H)).min() >= 1e4
    sweep = miso_sweep.power_sweep(config, array, HOVER, [70.0, 80.0], "sum", max_iter=30)
    dof = miso_sweep.dof_slope(K)
    assert dof == pytest.approx(K * 0.33219280948873623, rel=1e-15)  # log2(10) / 10 per stream
    zf = sweep.slope("ZF aligned")[0]
    assert (1 - 1e-3) * dof <= zf <= dof
    for name in ("AO", "bound"):
        assert sweep.slope(name)[0] == pytest.approx(dof, rel=1e-2), name
    assert 0 <= sweep.slope("MRT aligned")[0] < 0.01 * dof
    # max-min: one stream's slope for ZF and the bound
    maxmin = miso_sweep.power_sweep(config, array, HOVER, [70.0, 80.0], "maxmin", random_starts=0, max_iter=5)
    for name in ("ZF aligned", "bound"):
        assert maxmin.slope(name)[0] == pytest.approx(miso_sweep.dof_slope(1), rel=1e-3), name


@pytest.mark.parametrize("K", [1, 2, 3])
def test_at_low_power_the_matched_filter_on_the_best_user_is_optimal(K):
    """At -20 dBm every G_k is about 1e-4: TDMA and AO attain the sum-rate bound (all power to the
    best user, MRT, its aligned phases), equal-power MRT's share of it is the first-order limit to
    1e-3 (its error is O(G)), ZF is below MRT, and TDMA's max-min is the bound's to 1e-3."""
    config, array = _spread(K), ArrayConfig(n_t=4)
    sweep = miso_sweep.power_sweep(config, array, HOVER, [-20.0], "sum", random_starts=0, max_iter=5)
    assert sweep.gains.max() < 1e-3
    np.testing.assert_allclose(sweep.values["TDMA"], sweep.bound, rtol=1e-12)
    np.testing.assert_allclose(sweep.values["AO"], sweep.bound, rtol=1e-12)
    channel = miso_sweep.sweep_channel(config, array, HOVER, -20.0)
    limit = miso_sweep.low_power_mrt_ratio(channel)
    assert sweep.values["MRT aligned"][0] / sweep.bound[0] == pytest.approx(limit, rel=1e-3)
    if K == 1:
        assert limit == pytest.approx(1.0, rel=1e-12)
    else:
        assert limit < 0.99  # the equal split and the shared phases cost: the check can tell
        assert sweep.values["ZF aligned"][0] < sweep.values["MRT aligned"][0]
    maxmin = miso_sweep.power_sweep(config, array, HOVER, [-20.0], "maxmin", random_starts=0, max_iter=5)
    assert maxmin.values["TDMA"][0] == pytest.approx(maxmin.bound[0], rel=1e-3)


def test_one_antenna_and_one_user_is_the_single_antenna_rate_at_every_power():
    """N_t = K = 1: AO, MRT and ZF with aligned phases, TDMA and the bound are all
    ``channel.slot_rates`` at the power P, to 1e-12 (the same sums in another order); 20 dBm is
    the scenario's own 0.1 W."""
    config = ScenarioConfig(ios_shape=(10, 6), g_element=1e3)
    q = np.array([-60.0, 10.0])
    powers = [-10.0, 20.0, 50.0]
    sweep = miso_sweep.power_sweep(config, ArrayConfig(), q, powers, "sum", random_starts=1, max_iter=20)
    single = [ch.slot_rates(config.replace(power_w=10 ** (p / 10) * 1e-3), q)[0] for p in powers]
    np.testing.assert_allclose(single[1], ch.slot_rates(config, q)[0], rtol=1e-14)
    for name in ("AO", "MRT aligned", "ZF aligned", "TDMA"):
        np.testing.assert_allclose(sweep.values[name], single, rtol=1e-12, err_msg=name)
    np.testing.assert_allclose(sweep.bound, single, rtol=1e-12)
    assert np.all(sweep.values["MRT random"] < 0.95 * sweep.bound)  # the phases matter here
    np.testing.assert_array_equal(sweep.snr_db, np.array(powers) - config.noise_dbm)


def test_the_channel_scales_with_the_power_in_dbm():
    """10 dB more power is sqrt(10) on every channel coefficient; the geometry is unchanged."""
    config, array = _spread(2), ArrayConfig(n_t=3)
    a, b = (miso_sweep.sweep_channel(config, array, HOVER, p) for p in (3.0, 13.0))
    np.testing.assert_allclose(b.coef, math.sqrt(10) * a.coef, rtol=1e-12)
    np.testing.assert_allclose(b.direct, math.sqrt(10) * a.direct, rtol=1e-12)
    np.testing.assert_array_equal(b.to_elements, a.to_elements)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (
            {"powers_dbm": []},
            r"powers_dbm must be a non-empty list of finite transmit powers in \[-100, 100\] dBm",
        ),
        ({"powers_dbm": [0.0, float("nan")]}, r"powers_dbm must be a non-empty list"),
        ({"powers_dbm": [0.0, 120.0]}, r"in \[-100, 100\] dBm"),
        ({"powers_dbm": [[0.0, 10.0]]}, r"powers_dbm must be a non-empty list"),
        ({"powers_dbm": [10.0, 10.0]}, r"powers_dbm must be strictly increasing"),
        ({"objective": "mean"}, r"objective must be one of \('sum', 'maxmin'\)"),
        ({"seed": -1}, r"seed must be an integer >= 0"),
        ({"random_starts": -1}, r"random_starts must be an integer >= 0"),
    ],
)
def test_bad_inputs_name_the_field_and_the_range(kwargs, message):
    args = {"powers_dbm": [0.0, 10.0]} | kwargs
    with pytest.raises(ValueError, match=message):
        miso_sweep.power_sweep(_spread(2), ArrayConfig(n_t=2), HOVER, **args)


def test_bad_scheme_and_stream_count_are_refused():
    sweep = miso_sweep.power_sweep(_spread(2), ArrayConfig(n_t=2), HOVER, [0.0], random_starts=0, max_iter=2)
    with pytest.raises(ValueError, match=r"scheme must be one of \('AO', 'MRT aligned'"):
        sweep.gap("WMMSE")
    with pytest.raises(ValueError, match="streams must be an integer >= 0"):
        miso_sweep.dof_slope(-1)
