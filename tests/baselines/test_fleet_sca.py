"""Block-coordinate SCA of a fleet's flights (``baselines.fleet_sca``): block 1 is the one scorer's
schedule, the refined flights are feasible and separated, the value never decreases and stays under
the certified bound, a poor start is improved, the separation's restriction holds against an
objective that pushes two UAVs together, and bad input is refused by name."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

pytest.importorskip("cvxpy")

from baselines import fleet, fleet_sca  # noqa: E402
from baselines.fleet_schedule import fleet_schedule  # noqa: E402
from ios_uav_env import ScenarioConfig, check_trajectory  # noqa: E402
from ios_uav_env.model.fleet import choice_rates, default_lanes, fleet_maxmin, fleet_setup  # noqa: E402
from ios_uav_env.model.separation import flights_separated  # noqa: E402

CONFIG = ScenarioConfig(
    ground_nodes=((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0)), ios_shape=(10, 6), T=40.0,
    q0=(-200.0, 20.0), qF=(200.0, 20.0),
)  # fmt: skip


def straight(config: ScenarioConfig, starts: np.ndarray, finals: np.ndarray) -> np.ndarray:
    return np.stack([np.linspace(s, f, config.N) for s, f in zip(starts, finals, strict=True)])


@pytest.fixture(scope="module")
def lanes() -> np.ndarray:
    """The default lanes flown straight: feasible, separated and far from every node's optimum."""
    return straight(CONFIG, *default_lanes(CONFIG, 2))


@pytest.fixture(scope="module")
def refined(lanes) -> fleet_sca.Refinement:
    return fleet_sca.refine(CONFIG, lanes, iterations=3)


@pytest.mark.parametrize("access", ["orthogonal", "shared"])
def test_block_one_is_the_one_scorers_schedule_and_its_choices_rebuild_it(lanes, access):
    rng = np.random.default_rng(1)
    flights = lanes.copy()
    flights[:, 1:-1] += rng.uniform(-5.0, 5.0, flights[:, 1:-1].shape)
    sched = fleet_schedule(CONFIG, flights, access)
    exact = fleet_maxmin(CONFIG, flights, access=access)
    assert sched.value == pytest.approx(exact.value, rel=1e-9)
    # every column's recorded choice per slot, time-shared by the mix, gives the schedule's rates
    choices = list(itertools.product(range(-1, CONFIG.K), repeat=2))
    rates = np.zeros(CONFIG.K)
    for j, lam in enumerate(sched.mix):
        for n, gains in enumerate(sched.gains):
            table = choice_rates(gains, CONFIG.eta, access)
            rates += lam * table[sched.align[j, n] * len(choices) + choices.index(tuple(sched.nodes[j, n]))]
    np.testing.assert_allclose(rates / CONFIG.N, sched.rates, rtol=1e-9)
    assert sched.dual.shape == (CONFIG.K,) and sched.dual.sum() == pytest.approx(1.0)


def test_refined_flights_are_feasible_separated_better_and_under_the_bound(lanes, refined):
    _, _, configs = fleet_setup(CONFIG, 2)
    for c, flight in zip(configs, refined.trajectories, strict=True):
        assert check_trajectory(c, flight).feasible
    assert flights_separated(refined.trajectories, fleet.DEFAULT_SEPARATION)
    assert refined.start_value == fleet_maxmin(CONFIG, lanes).value
    assert refined.value == fleet_maxmin(CONFIG, refined.trajectories).value
    assert refined.value > refined.start_value * 1.05  # the straight lanes are far from optimal
    bound = fleet.fleet_bound(configs, resolution=10.0, max_cuts=6)[0]
    assert refined.value <= bound


def test_the_value_never_decreases_along_the_accepted_steps(refined):
    accepted = [r["value"] for r in refined.history if r["accepted"]]
    assert accepted and accepted == sorted(accepted) and accepted[0] >= refined.start_value
    assert all(r["value"] is None or r["accepted"] or r["value"] < v for r, v in _before(refined))


def _before(result: fleet_sca.Refinement) -> list[tuple[dict, float]]:
    """Each step with the value it started from."""
    out, value = [], result.start_value
    for record in result.history:
        out.append((record, value))
        if record["accepted"]:
            value = record["value"]
    return out


def test_a_worse_step_is_never_accepted(lanes, monkeypatch):
    """Every step proposes the UAV's lane bent 60 m south (both lanes pass north of two nodes and
    south of the third): feasible and separated, but worse for either UAV and both, so the start
    comes back unchanged."""
    worse = lanes.copy()
    worse[:, 1:-1, 1] -= 60.0 * np.sin(np.linspace(0, np.pi, CONFIG.N))[1:-1]
    for u in range(2):
        trial = lanes.copy()
        trial[u] = worse[u]
        assert fleet_maxmin(CONFIG, trial).value < fleet_maxmin(CONFIG, lanes).value
    assert all(check_trajectory(c, f).feasible for c, f in zip(fleet_setup(CONFIG, 2)[2], worse, strict=True))

    def away(config, uav, sched, u, flights, *args):
        return worse[u], 1.0, "optimal"

    monkeypatch.setattr(fleet_sca, "_step", away)
    result = fleet_sca.refine(CONFIG, lanes, iterations=2)
    assert result.value == result.start_value and np.array_equal(result.trajectories, lanes)
    assert result.stop == "no step accepted" and not any(r["accepted"] for r in result.history)


def test_two_uavs_drawn_to_one_node_keep_the_separation():
    """One node between two lanes 100 m apart: both UAVs want to hover over it, so the objective
    pushes them together; the separation's half-planes stop them at d_min (no step fails the
    check), and they end up pressed against it."""
    config = ScenarioConfig(
        ground_nodes=((-60.0, 0.0),), ios_shape=(10, 6), T=30.0, q0=(-200.0, 0.0), qF=(200.0, 0.0)
    )
    starts, finals = np.array([[-200.0, 50.0], [-200.0, -50.0]]), np.array([[200.0, 50.0], [200.0, -50.0]])
    d_min = 40.0
    result = fleet_sca.refine(config, straight(config, starts, finals), min_separation=d_min, iterations=4)
    assert flights_separated(result.trajectories, d_min)
    assert not any("not separated" in r["status"] for r in result.history)
    gaps = np.hypot(*(result.trajectories[0] - result.trajectories[1]).T)
    assert gaps.min() < d_min + 1.0  # pressed against the separation, not kept away by the start
    assert result.value > result.start_value


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"iterations": -1}, "iterations must be an integer >= 0"),
        ({"iterations": 1.5}, "iterations must be an integer >= 0"),
        ({"tol": 0.0}, r"tol must be a number in \(0, 1\)"),
        ({"trust": 0.0}, "trust must be a finite number > 0"),
        ({"tiles": 0}, "tiles must be an integer >= 1"),
        ({"access": "tdma"}, "access must be one of"),
        ({"min_separation": 200.0}, "starts: UAVs 0 and 1 are 80 m apart"),
        ({"speeds": [25.0, -1.0]}, "speeds must be None or 2 finite speeds > 0"),
    ],
)
def test_bad_arguments_are_refused_by_name(lanes, kwargs, message):
    with pytest.raises(ValueError, match=message):
        fleet_sca.refine(CONFIG, lanes, **kwargs)


def test_bad_flights_are_refused_by_name(lanes):
    with pytest.raises(TypeError, match="config must be a ScenarioConfig"):
        fleet_sca.refine("config", lanes)
    with pytest.raises(ValueError, match=r"trajectories must be a finite \(U, N=40, 2\) array"):
        fleet_sca.refine(CONFIG, lanes[:, :-1])
    jump = lanes.copy()
    jump[1, 20, 1] += 40.0  # beyond the 25 m a slot allows
    with pytest.raises(ValueError, match=r"trajectories\[1\] is not a feasible flight of UAV 1"):
        fleet_sca.refine(CONFIG, jump)
    meet = lanes.copy()
    meet[1, 20] = meet[0, 20] + (3.0, 0.0)
    with pytest.raises(ValueError, match="not separated by min_separation = 10 m"):
        fleet_sca.refine(CONFIG, meet, speeds=100.0)
    with pytest.raises(ValueError, match="sca_iterations must be an integer >= 0"):
        fleet.solve(CONFIG, sca_iterations=-1)


def test_zero_iterations_return_the_start(lanes):
    result = fleet_sca.refine(CONFIG, lanes, iterations=0)
    assert (
        result.rounds == 0
        and result.value == result.start_value
        and np.array_equal(result.trajectories, lanes)
    )


def test_a_shared_band_is_refined_with_its_interference(lanes):
    """The same lanes in one shared band: the value is the shared band's (interference from the
    fixed UAVs a constant per slot in each step), it rises, and stays at most the orthogonal one."""
    result = fleet_sca.refine(CONFIG, lanes, access="shared", iterations=2)
    assert result.value == fleet_maxmin(CONFIG, result.trajectories, access="shared").value
    assert result.value > result.start_value
    assert result.value <= fleet_maxmin(CONFIG, result.trajectories).value * (1 + 1e-9)
    assert flights_separated(result.trajectories, fleet.DEFAULT_SEPARATION)
