"""The STAR surface model (``ios_uav_env.model.star``): the paper's IOS as a case, the per-element
channel against ``channel.los_channel``, the exact b-bit phases, the b-bit loss of Wu and Zhang,
NOMA's closed form, and the errors of bad inputs."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from ios_uav_env.model import channel, star
from ios_uav_env.model.config import ScenarioConfig

CONFIG = ScenarioConfig()
# (UAV position, user r on its side, user t across the plane x = 0)
GEOMETRIES = [
    ((-100.0, -20.0), (-100.0, -20.0), (100.0, 30.0)),
    ((100.0, 0.0), (150.0, -40.0), (-100.0, -20.0)),
    ((-20.0, 5.0), (-50.0, 0.0), (30.0, -10.0)),
    ((250.0, 60.0), (20.0, 10.0), (-300.0, -80.0)),
]


@pytest.mark.parametrize("surface", ["ios", "ris", "none"])
@pytest.mark.parametrize("quadrature_nodes", [0, 8])
def test_fixed_split_is_the_papers_surface(surface: str, quadrature_nodes: int) -> None:
    """The "fixed" split with phases aligned to the served user is ``channel.slot_rates`` at each
    user, for the IOS, the RIS and no surface. The STAR side sums every element, slot_rates the
    compressed sum (relative error <= quadrature_tol = 1e-12 on the amplitude): 1e-12 holds."""
    config = CONFIG.replace(surface=surface, quadrature_nodes=quadrature_nodes)
    for q, user_r, user_t in GEOMETRIES:
        c_r, c_t = star.fixed_tdma_rates(config, q, user_r, user_t)
        ref_r = channel.slot_rates(config.replace(ground_node=user_r), q)[0]
        ref_t = channel.slot_rates(config.replace(ground_node=user_t), q)[0]
        assert c_r == pytest.approx(ref_r, rel=1e-12, abs=0)
        assert c_t == pytest.approx(ref_t, rel=1e-12, abs=0)


def test_side_amplitude_is_the_los_channel() -> None:
    """|h_s| under any phases equals ``channel.los_channel``'s modulus for that user (the IOS's
    transmission amplitude epsilon times the unit element's)."""
    rng = np.random.default_rng(3)
    config = CONFIG.replace(ios_shape=(12, 8))
    q, user_r, user_t = GEOMETRIES[1]
    ch = star.star_channels(config, q, user_r, user_t)
    for user, amps, phi, direct in (
        (user_r, ch.a_r, ch.phi_r, ch.direct_r),
        (user_t, config.epsilon * ch.a_t, ch.phi_t, ch.direct_t),
    ):
        theta = rng.uniform(0, 2 * np.pi, ch.M)
        ref = abs(channel.los_channel(config.replace(ground_node=user), np.array([q]), theta[None])[0])
        assert star.side_amplitude(amps, phi, direct, theta) == pytest.approx(ref, rel=1e-12)


def test_best_discrete_phases_is_exact() -> None:
    """The sorted scan finds the b-bit optimum of brute force over every setting (tiny M)."""
    rng = np.random.default_rng(0)
    for _ in range(150):
        m, bits = int(rng.integers(1, 5)), int(rng.integers(1, 4))
        if m * bits > 9:
            bits = 1
        amps, phi = rng.random(m), rng.uniform(0, 2 * np.pi, m)
        direct = float(rng.random() * rng.integers(0, 2))
        theta, amp = star.best_discrete_phases(amps, phi, direct, bits)
        brute = max(
            star.side_amplitude(amps, phi, direct, np.array(c))
            for c in itertools.product(star.phase_grid(bits), repeat=m)
        )
        assert amp == pytest.approx(brute, rel=1e-12)
        assert star.side_amplitude(amps, phi, direct, theta) == pytest.approx(amp, rel=1e-12)
        assert np.allclose(star.quantise(theta, bits), theta)  # on the grid


@pytest.mark.parametrize(("bits", "loss_db"), [(1, -3.92), (2, -0.91), (3, -0.22)])
def test_quantisation_loss_of_wu_and_zhang(bits: int, loss_db: float) -> None:
    """Wu and Zhang (IEEE TCOM 2020): rounding the aligned phases to b bits keeps a fraction
    [sin(pi/2^b) / (pi/2^b)]^2 of the received power as M grows (-3.92, -0.91, -0.22 dB). At the
    default surface (M = 6000) the surface's power gain is within 0.01 dB of it; the exact b-bit
    optimum is no worse than rounding and no better than continuous phases."""
    q, user_r, user_t = GEOMETRIES[0]
    ch = star.star_channels(CONFIG, q, user_r, user_t)
    x = math.pi / 2**bits
    assert 20 * math.log10(math.sin(x) / x) == pytest.approx(loss_db, abs=0.005)
    ideal = ch.a_r.sum()
    rounded = star.side_amplitude(ch.a_r, ch.phi_r, 0.0, star.quantise(ch.phi_r, bits))
    assert 20 * math.log10(rounded / ideal) == pytest.approx(loss_db, abs=0.01)
    _, best = star.best_discrete_phases(ch.a_r, ch.phi_r, 0.0, bits)
    assert rounded <= best <= ideal


def test_noma_maxmin_closed_form() -> None:
    """The closed-form split gives equal rates, and no split of a fine grid does better; the
    rate grows with either SNR; SIC rates as in the docstring."""
    rng = np.random.default_rng(1)
    grid = np.linspace(0, 1, 20001)
    for _ in range(50):
        g_r, g_t = 10 ** rng.uniform(-2, 3, 2)
        rate, split = star.noma_maxmin(g_r, g_t)
        r_r, r_t = star.noma_rates(g_r, g_t, split)
        assert r_r == pytest.approx(rate, rel=1e-12) and r_t == pytest.approx(rate, rel=1e-12)
        brute = np.minimum(*star.noma_rates(g_r, g_t, grid)).max()
        assert brute <= rate * (1 + 1e-12)
        assert brute >= rate * (1 - 1e-3)
        assert star.noma_maxmin(1.1 * g_r, g_t)[0] >= rate and star.noma_maxmin(g_r, 1.1 * g_t)[0] >= rate
    # all power to one user: its single-user rate; equal SNRs g: x = 1 / (1 + sqrt(1 + g))
    assert star.noma_rates(3.0, 1.0, 1.0)[0] == pytest.approx(2.0)
    assert star.noma_maxmin(8.0, 8.0)[0] == pytest.approx(math.log2(1 + 8 / 4))


def test_tdma_maxmin_closed_form() -> None:
    rate, share = star.tdma_maxmin(2.0, 1.0)
    assert rate == pytest.approx(2 / 3) and share == pytest.approx(1 / 3)
    assert star.tdma_rates(2.0, 1.0, share) == pytest.approx((2 / 3, 2 / 3))


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"protocol": "xs"}, "protocol"),
        ({"phases": "free"}, "phases"),
        ({"bits": 0}, "bits"),
        ({"bits": 9}, "bits"),
        ({"bits": True}, "bits"),
        ({"bits": 1.5}, "bits"),
        ({"protocol": "fixed", "phases": "independent"}, "phases"),
        ({"phases": "coupled", "bits": 1}, "bits"),
    ],
)
def test_bad_surface(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        star.StarSurface(**kwargs)


def test_bad_geometry_and_rates() -> None:
    with pytest.raises(ValueError, match="opposite sides"):
        star.star_channels(CONFIG, (-100, 0), (-100, -20), (-50, 30))
    with pytest.raises(ValueError, match="user_r must be on the UAV's side"):
        star.star_channels(CONFIG, (100, 0), (-100, -20), (100, 30))
    with pytest.raises(ValueError, match="position"):
        star.star_channels(CONFIG, (100, 0, 3), (100, -20), (-100, 30))
    with pytest.raises(ValueError, match="user_t"):
        star.star_channels(CONFIG, (100, 0), (100, -20), (np.nan, 30))
    with pytest.raises(ValueError, match=r"split .* \[0, 1\]"):
        star.noma_rates(1.0, 2.0, 1.5)
    with pytest.raises(ValueError, match=r"share .* \[0, 1\]"):
        star.tdma_rates(1.0, 2.0, -0.1)
    with pytest.raises(ValueError, match=r"lam .* \[0, 1\]"):
        star.ts_rates((1.0, 1.0), (1.0, 1.0), 1.2, 0.5, 0.5)


def test_bad_settings() -> None:
    """check_setting names what breaks each protocol, phase model and grid."""
    m = 3
    ones, zeros, half = np.ones(m), np.zeros(m), np.full(m, 0.5)
    th = np.zeros(m)
    es, ms = star.StarSurface("es"), star.StarSurface("ms")
    star.check_setting(es, np.full(m, 0.6), np.full(m, 0.8), th, th)  # on the ES circle
    with pytest.raises(ValueError, match=r"u_r\^2 \+ u_t\^2 must be <= 1"):
        star.check_setting(es, ones, half, th, th)
    with pytest.raises(ValueError, match="protocol='ms'"):
        star.check_setting(ms, half, half, th, th)
    with pytest.raises(ValueError, match=">= 0"):
        star.check_setting(es, -half, half, th, th)
    with pytest.raises(ValueError, match="phases='shared'"):
        star.check_setting(star.StarSurface("es", "shared"), half, half, th, th + 0.1)
    star.check_setting(star.StarSurface("es", "coupled"), half, half, th, th - np.pi / 2)
    with pytest.raises(ValueError, match="phases='coupled'"):
        star.check_setting(star.StarSurface("es", "coupled"), half, half, th, th + 0.1)
    with pytest.raises(ValueError, match="theta_t must lie on the 2-bit grid"):
        star.check_setting(star.StarSurface("es", bits=2), half, half, th, th + 0.3)
    with pytest.raises(ValueError, match="configured split"):
        star.check_setting(star.StarSurface("fixed", "shared"), ones, zeros, th, th, fixed=(1.0, 3.55))
    # TDMA: the sides serve in turn, so neither the split nor the phase model binds across them
    star.check_setting(star.StarSurface("es", "shared"), ones, ones, th, th + 1.0, simultaneous=False)
