"""The multi-antenna UAV's slot channel: N_t = 1 is today's channel, the single-user closed form
against a numerical optimiser, the array gain, the bounds and the baselines, bad inputs."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from ios_uav_env import ScenarioConfig
from ios_uav_env.model import channel as ch
from ios_uav_env.model import miso
from ios_uav_env.model.array import ArrayConfig
from ios_uav_env.model.surface import element_positions

DEFAULT = ScenarioConfig()
SPOTS = [(-100.0, -20.0), (100.0, 0.0), (0.0, 0.0), (37.0, -250.0), (-420.0, 180.0)]


def random_slot(
    rng: np.random.Generator,
    *,
    n_t: int,
    K: int,
    steering: str = "centre",
    shape=(12, 8),
    g_element: float = 1e3,
    surface: str | None = None,
):
    """A small random slot where the surface matters: K users on both sides of it, within 60 m,
    the UAV within 80 m, a random array orientation. A small M is fast; the element gain G_m and
    a steeper direct path loss (alpha in [5.5, 7], a partly blocked direct link) make the surface's
    paths as strong as the direct one (median ratio ~2 at M = 96), the power spreads the SNR over
    about 0.1 to 300."""
    nodes = tuple(
        (rng.choice([-1.0, 1.0]) * rng.uniform(5.0, 60.0), rng.uniform(-60.0, 60.0)) for _ in range(K)
    )
    if K > 1:  # at least one user on each side
        nodes = ((-abs(nodes[0][0]), nodes[0][1]), (abs(nodes[1][0]), nodes[1][1]), *nodes[2:])
    config = ScenarioConfig(
        surface=str(rng.choice(["ios", "ios", "ris"])) if surface is None else surface,
        ground_nodes=nodes,
        ios_shape=shape,
        g_element=g_element,
        alpha=rng.uniform(5.5, 7.0),
        power_w=10 ** rng.uniform(0.0, 3.0),
    )
    array = ArrayConfig(n_t=n_t, orientation_rad=rng.uniform(0, 2 * np.pi), steering=steering)
    return miso.slot_channel(config, array, rng.uniform(-80.0, 80.0, 2))


@pytest.mark.parametrize("surface", ["ios", "ris", "none"])
def test_one_antenna_and_the_closed_form_phases_give_today_s_slot_rates(surface):
    """N_t = 1, w = 1, eq. (13)'s phases: channel.slot_rates to 1e-12 (the same sums in another order;
    the node compression's error is ~1e-16 at these points)."""
    config = DEFAULT.replace(surface=surface)
    for q in SPOTS:
        slot = miso.slot_channel(config, ArrayConfig(), q)
        today = ch.slot_rates(config, q)
        for phases in (ch.phase_shifts(config, q)[0], miso.aligned_phases(slot, 0)):
            got = miso.user_rates(slot.matrix(phases), np.ones((1, 1)))
            np.testing.assert_allclose(got, today, rtol=1e-12)
        np.testing.assert_allclose(np.log2(1 + miso.user_gain_bound(slot, 0)), today, rtol=1e-12)
        np.testing.assert_allclose(miso.tdma_rates(slot), today, rtol=1e-12)


def test_one_antenna_with_any_phases_is_today_s_los_channel():
    rng = np.random.default_rng(0)
    config = DEFAULT.replace(ground_nodes=((-100.0, -20.0), (80.0, 40.0), (30.0, -90.0)))
    for q in SPOTS[:3]:
        slot = miso.slot_channel(config, ArrayConfig(), q)
        phases = rng.uniform(0, 2 * np.pi, config.M)
        H = slot.matrix(phases)
        for k in range(config.K):
            today = ch.los_channel(config.node_config(k), q, phases[None])
            np.testing.assert_allclose(H[k, 0], np.sqrt(config.eta) * today[0], rtol=1e-12)


def test_the_array_gain_without_a_surface_is_n_t():
    """No surface: MRT on the direct link gives N_t times the single-antenna SNR, whatever the angle."""
    config = DEFAULT.replace(surface="none")
    for n_t in (2, 4, 8):
        for q in SPOTS:
            slot = miso.slot_channel(config, ArrayConfig(n_t=n_t, orientation_rad=0.7), q)
            snr = config.eta * ch.direct_amplitude(config, q)[0] ** 2
            np.testing.assert_allclose(miso.user_gain_bound(slot, 0), n_t * snr, rtol=1e-12)
            h = slot.matrix(np.zeros(config.M))[0]
            np.testing.assert_allclose(np.abs(h @ miso.mrt_beam(h)) ** 2, n_t * snr, rtol=1e-12)


@pytest.mark.parametrize("seed", range(4))
def test_the_single_user_closed_form_is_the_numerical_optimum(seed):
    """Rank-one UAV-surface channel: aligned phases + MRT attain G, and a quasi-Newton search over
    every phase and the beam from 8 starts finds no more (and finds G to 1e-6)."""
    rng = np.random.default_rng(seed)
    # M = 6 elements made strong (G_m = 1e8), the user across the IOS for odd seeds
    side = 1.0 if seed % 2 else -1.0
    config = ScenarioConfig(ground_node=(side * 40.0, 15.0), ios_shape=(3, 2), g_element=1e8, power_w=1.0)
    array = ArrayConfig(n_t=int(rng.choice([2, 3, 4])), orientation_rad=rng.uniform(0, 2 * np.pi))
    slot = miso.slot_channel(config, array, (-rng.uniform(20.0, 60.0), rng.uniform(-30.0, 30.0)))
    G = miso.user_gain_bound(slot, 0)
    h = slot.matrix(miso.aligned_phases(slot, 0))[0]
    np.testing.assert_allclose(np.abs(h @ miso.mrt_beam(h)) ** 2, G, rtol=1e-12)
    h = slot.matrix(miso.random_phases(slot, rng))[0]
    assert np.vdot(h, h).real < 0.95 * G  # the phases matter here: the test can tell
    M, n = slot.M, slot.n_t

    def loss(x):  # -|h(psi) w|^2 / G, w = x / ||x||
        w = x[M : M + n] + 1j * x[M + n :]
        return -(np.abs(slot.matrix(x[:M])[0] @ w) ** 2) / np.vdot(w, w).real / G

    best = max(
        -minimize(loss, np.concatenate([rng.uniform(0, 2 * np.pi, M), rng.normal(size=2 * n)]), method="BFGS",
                  options={"gtol": 1e-12}).fun
        for _ in range(8)
    )  # fmt: skip
    assert best <= 1.0 + 1e-9
    assert best >= 1.0 - 1e-6


def test_element_steering_bound_holds_and_centre_is_its_rank_one_case():
    rng = np.random.default_rng(5)
    for _ in range(10):
        slot = random_slot(rng, n_t=4, K=1, steering="element", shape=(8, 6))
        assert not slot.rank_one
        bound = miso.user_gain_bound(slot, 0)
        h = slot.matrix(miso.aligned_phases(slot, 0))[0]
        assert np.vdot(h, h).real <= bound * (1 + 1e-12)
        d = slot.direct[0]
        upper = (np.sqrt(4) * np.abs(slot.coef[0]).sum() + np.linalg.norm(d)) ** 2
        assert bound == pytest.approx(upper, rel=1e-12)


def test_bounds_dominate_tdma_and_the_smallest_single_user_optimum():
    rng = np.random.default_rng(7)
    for _ in range(20):
        slot = random_slot(rng, n_t=int(rng.choice([1, 2, 4])), K=int(rng.choice([2, 3, 4])))
        bounds = miso.slot_bounds(slot)
        single = np.log2(1.0 + bounds.gains)
        np.testing.assert_allclose(single, miso.tdma_rates(slot), rtol=1e-12)  # rank one: attained
        assert bounds.maxmin_rate <= single.min()
        # (all the power to one user is a water-filling candidate: equal up to rounding then)
        assert single.max() <= bounds.sum_rate * (1 + 1e-12) and bounds.sum_rate <= single.sum()
        for objective in miso.SLOT_OBJECTIVES:
            assert miso.tdma_value(single, objective) <= bounds.of(objective) * (1 + 1e-12)


def test_water_filling_meets_its_optimality_conditions():
    rng = np.random.default_rng(2)
    for _ in range(50):
        gains = 10 ** rng.uniform(-2, 2, rng.integers(1, 6))
        p = miso.water_filling(gains)
        assert p.min() >= 0 and p.sum() == pytest.approx(1.0, rel=1e-12)
        level = p + 1.0 / gains  # mu where p > 0, above mu where p = 0
        mu = level[p > 0]
        np.testing.assert_allclose(mu, mu[0], rtol=1e-12)
        assert np.all(level[p == 0] >= mu[0] * (1 - 1e-12))


def test_zero_forcing_cancels_the_interference():
    rng = np.random.default_rng(4)
    slot = random_slot(rng, n_t=4, K=3)
    H = slot.matrix(miso.random_phases(slot, rng))
    gains = np.abs(H @ miso.zf_beams(H)) ** 2
    assert np.max(gains - np.diag(np.diag(gains))) < 1e-20 * np.max(gains)
    np.testing.assert_allclose(np.sum(np.abs(miso.zf_beams(H)) ** 2), 1.0, rtol=1e-12)
    with pytest.raises(ValueError, match=r"zero-forcing needs n_t >= K antennas \(N_t = 2, K = 3"):
        miso.zf_beams(H[:, :2])


def test_a_user_across_a_ris_gets_no_surface_path_and_across_an_ios_gets_one():
    nodes = ((-100.0, -20.0), (100.0, 0.0))
    for surface, across in (("ris", 0.0), ("ios", None)):
        slot = miso.slot_channel(
            DEFAULT.replace(surface=surface, ground_nodes=nodes), ArrayConfig(n_t=2), (-50, 0)
        )
        assert np.abs(slot.coef[0]).sum() > 0  # same side as the UAV: reflection
        if across is None:
            assert np.abs(slot.coef[1]).sum() > 0
        else:
            assert np.abs(slot.coef[1]).sum() == across


def test_baselines_are_achievable_values():
    rng = np.random.default_rng(9)
    slot = random_slot(rng, n_t=2, K=3)
    bounds = miso.slot_bounds(slot)
    for objective in miso.SLOT_OBJECTIVES:
        values = miso.baselines(slot, objective, np.random.default_rng(0))
        assert set(values) == {"MRT aligned", "MRT random", "ZF aligned", "ZF random", "TDMA"}
        assert np.isnan(values["ZF aligned"]) and np.isnan(values["ZF random"])  # N_t < K
        assert all(0 < values[name] <= bounds.of(objective) for name in ("MRT aligned", "MRT random", "TDMA"))


def test_bad_inputs_name_the_field_and_the_range():
    slot = miso.slot_channel(
        DEFAULT.replace(ground_nodes=((-100.0, -20.0), (50.0, 9.0))), ArrayConfig(n_t=2), (0, 1)
    )
    H = slot.matrix(np.zeros(slot.M))
    with pytest.raises(ValueError, match=r"phases must be a finite array of shape \(6000,\)"):
        slot.matrix(np.zeros(5))
    with pytest.raises(ValueError, match=r"phases must be a finite array"):
        slot.matrix(np.full(slot.M, np.nan))
    with pytest.raises(ValueError, match=r"beams must have total power sum_k \|\|w_k\|\|\^2 in \[0, 1\]"):
        miso.sinr(H, np.ones((2, 2)))
    with pytest.raises(ValueError, match=r"beams must be a finite complex array of shape \(2, 2\)"):
        miso.sinr(H, np.ones((2, 3)) * 0.1)
    with pytest.raises(ValueError, match=r"user index k must be an integer in \[0, 1\]"):
        miso.aligned_phases(slot, 2)
    with pytest.raises(ValueError, match=r"objective must be one of \('sum', 'maxmin'\)"):
        miso.objective_value(np.ones(2), "mean")
    with pytest.raises(ValueError, match=r"position must be one horizontal position"):
        miso.slot_channel(DEFAULT, ArrayConfig(), np.zeros((2, 2)))
    with pytest.raises(TypeError, match="array must be an ArrayConfig"):
        miso.slot_channel(DEFAULT, 2, (0, 1))


def test_the_far_field_channel_matches_exact_antenna_distances():
    """Each antenna's exact distance to every element and user, the amplitudes kept: the
    per-element steering (far field per link) is within its ~k a^2 / (2 d) phase error."""
    config = DEFAULT.replace(ground_nodes=((-60.0, 20.0), (70.0, -30.0)), ios_shape=(12, 8), g_element=1e4)
    array = ArrayConfig(n_t=4, orientation_rad=0.4, steering="element")
    q = np.array([-40.0, 35.0])
    slot = miso.slot_channel(config, array, q)
    phases = np.random.default_rng(1).uniform(0, 2 * np.pi, config.M)
    k_w = 2 * np.pi / config.wavelength
    antennas = np.array([q[0], q[1], config.uav_altitude]) + np.outer(
        array.offsets * config.wavelength, array.axis
    )
    elements = element_positions(config)
    exact = np.empty((config.K, array.n_t), dtype=complex)
    for k in range(config.K):
        user = config.node_config(k)
        a = ch.element_amplitudes(user, q)[0]
        d_mk = np.linalg.norm(elements - np.array([*user.ground_node, 0.0]), axis=1)
        for n, p in enumerate(antennas):
            d_nm = np.linalg.norm(elements - p, axis=1)
            d_nk = np.linalg.norm(p - np.array([*user.ground_node, 0.0]))
            via = np.sum(a * np.exp(-1j * (k_w * (d_nm + d_mk) + phases)))
            exact[k, n] = via + ch.direct_amplitude(user, q)[0] * np.exp(-1j * k_w * d_nk)
    exact *= np.sqrt(config.eta)
    assert np.max(np.abs(slot.matrix(phases) - exact)) < 5e-3 * np.max(np.abs(exact))  # 8e-4 here
    flipped = miso.SlotChannel(slot.coef, slot.to_elements.conj(), slot.direct, False)  # the other sign
    assert np.max(np.abs(flipped.matrix(phases) - exact)) > 0.1 * np.max(np.abs(exact))


@pytest.mark.parametrize("steering", ["centre", "element"])
def test_a_paths_channels_are_each_positions(steering):
    """``slot_channels`` computes every position of a path at once (the MISO control env builds its
    episode's slots so) as ``slot_channel`` does each alone: to rounding, as the steering vectors'
    cosines are dot products of (P, 3) rows, whose summation may differ with P."""
    config = DEFAULT.replace(ios_shape=(4, 6), ground_nodes=((-100.0, -20.0), (50.0, 9.0), (-30.0, 60.0)))
    array = ArrayConfig(n_t=3, orientation_rad=0.7, steering=steering)
    path = np.array(SPOTS)
    for q, many in zip(path, miso.slot_channels(config, array, path), strict=True):
        one = miso.slot_channel(config, array, q)
        for name in ("coef", "to_elements", "direct"):
            x, y = getattr(many, name), getattr(one, name)
            assert np.allclose(x, y, rtol=1e-12, atol=1e-12 * np.abs(y).max()), name
        assert many.rank_one == one.rank_one == (steering == "centre")
    with pytest.raises(ValueError, match=r"trajectory must have shape \(K, 2\)"):
        miso.slot_channels(config, array, np.zeros((2, 3)))
