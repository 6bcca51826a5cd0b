"""The multi-antenna UAV's closed-form slot rate (``ScenarioConfig.antennas``): ``channel.aligned_gain``
is the per-element model's optimum of ``model.miso`` (aligned phases and MRT), the compiled kernel
is the numpy model, one antenna is eq. (14) exactly, and the bounds that hold every rate hold it."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from ios_uav_env import ScenarioConfig
from ios_uav_env.envs.observation import rate_bound
from ios_uav_env.model import channel, miso
from ios_uav_env.model.array import scenario_array
from ios_uav_env.model.peak import rate_peak

#: The quadrature of the surface sum (``quadrature_tol`` 1e-12 of the amplitude) against the
#: per-element sum of ``model.miso``, with room for rounding: 1e-10 of the gain.
QUADRATURE_REL = 1e-10
#: The compiled kernel against the numpy model: the same formula, summed in another order.
KERNEL_REL = 1e-12

POINTS = np.array([[-350.0, 20.0], [-100.0, -20.0], [-30.0, 5.0], [0.0, 60.0], [45.0, -80.0], [300.0, 20.0]])
NODES = [(-100.0, -20.0), (60.0, 30.0)]  # the UAV's side of the surface (reflection), and across


@pytest.mark.parametrize("surface", ["ios", "ris", "none", "star"])
@pytest.mark.parametrize("node", NODES)
@pytest.mark.parametrize("antennas", [1, 2, 4, 8])
def test_the_gain_is_the_per_element_optimum_of_aligned_phases_and_mrt(surface, node, antennas):
    """|h w|^2 of ``model.miso``'s channel at its aligned phases with MRT (the joint optimum when
    the UAV-surface link is rank one) and its exact bound ``user_gain_bound`` are the closed form."""
    cfg = ScenarioConfig(surface=surface, ground_node=node, antennas=antennas)
    got = channel.aligned_gain(cfg, POINTS)
    for p, slot in enumerate(miso.slot_channels(cfg, scenario_array(cfg), POINTS)):
        h = slot.matrix(miso.aligned_phases(slot, 0))[0]
        achieved = float(np.abs(h @ miso.mrt_beam(h)) ** 2)
        assert got[p] == pytest.approx(achieved, rel=QUADRATURE_REL)
        assert got[p] == pytest.approx(miso.user_gain_bound(slot, 0), rel=QUADRATURE_REL)
    np.testing.assert_allclose(channel.slot_rates(cfg, POINTS), np.log2(1.0 + got), rtol=1e-15)


@pytest.mark.parametrize("antennas", [2, 4, 8])
def test_the_compiled_kernel_is_the_numpy_model(antennas):
    rng = np.random.default_rng(antennas)
    points = np.column_stack([rng.uniform(-450.0, 450.0, 200), rng.uniform(-150.0, 150.0, 200)])
    for node in NODES:
        cfg = ScenarioConfig(ground_node=node, antennas=antennas)
        kernel = channel.rate_kernel(cfg)
        np.testing.assert_allclose(kernel.rates(points), channel.slot_rates(cfg, points), rtol=KERNEL_REL)
        assert kernel.rate(*points[0]) == pytest.approx(channel.slot_rates(cfg, points[0])[0], rel=KERNEL_REL)


def test_one_antenna_is_eq_14_exactly():
    cfg = ScenarioConfig()
    assert cfg.antennas == 1 and "antennas" not in cfg.to_dict()
    z = channel.zeta(cfg, POINTS)
    assert np.array_equal(channel.aligned_gain(cfg, POINTS), cfg.eta * z * z)
    assert np.array_equal(channel.array_factor(cfg, POINTS), np.ones(len(POINTS)))


def test_doubling_the_antennas_never_lowers_the_gain():
    """G(2 N) >= 2 N (S^2 + a_D^2) >= N (S + a_D)^2 >= G(N): the array factor is in [0, N]."""
    rng = np.random.default_rng(1)
    points = np.column_stack([rng.uniform(-450.0, 450.0, 500), rng.uniform(-150.0, 150.0, 500)])
    gains = [channel.aligned_gain(ScenarioConfig(antennas=n), points) for n in (1, 2, 4, 8, 16)]
    for lower, higher in itertools.pairwise(gains):
        assert np.all(higher >= lower) and np.mean(higher / lower) > 1.5  # (about the array gain, 2)
    factor = channel.array_factor(ScenarioConfig(antennas=8), points)
    assert np.all((factor >= 0.0) & (factor <= 8.0 + 1e-12)) and np.ptp(factor) > 1.0


@pytest.mark.parametrize("antennas", [4, 16])
def test_the_observation_bound_and_the_peak_search_hold_the_rate(antennas):
    cfg = ScenarioConfig(T=40.0, antennas=antennas)
    xs, ys = np.meshgrid(np.linspace(-450.0, 450.0, 181), np.linspace(-150.0, 150.0, 61))
    grid = np.column_stack([xs.ravel(), ys.ravel()])
    rates = channel.slot_rates(cfg, grid)
    assert rates.max() <= rate_bound(cfg)
    peak = rate_peak(cfg)  # branch and bound on the N_t zeta^2 block bound
    assert peak.rate == pytest.approx(float(channel.slot_rates(cfg, np.array([[peak.x, peak.y]]))[0]))
    assert peak.rate >= rates.max() - 1e-9


def test_the_single_antenna_channel_refuses_several_antennas():
    cfg = ScenarioConfig(antennas=2)
    rng = np.random.default_rng(0)
    with pytest.raises(
        ValueError,
        match=r"faded_rates models the single-antenna UAV.*antennas=2.*Rician draw .*model.miso_fading",
    ):
        channel.faded_rates(cfg, POINTS, rng)
    with pytest.raises(ValueError, match=r"phased_rates models the single-antenna UAV"):
        channel.phased_rates(cfg, POINTS, channel.phase_shifts(cfg, POINTS))
