"""Per-UAV horizons in the fleet model (``model.fleet_horizons``, ``fleet_setup``, ``fleet_maxmin``,
``flights_separated``): bad horizons are refused by rule, a UAV past its horizon serves nothing
(the pricer equals the fleet without it in those slots), contributes at most its own slots, and
is not checked for separation after it has left."""

from __future__ import annotations

import numpy as np
import pytest

from ios_uav_env import ScenarioConfig
from ios_uav_env.model.fleet import fleet_maxmin, fleet_pricer, fleet_setup, link_rates
from ios_uav_env.model.fleet_horizons import active_slots, check_slots, hold_flights, horizon_slots
from ios_uav_env.model.separation import flights_separated

CONFIG = ScenarioConfig(
    T=40.0, ios_shape=(10, 6), ground_nodes=((-100.0, -20.0), (60.0, 30.0), (-30.0, 80.0))
)
FLIGHT = np.linspace(CONFIG.q0, CONFIG.qF, CONFIG.N)
BACK = FLIGHT[::-1].copy()


@pytest.mark.parametrize(
    ("horizons", "message"),
    [
        ([40.0, 30.5], r"horizons\[1\] must be a multiple of dt = 1 s within \[2, 40\] s"),  # not whole slots
        ([41.0, 40.0], r"horizons\[0\] must be a multiple of dt = 1 s within \[2, 40\] s .*got 41.0"),
        ([40.0, 0.0], r"horizons\[1\] must be a multiple"),  # not positive
        ([40.0, -2.0], r"horizons\[1\] must be a multiple"),
        ([1.0, 40.0], r"horizons\[0\] must be a multiple of dt = 1 s within \[2, 40\] s \(2 to N = 40"),
        ([40.0, float("nan")], r"horizons\[1\] must be a multiple"),
        ([40.0, 40.0, 40.0], r"horizons must be None or 2 horizons in s \(one per UAV\)"),
        ("long", r"horizons must be None or 2 horizons"),
        ([40.0, 20.0], r"horizons\[1\] = 20 s: T=20.0 s is too short .* T must be >= 33 s"),  # unreachable
    ],
)
def test_bad_horizons_are_refused_by_rule(horizons, message):
    with pytest.raises(ValueError, match=message):
        fleet_setup(CONFIG, 2, horizons=horizons)


def test_horizons_are_each_uavs_own_scenario():
    _, _, plain = fleet_setup(CONFIG, 2)
    _, _, same = fleet_setup(CONFIG, 2, horizons=[40.0, np.float32(40.0)])
    assert same == plain and all(c.T == CONFIG.T for c in plain)  # every UAV the scenario's T
    _, _, configs = fleet_setup(CONFIG, 2, speeds=[25.0, 50.0], horizons=np.array([40.0, 18.0]))
    assert [c.T for c in configs] == [40.0, 18.0] and horizon_slots(configs).tolist() == [40, 18]
    assert configs[1] == plain[1].replace(v_max=50.0, T=18.0)
    _, _, one = fleet_setup(CONFIG, 3, speeds=50.0, horizons=np.float64(20.0))  # one for every UAV
    assert horizon_slots(one).tolist() == [20, 20, 20]


def test_the_representation_holds_a_finished_uav_at_its_final_point():
    held = hold_flights([FLIGHT, FLIGHT[:5]], CONFIG.N)
    np.testing.assert_array_equal(held[1, :5], FLIGHT[:5])
    np.testing.assert_array_equal(held[1, 5:], np.broadcast_to(FLIGHT[4], (CONFIG.N - 5, 2)))
    assert active_slots(np.array([40, 5]), CONFIG.N).sum(axis=1).tolist() == [40, 5]
    with pytest.raises(ValueError, match=r"flights\[1\] must be an \(n_u, 2\) array"):
        hold_flights([FLIGHT[:5], FLIGHT], 10)
    for bad in ([40, 0], [40, 41], [40.0, 5], [40], [True, 5]):
        with pytest.raises(ValueError, match=r"slots must be None or 2 integers in \[1, 40\]"):
            check_slots(bad, 2, CONFIG.N)
    assert check_slots(np.array([40, 5]), 2, CONFIG.N).tolist() == [40, 5]


@pytest.mark.parametrize("access", ["orthogonal", "shared"])
def test_a_uav_past_its_horizon_serves_nothing(access):
    """The pricer of two UAVs, the second flying 12 slots, is the two-UAV pricer on those slots
    plus the first UAV alone on the others (each averaged over all N); and where the second is
    held after its horizon does not matter."""
    n, n1 = CONFIG.N, 12
    both = np.stack([FLIGHT, BACK])
    price = fleet_pricer(CONFIG, both, access, slots=[n, n1])
    early = fleet_pricer(CONFIG, both[:, :n1], access)
    alone = fleet_pricer(CONFIG, FLIGHT[None, n1:], access)
    moved = both.copy()
    moved[1, n1:] = (0.0, 0.0)  # a held point anywhere: not read
    elsewhere = fleet_pricer(CONFIG, moved, access, slots=[n, n1])
    for w in np.random.default_rng(5).dirichlet(np.ones(3), size=4):
        point, value = price(w)
        want = (n1 * early(w)[1] + (n - n1) * alone(w)[1]) / n
        assert value == pytest.approx(want, rel=1e-12)
        np.testing.assert_allclose(point, (n1 * early(w)[0] + (n - n1) * alone(w)[0]) / n, rtol=1e-12)
        assert elsewhere(w)[1] == value
    short = fleet_maxmin(CONFIG, both, access=access, slots=[n, n1]).value
    assert short < fleet_maxmin(CONFIG, both, access=access).value  # it leaves early: less service


def test_a_uav_flying_one_slot_contributes_at_most_that_slot():
    """V(U0 + U1 for one slot) <= V(U0 alone) + max_k r_{1,k} / N: for any w, slot 0's best choice
    is at most U0's aligned best plus U1's aligned best, every other slot is U0's alone."""
    both = np.stack([FLIGHT, BACK])
    alone = fleet_maxmin(CONFIG, FLIGHT[None])
    got = fleet_maxmin(CONFIG, both, slots=[CONFIG.N, 1])
    r = link_rates(CONFIG, both[:, 0])
    one_slot = max(r[1, k, 1, k] for k in range(CONFIG.K)) / CONFIG.N
    assert alone.value * (1 - 1e-9) <= got.value <= (alone.upper + one_slot) * (1 + 1e-9)
    assert got.value < fleet_maxmin(CONFIG, both, slots=[CONFIG.N, 2]).value  # a second slot helps


def test_the_pricer_with_no_uav_flying_a_slot_serves_nothing_there():
    both = np.stack([FLIGHT, BACK])
    w = np.full(3, 1 / 3)
    value = fleet_pricer(CONFIG, both, slots=[10, 12])(w)[1]
    assert value == pytest.approx(
        fleet_pricer(CONFIG, both[:, :12], slots=[10, 12])(w)[1] * 12 / 40, rel=1e-12
    )


def test_separation_is_checked_only_while_both_fly():
    """UAV 1 lands at the origin at its horizon; UAV 0 crosses the origin later: separated, unless
    UAV 1 stayed (every horizon N)."""
    n = CONFIG.N
    crossing = np.linspace((-200.0, 0.0), (200.0, 0.0), n)  # through the origin at slot ~20
    landing = hold_flights([np.linspace((-100.0, 100.0), (0.0, 0.0), 8)], n)[0]
    flights = np.stack([crossing, landing])
    assert flights_separated(flights, 10.0, slots=[n, 8])
    assert not flights_separated(flights, 10.0)
    assert not flights_separated(flights, 10.0, slots=[n, 22])  # still there when UAV 0 passes
