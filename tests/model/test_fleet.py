"""Several UAVs in orthogonal bands sharing one surface (``model.fleet``): one UAV is the frame's
max-min schedule, a second UAV only helps, the misaligned links are the link component's rates,
and the pricer's enumeration against brute force."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from ios_uav_env import ScenarioConfig, maxmin_rate, slot_rates
from ios_uav_env.components import SingleAntennaLink
from ios_uav_env.model import channel
from ios_uav_env.model.fleet import (
    choice_rates,
    fleet_maxmin,
    fleet_pricer,
    fleet_setup,
    link_gains,
    link_rates,
    shared_slot_service,
    slot_service,
)

CONFIG = ScenarioConfig(
    T=40.0, ios_shape=(10, 6), ground_nodes=((-100.0, -20.0), (60.0, 30.0), (-30.0, 80.0))
)
FLIGHT = np.linspace(CONFIG.q0, CONFIG.qF, CONFIG.N)


def test_one_uav_is_the_frames_schedule():
    got = fleet_maxmin(CONFIG, FLIGHT[None])
    assert got.value == pytest.approx(maxmin_rate(CONFIG, FLIGHT), rel=1e-9) and got.gap <= 1e-9


def test_a_second_uav_only_helps():
    back = FLIGHT[::-1].copy()
    both = fleet_maxmin(CONFIG, np.stack([FLIGHT, back])).value
    assert both >= max(maxmin_rate(CONFIG, FLIGHT), maxmin_rate(CONFIG, back)) * (1 + 0.5)


def test_the_link_rates_are_the_link_components():
    q = FLIGHT[[3, 30]]
    r = link_rates(CONFIG, q)
    link = SingleAntennaLink()
    for us, ks, u, k in itertools.product(range(2), range(3), range(2), range(3)):
        phases = channel.phase_shifts(CONFIG.node_config(ks), q[us : us + 1])
        want = link.rates(CONFIG.node_config(k), q[u : u + 1], phases=phases)[0]
        assert r[us, ks, u, k] == pytest.approx(want, rel=1e-12)
        if (us, ks) == (u, k):  # the aligned link is the env's rate, and no alignment beats it
            assert r[us, ks, u, k] == pytest.approx(
                slot_rates(CONFIG.node_config(k), q[u : u + 1])[0], rel=1e-12
            )
        assert r[us, ks, u, k] <= r[u, k, u, k] * (1 + 1e-12)


def test_the_pricer_is_the_enumerated_maximum():
    t = np.stack([FLIGHT[:3], FLIGHT[::-1][:3]])
    price = fleet_pricer(CONFIG, t)
    w = np.array([0.5, 0.3, 0.2])
    point, bound = price(w)
    brute = 0.0
    for n in range(3):
        r = link_rates(CONFIG, t[:, n])
        brute += max(  # every alignment and every assignment of a node to each UAV
            sum(w[a[u]] * r[us, ks, u, a[u]] for u in range(2))
            for us, ks in itertools.product(range(2), range(3))
            for a in itertools.product(range(3), repeat=2)
        )
    assert bound == pytest.approx(brute / 3, rel=1e-12) and float(w @ point) == pytest.approx(
        bound, rel=1e-12
    )


def test_bad_trajectories_are_refused():
    with pytest.raises(ValueError, match=r"trajectories must be a finite \(U, N, 2\)"):
        fleet_maxmin(CONFIG, FLIGHT)


def test_slot_service_of_one_uav_is_its_shares_of_its_aligned_rates():
    q = FLIGHT[[7]]
    r = link_rates(CONFIG, q)
    shares = np.array([[0.2, 0.5, 0.3]])
    want = shares[0] * np.array([r[0, k, 0, k] for k in range(3)])
    np.testing.assert_array_equal(slot_service(r, shares, np.ones(1)), want)


def test_slot_service_is_a_point_of_the_priced_region():
    """The env's time shares give a mix of the slot's choices, so no weighting of its rates
    beats the pricer's best choice (else it would not be a point of the region)."""
    rng = np.random.default_rng(3)
    q = np.stack([FLIGHT[5], FLIGHT[::-1][9]])
    price = fleet_pricer(CONFIG, q[:, None, :])  # one slot
    r = link_rates(CONFIG, q)
    for _ in range(20):
        shares = rng.dirichlet(np.ones(3), size=2)
        beta = rng.dirichlet(np.ones(2))
        point = slot_service(r, shares, beta)
        w = rng.dirichlet(np.ones(3))
        assert w @ point <= price(w)[1] * (1 + 1e-12)
    # a surface given wholly to UAV 0, each UAV serving one node: the enumerated choice itself
    one = slot_service(r, np.eye(3)[[0, 2]], np.array([1.0, 0.0]))
    np.testing.assert_allclose(one, [r[0, 0, 0, 0], 0.0, r[0, 0, 1, 2]], rtol=1e-15)


def _enumerated_value(config, trajectories, w, access):
    """The weighted-sum price of the slots by brute force over choice_rates' table."""
    t = np.asarray(trajectories)
    tables = [choice_rates(link_gains(config, t[:, n]), config.eta, access) for n in range(t.shape[1])]
    return np.mean([np.max(table @ w) for table in tables])


def test_the_orthogonal_pricer_is_the_enumeration_with_silence_allowed():
    t = np.stack([FLIGHT[:4], FLIGHT[::-1][:4]])
    price = fleet_pricer(CONFIG, t)
    for w in np.random.default_rng(2).dirichlet(np.ones(3), size=5):
        assert price(w)[1] == pytest.approx(_enumerated_value(CONFIG, t, w, "orthogonal"), rel=1e-12)


def test_a_shared_band_choice_is_the_sinr_of_its_links():
    q = np.stack([FLIGHT[6], FLIGHT[::-1][6]])
    g = link_gains(CONFIG, q)
    np.testing.assert_allclose(np.log2(1 + CONFIG.eta * g), link_rates(CONFIG, q), rtol=1e-15)
    table = choice_rates(g, CONFIG.eta, "shared").reshape(2 * 3, 16, 3)
    choices = list(itertools.product(range(-1, 3), repeat=2))
    aligned, c = 1 * 3 + 2, choices.index((0, 2))  # surface on UAV 1's link to node 2; UAV 0 serves node 0
    gl = g[1, 2]
    eta = CONFIG.eta
    want = [
        np.log2(1 + eta * gl[0, 0] / (1 + eta * gl[1, 0])),
        0.0,
        np.log2(1 + eta * gl[1, 2] / (1 + eta * gl[0, 2])),
    ]
    np.testing.assert_allclose(table[aligned, c], want, rtol=1e-14)
    alone = choices.index((-1, 2))  # UAV 0 silent: UAV 1 is heard alone
    assert table[aligned, alone, 2] == pytest.approx(np.log2(1 + eta * gl[1, 2]), rel=1e-14)


def test_a_shared_band_is_never_better_than_bands_of_their_own():
    two = np.stack([FLIGHT, FLIGHT[::-1]])
    shared, own = fleet_maxmin(CONFIG, two, access="shared"), fleet_maxmin(CONFIG, two)
    assert shared.value <= own.value * (1 + 1e-9) and shared.gap <= 1e-9
    one = fleet_maxmin(CONFIG, FLIGHT[None], access="shared")  # no one to interfere
    assert one.value == pytest.approx(maxmin_rate(CONFIG, FLIGHT), rel=1e-9)
    with pytest.raises(ValueError, match=r"access must be one of \('orthogonal', 'shared'\)"):
        fleet_maxmin(CONFIG, two, access="common")


def test_the_shared_slot_service_is_a_point_of_the_shared_region():
    q = np.stack([FLIGHT[5], FLIGHT[::-1][9]])
    g = link_gains(CONFIG, q)
    price = fleet_pricer(CONFIG, q[:, None, :], "shared")
    rng = np.random.default_rng(4)
    for _ in range(10):
        shares, beta = rng.dirichlet(np.ones(3), size=2), rng.dirichlet(np.ones(2))
        point = shared_slot_service(g, CONFIG.eta, shares, beta)
        assert np.all(point <= slot_service(link_rates(CONFIG, q), shares, beta) * (1 + 1e-12))
        w = rng.dirichlet(np.ones(3))
        assert w @ point <= price(w)[1] * (1 + 1e-12)


def test_the_shared_slot_service_of_one_choice_is_its_sinr_rates():
    """One-hot shares and surface: the slot is one choice, each node's rate its SINR rate."""
    q = np.stack([FLIGHT[5], FLIGHT[::-1][9]])
    g = link_gains(CONFIG, q)
    shares = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # UAV 0 serves node 1, UAV 1 node 2
    got = shared_slot_service(g, CONFIG.eta, shares, np.array([0.0, 1.0]))  # surface on UAV 1's link
    table = choice_rates(g, CONFIG.eta, "shared").reshape(2 * 3, 16, 3)
    choice = list(itertools.product(range(-1, 3), repeat=2)).index((1, 2))
    np.testing.assert_allclose(got, table[1 * 3 + 2, choice], rtol=1e-14)
    assert got[1] < link_rates(CONFIG, q)[1, 2, 0, 1]  # UAV 1's signal is interference at node 1


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"uavs": 0}, "uavs must be an integer >= 1"),
        ({"uavs": 2.0}, "uavs must be an integer >= 1"),
        ({"uavs": 2, "starts": "here"}, r"starts must be a finite \(2, 2\) array"),
        ({"uavs": 2, "finals": [[200.0, 20.0], [200.0, np.nan]]}, r"finals must be a finite \(2, 2\) array"),
        ({"uavs": 2, "min_separation": -1.0}, "min_separation must be a finite number >= 0"),
        ({"uavs": 2, "access": "cdma"}, r"access must be one of \('orthogonal', 'shared'\)"),
        ({"uavs": 8, "access": "shared"}, "has 1572864 choices per slot, more than 200000"),
        ({"uavs": 2, "finals": [[200.0, 20.0], [5000.0, 0.0]]}, r"starts\[1\] / finals\[1\] / speeds: .*T"),
        ({"uavs": 2, "speeds": [25.0, 0.0]}, r"speeds must be None or 2 finite speeds > 0"),
        ({"uavs": 2, "speeds": [25.0, 5.0]}, r"starts\[1\] / finals\[1\] / speeds: .*v_max=5"),
    ],
)
def test_fleet_setup_refuses_bad_input_by_name(kwargs, message):
    with pytest.raises(ValueError, match=message):
        fleet_setup(CONFIG, **kwargs)


def test_fleet_setup_takes_numpy_numbers():
    starts, finals, configs = fleet_setup(CONFIG, np.int64(2), min_separation=np.float32(10.0))
    assert len(configs) == 2 and configs[1].q0 == (CONFIG.q0[0], CONFIG.q0[1] - 80.0)
