"""Per-UAV horizons in the fleet planner (``baselines.fleet``): each UAV is planned and checked over
its own slots, the bound scales each UAV's single-UAV bound by N_u / N and stays above the plan
and above random feasible separated flights, and the CLI takes ``--horizons``."""

from __future__ import annotations

import numpy as np
import pytest

from baselines import fleet
from baselines.dp_relaxed import RelaxedDP
from ios_uav_env import ScenarioConfig, check_trajectory
from ios_uav_env.model.fleet import fleet_maxmin, fleet_setup
from ios_uav_env.model.fleet_horizons import hold_flights, horizon_slots
from ios_uav_env.model.separation import flights_separated

CONFIG = ScenarioConfig(
    ground_nodes=((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0)), ios_shape=(10, 6), T=40.0,
    q0=(-200.0, 20.0), qF=(200.0, 20.0),
)  # fmt: skip
HORIZONS = [40.0, 25.0]  # UAV 1 leaves 15 s early (its lane needs 17 slots)


@pytest.fixture(scope="module")
def plan() -> fleet.FleetPlan:
    return fleet.solve(CONFIG, uavs=2, resolution=10.0, horizons=HORIZONS, polish_steps=(20.0,))


def test_each_uav_is_planned_over_its_own_slots(plan):
    _, finals, configs = fleet_setup(CONFIG, 2, horizons=HORIZONS)
    slots = horizon_slots(configs)
    assert plan.trajectories.shape == (2, CONFIG.N, 2) and plan.info["horizons"] == HORIZONS
    for c, flight, final in zip(configs, plan.trajectories, finals, strict=True):
        assert check_trajectory(c, flight[: c.N]).feasible  # at its final point by its horizon
        np.testing.assert_array_equal(flight[c.N - 1 :], np.broadcast_to(final, (CONFIG.N - c.N + 1, 2)))
    assert flights_separated(plan.trajectories, fleet.DEFAULT_SEPARATION, slots)
    assert plan.value == fleet_maxmin(CONFIG, plan.trajectories, slots=slots).value
    assert 0.0 < plan.value <= plan.upper_bound
    sca = plan.info["sca"]  # block-coordinate SCA ran, each UAV over its own slots
    assert sca is not None and sca["rounds"] >= 1
    assert sca["from"] <= sca["value"] <= plan.value


def test_the_bound_is_above_random_separated_flights_with_unequal_horizons(plan):
    starts, finals, configs = fleet_setup(CONFIG, 2, horizons=HORIZONS)
    slots = horizon_slots(configs)
    rng = np.random.default_rng(0)
    for _ in range(3):  # each UAV wobbles about its straight lane, arriving by its own horizon
        flights = []
        for s, f, n_u in zip(starts, finals, slots, strict=True):
            lane = np.linspace(s, f, n_u)
            lane[1:-1, 1] += rng.uniform(-5.0, 5.0, n_u - 2)
            flights.append(lane)
        for c, flight in zip(configs, flights, strict=True):
            assert check_trajectory(c, flight).feasible
        held = hold_flights(flights, CONFIG.N)
        assert flights_separated(held, 10.0, slots)
        assert fleet_maxmin(CONFIG, held, slots=slots).upper <= plan.upper_bound
    # UAV 1's early leave costs: the fleet with both horizons T is bounded higher
    full = fleet.fleet_bound(fleet_setup(CONFIG, 2)[2], resolution=10.0, slots=CONFIG.N)[0]
    assert plan.upper_bound < full


def test_each_uav_bound_is_scaled_by_its_share_of_the_slots():
    """At fixed weights the fleet's bound is UB_0(w) + (N_1 / N) UB_1(w), UB_u the relaxed DP of
    UAV u's own scenario; a UAV flying 2 slots adds at most 2 / N of its bound."""
    w = np.array([0.5, 0.3, 0.2])
    for horizons in ([40.0, 40.0], [40.0, 25.0]):
        _, _, configs = fleet_setup(CONFIG, 2, horizons=horizons)
        got = fleet.fleet_bound(configs, resolution=10.0, max_cuts=1, start_weights=w, slots=CONFIG.N)[0]
        each = [RelaxedDP(c, 10.0).value(w)[0] for c in configs]
        assert got == pytest.approx(each[0] + configs[1].N / CONFIG.N * each[1], rel=1e-12)
    starts = [[-200.0, 20.0], [150.0, -40.0]]  # UAV 1 hovers two slots near node 1, then leaves
    _, _, configs = fleet_setup(CONFIG, 2, starts=starts, finals=starts, horizons=[40.0, 2.0])
    got = fleet.fleet_bound(configs, resolution=10.0, max_cuts=1, start_weights=w, slots=CONFIG.N)[0]
    alone = fleet.fleet_bound(configs[:1], resolution=10.0, max_cuts=1, start_weights=w, slots=CONFIG.N)[0]
    assert alone < got <= alone + 2 / CONFIG.N * RelaxedDP(configs[1], 10.0).value(w)[0] * (1 + 1e-12)
    with pytest.raises(ValueError, match=r"slots must be an integer >= every UAV's N_u \(>= 40\)"):
        fleet.fleet_bound(configs, resolution=10.0, slots=30)


def test_equal_horizons_change_nothing():
    _, _, plain = fleet_setup(CONFIG, 2)
    _, _, same = fleet_setup(CONFIG, 2, horizons=[40.0, 40.0])
    a = fleet.fleet_bound(plain, resolution=10.0, max_cuts=3)
    b = fleet.fleet_bound(same, resolution=10.0, max_cuts=3, slots=CONFIG.N)
    assert a[0] == b[0] and np.array_equal(a[1], b[1])


def test_the_cli_takes_horizons(capsys):
    with pytest.raises(SystemExit):
        fleet.main(["--uavs", "2", "--horizons", "150", "150", "150"])
    assert "--horizons with --uavs 2: horizons must be None or 2 horizons" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        fleet.main(["--uavs", "1", "2", "--horizons", "149.5"])
    assert r"horizons[0] must be a multiple of dt = 1 s" in capsys.readouterr().err
