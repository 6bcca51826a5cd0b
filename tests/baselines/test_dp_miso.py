"""The multi-antenna UAV's DP (``dp-miso``): the grid optimum of the closed-form rate map, exact against
brute force, feasible, scored by ``score_plan``, above the fixed flights and the peak heuristics,
``dp``'s plan for one antenna and never lower for more antennas."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from baselines import dp, registry
from baselines.fixed import fly_hover_fly, straight_line
from baselines.loiter import hover, loiter
from baselines.registry import PlannerMismatch
from ios_uav_env import IOSUAVEnv, ScenarioConfig, score_plan
from tests.baselines.test_dp import _brute_force, _tiny

SMALL = ScenarioConfig(T=40, ios_shape=(10, 6), antennas=4)


@pytest.mark.parametrize("antennas", [2, 8])
def test_dp_miso_equals_brute_force_on_tiny_grid(antennas: int) -> None:
    config, resolution, margin = _tiny().replace(antennas=antennas), 2.5, 2.5
    _, _, rates = dp.rate_map(config, resolution, margin)
    assert rates.size < 60 and np.ptp(rates) > 0.01  # a small, non-flat problem
    expected = _brute_force(config, resolution, margin)
    plan = dp.solve_miso(config, resolution=resolution, margin=margin)
    assert plan.info["dp_objective"] == pytest.approx(expected, rel=1e-12, abs=1e-12)
    assert plan.mean_rate == pytest.approx(expected, rel=1e-12, abs=1e-12) and plan.feasible


def test_the_plan_is_feasible_and_scored_by_score_plan() -> None:
    plan = registry.solve("dp-miso", SMALL, resolution=5.0)
    score = score_plan(SMALL, plan.trajectory)
    assert plan.scheme == "dp-miso" and plan.config == SMALL and score.feasible
    assert plan.mean_rate == score.rate and abs(plan.info["dp_objective"] - score.rate) <= 1e-9


def test_the_plan_beats_the_fixed_flights_and_the_peak_heuristics() -> None:
    """On a horizon with room to detour (T = 60 s: 32 of 59 moves needed). On a tight one the grid's
    diagonal moves, shorter than D, can leave the grid optimum below a continuous heuristic (the
    loiter flight beats ``dp``'s 2.5 m grid at T = 40 s, with one antenna as with four)."""
    config = SMALL.replace(T=60.0)
    plan = dp.solve_miso(config, resolution=2.5)
    for other in (straight_line(config), fly_hover_fly(config), hover(config), loiter(config)):
        assert other.config == config and other.feasible
        assert plan.mean_rate >= other.mean_rate, other.scheme
    assert plan.mean_rate > straight_line(config).mean_rate + 0.1


def test_one_antenna_is_dps_plan_and_more_antennas_never_lower_the_optimum() -> None:
    """Doubling N_t never lowers a slot's rate (``channel.aligned_gain``), so neither the optimum."""
    one = SMALL.replace(antennas=1)
    base = dp.solve(one, resolution=5.0)
    same = dp.solve_miso(one, resolution=5.0)
    assert np.array_equal(same.trajectory, base.trajectory) and same.mean_rate == base.mean_rate
    values = [dp.solve_miso(SMALL.replace(antennas=n), resolution=5.0).mean_rate for n in (1, 2, 4, 8)]
    assert all(b > a + 0.1 for a, b in itertools.pairwise(values))


def test_the_env_replays_the_plan() -> None:
    """Flown in the multi-antenna env (no arrival guard), the plan gets its rate, slot by slot."""
    plan = dp.solve_miso(SMALL, resolution=5.0)
    env = IOSUAVEnv(SMALL, arrival_guard=False)
    _, info = env.reset(seed=0)
    for a, b in itertools.pairwise(plan.trajectory):
        _, _, terminated, _, info = env.step((b - a) / SMALL.D)
    assert terminated and info["feasible"]
    assert info["average_rate"] == pytest.approx(plan.mean_rate, rel=1e-9)


def test_the_registry_routes_the_antennas() -> None:
    with pytest.raises(
        PlannerMismatch, match=r"planner 'dp' .*antennas=4.*use dp-miso \(baselines\.dp:solve_miso\)"
    ):
        dp.solve(SMALL, resolution=5.0)
    with pytest.raises(PlannerMismatch, match=r"planner 'dp-miso' .*2 ground node\(s\) \(it takes K = 1\)"):
        dp.solve_miso(SMALL.replace(ground_nodes=((-100.0, -20.0), (60.0, 30.0))), resolution=5.0)
    assert {p.name for p in registry.handlers(SMALL)} == {"dp-miso", "fixed", "loiter", "hover"}
