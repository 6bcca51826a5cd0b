"""The multi-antenna UAV's Rician slot channel (``ios_uav_env.model.miso_fading``): with one antenna
and the scattering "link" it is the paper's Rician channel of eqs. (4)-(8) (``channel.channel``),
drawn from the same generator stream; kappa -> infinity recovers the LoS channel; the draws' mean
power is the path-loss prediction (``mean_gains``, itself eta zeta^2 at eq. (13)'s phases); no
setting, AO or baseline beats the certified bound on a drawn channel; bad input is refused by name."""

from __future__ import annotations

import numpy as np
import pytest

from ios_uav_env.envs.star_control import BASE_CONFIG
from ios_uav_env.model import channel as ch
from ios_uav_env.model import miso, miso_fading, miso_slot
from ios_uav_env.model.array import ArrayConfig
from tests.tolerances import RATE_REL

#: A small surface, two users (one on each side), the ULA along the flight's direction.
CONFIG = BASE_CONFIG.replace(ios_shape=(4, 4), ground_nodes=((-10.0, 10.0), (10.0, -10.0)))
ONE_USER = CONFIG.replace(ground_nodes=CONFIG.ground_nodes[:1])
PATH = np.array([[-200.0, -100.0], [-150.0, 20.0], [-120.0, 100.0], [-100.0, -150.0]])
#: Rounding of two orders of the same complex sums (h summed over 16 elements: ~1e-15 relative).
ROUNDING = 1e-12


def _array(n_t: int, steering: str = "centre") -> ArrayConfig:
    return ArrayConfig(n_t=n_t, orientation_rad=np.pi / 2, steering=steering)


def test_one_antenna_link_scattering_is_the_papers_channel_from_the_same_stream():
    """N_t = 1, K = 1: h = sqrt(eta) channel.channel (eqs. (4)-(8)) at any phases, and the generator
    has consumed exactly the draws channel.channel consumes (its state after, bit for bit)."""
    phases = np.random.default_rng(1).uniform(0, 2 * np.pi, (len(PATH), ONE_USER.M))
    for kappa in (0.0, 3.0, 10.0):
        config = ONE_USER.replace(kappa=kappa)
        paper_rng, ours = np.random.default_rng(5), np.random.default_rng(5)
        h = np.sqrt(config.eta) * ch.channel(config, PATH, paper_rng, phases)
        drawn = miso_fading.rician_slot_channels(config, ArrayConfig(), PATH, ours)
        h_ours = np.array([c.matrix(p)[0, 0] for c, p in zip(drawn, phases, strict=True)])
        np.testing.assert_allclose(h_ours, h, rtol=ROUNDING)
        assert ours.bit_generator.state == paper_rng.bit_generator.state
        paper_rng, ours = np.random.default_rng(6), np.random.default_rng(6)
        h = np.sqrt(config.eta) * ch.channel(config, PATH[:1], paper_rng, phases[:1])
        one = miso_fading.rician_slot_channel(config, ArrayConfig(), PATH[0], ours)
        np.testing.assert_allclose(one.matrix(phases[0])[0], h, rtol=ROUNDING)
        assert ours.bit_generator.state == paper_rng.bit_generator.state


@pytest.mark.parametrize("scattering", miso_fading.SCATTERINGS)
@pytest.mark.parametrize(("n_t", "steering"), [(1, "centre"), (4, "centre"), (4, "element")])
def test_a_large_kappa_recovers_the_los_channel(scattering, n_t, steering):
    array, phases = _array(n_t, steering), np.random.default_rng(2).uniform(0, 2 * np.pi, CONFIG.M)
    los = miso.slot_channels(CONFIG, array, PATH)
    drawn = miso_fading.rician_slot_channels(
        CONFIG.replace(kappa=1e12), array, PATH, np.random.default_rng(3), scattering
    )
    for a, b in zip(los, drawn, strict=True):
        H, H_los = b.matrix(phases), a.matrix(phases)
        assert np.max(np.abs(H - H_los)) <= 1e-5 * np.max(np.abs(H_los))  # ~ 1 / sqrt(kappa)
    far = miso_fading.rician_slot_channels(CONFIG, array, PATH, np.random.default_rng(3), scattering)
    assert np.max(np.abs(far[0].matrix(phases) - los[0].matrix(phases))) > 1e-2 * np.max(
        np.abs(los[0].matrix(phases))
    )  # kappa = 3 does fade


def test_the_mean_power_of_one_antenna_at_eq_13s_phases_is_eta_zeta_squared():
    """eqs. (4)-(8): E|h|^2 = zeta^2 at the closed-form phases (the expected-gain rate's SNR)."""
    for q in PATH:
        phases = ch.phase_shifts(ONE_USER, q)[0]
        mean = miso_fading.mean_gains(ONE_USER, ArrayConfig(), q, phases, "link")
        z = ch.zeta(ONE_USER.replace(quadrature_nodes=0), q)
        np.testing.assert_allclose(mean, ONE_USER.eta * z * z, rtol=RATE_REL)


@pytest.mark.parametrize("scattering", miso_fading.SCATTERINGS)
@pytest.mark.parametrize("kappa", [0.0, 3.0])
def test_the_draws_mean_power_is_the_path_loss_prediction(scattering, kappa):
    """The empirical means over n = 4000 draws (fixed seed) of ||h_k||^2 (against ``mean_gains``) and
    of its two parts, the surface's sum_m v_m c_km g_m and the direct row d_k (against the model's
    powers, written out here: each LoS term's power times kappa / (1 + kappa) plus the scattered
    power over 1 + kappa). Each is a LoS part plus a sum of CN(0, s^2 I) vectors: at most a
    chi-square of 2 N_t = 8 degrees of freedom in relative spread, standard deviation at most
    1 / sqrt(N_t) = 0.5 relative, so the mean's is at most 0.5 / sqrt(4000) = 0.008. The tolerance
    0.06 is more than 7 of those (seed-safe), while a scattered power off by a factor (an amplitude
    for its square, a missing N_t or eta, the coherent sum for the incoherent) moves a part's mean
    by a factor."""
    config, array, n = CONFIG.replace(kappa=kappa), _array(4), 4000
    q = np.array([-150.0, -60.0])
    phases = np.random.default_rng(4).uniform(0, 2 * np.pi, config.M)
    path = np.tile(q, (n, 1))
    drawn = miso_fading.rician_slot_channels(config, array, path, np.random.default_rng(7), scattering)
    total = np.mean([np.sum(np.abs(c.matrix(phases)) ** 2, axis=1) for c in drawn], axis=0)
    surface = np.mean([np.sum(np.abs(c.matrix(phases) - c.direct) ** 2, axis=1) for c in drawn], axis=0)
    direct = np.mean([np.sum(np.abs(c.direct) ** 2, axis=1) for c in drawn], axis=0)
    los = miso.slot_channel(config, array, q)
    los_surface = np.sum(np.abs(los.matrix(phases) - los.direct) ** 2, axis=1)
    los_direct = np.sum(np.abs(los.direct) ** 2, axis=1)
    users = [config.node_config(k) for k in range(config.K)]
    a = np.stack([ch.element_amplitudes(u, q)[0] for u in users])  # (K, M)
    a_d = np.array([ch.direct_amplitude(u, q)[0] for u in users])
    w_los, w_nlos, n_t = kappa / (1 + kappa), 1 / (1 + kappa), array.n_t
    if scattering == "link":  # the surface's part stays LoS; one vector of amplitude S + a_D
        want_surface = w_los * los_surface
        want_direct = w_los * los_direct + w_nlos * n_t * config.eta * (a.sum(axis=1) + a_d) ** 2
    else:
        want_surface = w_los * los_surface + w_nlos * n_t * config.eta * (a * a).sum(axis=1)
        want_direct = w_los * los_direct + w_nlos * n_t * config.eta * a_d**2
    np.testing.assert_allclose(surface, want_surface, rtol=0.06)
    np.testing.assert_allclose(direct, want_direct, rtol=0.06)
    np.testing.assert_allclose(total, miso_fading.mean_gains(config, array, q, phases, scattering), rtol=0.06)


def test_the_two_scatterings_differ_by_the_coherent_against_the_incoherent_surface_sum():
    """With the direct links' scattering the same, the link scattering's surface power exceeds the
    element scattering's by (sum_m a_km)^2 - sum_m a_km^2 >= 0: equal without a surface's share."""
    q, phases = PATH[1], np.zeros(CONFIG.M)
    config = CONFIG.replace(kappa=0.0)
    link, element = (miso_fading.mean_gains(config, _array(2), q, phases, s) for s in miso_fading.SCATTERINGS)
    users = [config.node_config(k) for k in range(config.K)]
    a = np.stack([ch.element_amplitudes(u, q)[0] for u in users])  # (K, M)
    a_d = np.array([ch.direct_amplitude(u, q)[0] for u in users])
    gap = config.eta * 2 * ((a.sum(axis=1) + a_d) ** 2 - (a * a).sum(axis=1) - a_d**2)  # N_t = 2
    np.testing.assert_allclose(link - element, gap, rtol=1e-9)
    assert np.all(gap > 0)


@pytest.mark.parametrize("scattering", miso_fading.SCATTERINGS)
@pytest.mark.parametrize("objective", miso.SLOT_OBJECTIVES)
def test_the_bound_holds_above_ao_baselines_and_random_settings_on_drawn_channels(scattering, objective):
    rng = np.random.default_rng(9)
    for n_t in (1, 2, 4):
        for kappa in (0.0, 3.0):
            config = CONFIG.replace(kappa=kappa)
            drawn = miso_fading.rician_slot_channels(config, _array(n_t), PATH[:2], rng, scattering)
            for slot in drawn:
                bound = miso.slot_bounds(slot).of(objective)
                best = miso_slot.slot_optimum(slot, objective)
                assert best.value <= bound * (1 + 1e-9)
                base = miso.baselines(slot, objective, rng)
                assert all(v <= bound * (1 + 1e-12) for v in base.values() if not np.isnan(v))
                assert best.value >= base["MRT aligned"] * (1 - 1e-12)
                for _ in range(20):
                    W = rng.standard_normal((n_t, config.K)) + 1j * rng.standard_normal((n_t, config.K))
                    rates = miso.user_rates(slot.matrix(miso.random_phases(slot, rng)), W / np.linalg.norm(W))
                    assert miso.objective_value(rates, objective) <= bound * (1 + 1e-12)


def test_one_user_link_scattering_keeps_the_closed_form_and_element_scattering_is_not_rank_one():
    """Link scattering adds to the direct row only: the aligned phases with MRT attain the bound
    (Wu & Zhang's closed form on the faded row). Element scattering makes G full rank."""
    rng = np.random.default_rng(12)
    config = CONFIG.replace(ground_nodes=CONFIG.ground_nodes[1:])
    for slot in miso_fading.rician_slot_channels(config, _array(4), PATH, rng, "link"):
        assert slot.rank_one
        h = slot.matrix(miso.aligned_phases(slot, 0))[0]
        assert np.vdot(h, h).real == pytest.approx(miso.user_gain_bound(slot, 0), rel=1e-12)
    for slot in miso_fading.rician_slot_channels(config, _array(4), PATH, rng, "element"):
        assert not slot.rank_one and np.linalg.matrix_rank(slot.to_elements) == 4


def test_bad_input_is_refused_by_name():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match=r"^scattering must be one of \('link', 'element'\)"):
        miso_fading.rician_slot_channels(CONFIG, _array(2), PATH, rng, "antenna")
    with pytest.raises(ValueError, match="^scattering must"):
        miso_fading.mean_gains(CONFIG, _array(2), PATH[0], np.zeros(CONFIG.M), "los")
    with pytest.raises(ValueError, match="^position must be one horizontal position"):
        miso_fading.rician_slot_channel(CONFIG, _array(2), PATH, rng)
    with pytest.raises(ValueError, match="^phases must"):
        miso_fading.mean_gains(CONFIG, _array(2), PATH[0], np.zeros(3))
    with pytest.raises(ValueError, match=r"^rng must be a numpy Generator"):
        miso_fading.rician_slot_channels(CONFIG, _array(2), PATH, 5)
