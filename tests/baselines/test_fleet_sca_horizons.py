"""Block-coordinate SCA of a fleet whose UAVs have their own horizons (``baselines.fleet_sca``):
the schedule is the one scorer's with each UAV's slot count (a UAV past its horizon serves nothing
and is no alignment), the refined flights are feasible over each UAV's own slots, held after them,
separated while both UAVs of a pair fly (and only then), never worse than the start and under the
certified bound, and equal horizons change nothing."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

pytest.importorskip("cvxpy")

from baselines import fleet, fleet_sca  # noqa: E402
from baselines.fleet_schedule import fleet_schedule  # noqa: E402
from ios_uav_env import ScenarioConfig  # noqa: E402
from ios_uav_env.model.fleet import choice_rates, default_lanes, fleet_maxmin, fleet_setup  # noqa: E402
from ios_uav_env.model.fleet_horizons import flights_feasibility, hold_flights, horizon_slots  # noqa: E402
from ios_uav_env.model.separation import flights_separated  # noqa: E402
from tests.tolerances import SOLVER_REL  # noqa: E402

CONFIG = ScenarioConfig(
    ground_nodes=((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0)), ios_shape=(10, 6), T=40.0,
    q0=(-200.0, 20.0), qF=(200.0, 20.0),
)  # fmt: skip
HORIZONS = [40.0, 25.0]  # UAV 1 leaves 15 s early (its lane needs 17 slots)


def held_lanes(config: ScenarioConfig, horizons) -> tuple[np.ndarray, list[ScenarioConfig]]:
    """The default lanes flown straight, each over its own horizon and held at its final point."""
    starts, finals, configs = fleet_setup(config, 2, horizons=horizons)
    lanes = [np.linspace(s, f, c.N) for s, f, c in zip(starts, finals, configs, strict=True)]
    return hold_flights(lanes, config.N), configs


@pytest.mark.parametrize("access", ["orthogonal", "shared"])
@pytest.mark.parametrize("horizons", [HORIZONS, [30.0, 25.0]])  # the second: the last 10 slots no UAV flies
def test_the_schedule_with_horizons_is_the_one_scorers_and_its_choices_rebuild_it(access, horizons):
    flights, configs = held_lanes(CONFIG, horizons)
    slots = horizon_slots(configs)
    rng = np.random.default_rng(2)
    for u, n_u in enumerate(slots):
        flights[u, 1 : n_u - 1] += rng.uniform(-4.0, 4.0, (n_u - 2, 2))
    sched = fleet_schedule(CONFIG, flights, access, slots)
    assert sched.value == pytest.approx(
        fleet_maxmin(CONFIG, flights, access=access, slots=slots).value, rel=1e-9
    )
    flying = np.arange(CONFIG.N)[:, None] < slots[None, :]  # (N, U)
    assert np.all(sched.nodes[:, ~flying] == -1)  # a UAV past its horizon serves nothing
    live = flying.any(axis=1)
    assert np.all(sched.align[:, ~live] == -1) and np.all(sched.align[:, live] >= 0)
    assert np.all(flying[np.flatnonzero(live), sched.align[:, live] // CONFIG.K])  # aligned to a UAV flying
    # every column's choice per slot, time-shared by the mix, gives the schedule's rates
    choices = list(itertools.product(range(-1, CONFIG.K), repeat=2))
    rates = np.zeros(CONFIG.K)
    for j, lam in enumerate(sched.mix):
        for n in np.flatnonzero(live):
            table = choice_rates(sched.gains[n], CONFIG.eta, access)
            rates += lam * table[sched.align[j, n] * len(choices) + choices.index(tuple(sched.nodes[j, n]))]
    np.testing.assert_allclose(rates / CONFIG.N, sched.rates, rtol=1e-9)
    # the shorter horizon's schedule is worth less than the whole flights' (UAV 1 leaves early)
    assert sched.value < fleet_schedule(CONFIG, flights, access).value


@pytest.mark.parametrize("access", ["orthogonal", "shared"])
def test_refined_flights_with_horizons_are_feasible_held_separated_better_and_under_the_bound(access):
    lanes, configs = held_lanes(CONFIG, HORIZONS)
    slots = horizon_slots(configs)
    result = fleet_sca.refine(CONFIG, lanes, access=access, horizons=HORIZONS, iterations=3)
    flights = result.trajectories
    assert flights_feasibility(configs, flights)[0]
    for flight, c, start in zip(flights, configs, lanes, strict=True):
        np.testing.assert_array_equal(flight[c.N - 1 :], np.broadcast_to(start[-1], (CONFIG.N - c.N + 1, 2)))
    assert not np.array_equal(flights[1, 1 : slots[1] - 1], lanes[1, 1 : slots[1] - 1])  # UAV 1 moved
    assert flights_separated(flights, fleet.DEFAULT_SEPARATION, slots)
    assert result.start_value == fleet_maxmin(CONFIG, lanes, access=access, slots=slots).value
    assert result.value == fleet_maxmin(CONFIG, flights, access=access, slots=slots).value
    assert result.value > result.start_value * 1.05  # the straight lanes are far from optimal
    accepted = [r["value"] for r in result.history if r["accepted"]]
    assert accepted == sorted(accepted) and accepted[0] >= result.start_value
    bound = fleet.fleet_bound(configs, resolution=10.0, max_cuts=6, slots=CONFIG.N)[0]
    assert result.value <= bound


def test_a_uav_is_separated_from_another_only_while_both_fly():
    """One node at (-60, 0); UAV 1 flies 4 slots to (-60, -30), 30 m from it, and leaves; UAV 0's
    lane passes 50 m north. With d_min = 40 m, UAV 0 may hover over the node only after UAV 1 has
    left: it does, closer than d_min to UAV 1's final point, and the pair is separated while both
    fly."""
    config = ScenarioConfig(
        ground_nodes=((-60.0, 0.0),), ios_shape=(10, 6), T=30.0, q0=(-200.0, 50.0), qF=(200.0, 50.0)
    )
    starts, finals = [[-200.0, 50.0], [-100.0, -60.0]], [[200.0, 50.0], [-60.0, -30.0]]
    horizons, d_min = [30.0, 4.0], 40.0
    _, _, configs = fleet_setup(
        config, 2, starts=starts, finals=finals, min_separation=d_min, horizons=horizons
    )
    slots = horizon_slots(configs)
    lanes = hold_flights(
        [np.linspace(s, f, c.N) for s, f, c in zip(starts, finals, configs, strict=True)], config.N
    )
    result = fleet_sca.refine(
        config, lanes, min_separation=d_min, horizons=horizons, iterations=4, trust=25.0
    )  # fmt: skip
    flights = result.trajectories
    assert flights_feasibility(configs, flights)[0] and flights_separated(flights, d_min, slots)
    after = np.hypot(*(flights[0, slots[1] :] - np.asarray(finals[1])).T)
    assert after.min() < d_min - 5.0  # over the node, where the gone UAV 1 would have stopped it
    assert not flights_separated(flights, d_min)  # as if UAV 1 stayed: the pair would be too close
    assert result.value > result.start_value


def test_equal_horizons_change_nothing():
    """The scenario's T for every UAV is the default, bit for bit; the value is the one the
    refinement gave before it modelled horizons (0.5319456223385168 bps/Hz, 3 rounds), to the conic
    solver's tolerance (``SOLVER_REL``: the value goes through Clarabel's compiled linear algebra, so
    another CPU moves its last digits; a changed round or surrogate moves it by far more)."""
    lanes = np.stack([np.linspace(s, f, CONFIG.N) for s, f in zip(*default_lanes(CONFIG, 2), strict=True)])
    plain = fleet_sca.refine(CONFIG, lanes, iterations=3)
    same = fleet_sca.refine(CONFIG, lanes, horizons=[CONFIG.T, CONFIG.T], iterations=3)
    assert plain.value == same.value and np.array_equal(plain.trajectories, same.trajectories)
    assert plain.value == pytest.approx(0.5319456223385168, rel=SOLVER_REL)


def test_bad_horizons_and_unheld_flights_are_refused_by_name():
    lanes, _ = held_lanes(CONFIG, HORIZONS)
    with pytest.raises(ValueError, match=r"horizons\[1\] must be a multiple of dt = 1 s"):
        fleet_sca.refine(CONFIG, lanes, horizons=[40.0, 25.5])
    loose = lanes.copy()
    loose[1, -1] += (0.0, 5.0)  # moves again after its horizon
    with pytest.raises(ValueError, match=r"trajectories\[1\] is not a feasible flight of UAV 1 .* N_u = 25"):
        fleet_sca.refine(CONFIG, loose, horizons=HORIZONS)
    with pytest.raises(ValueError, match=r"trajectories\[1\] is not a feasible flight of UAV 1"):
        fleet_sca.refine(CONFIG, lanes, horizons=[40.0, 20.0])  # UAV 1 arrives at slot 24, not by 19
