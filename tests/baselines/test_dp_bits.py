"""The DP on a STAR surface of b-bit phases (``ScenarioConfig(surface="star", star_bits=b)``, TDMA):
the grid DP on the b-bit per-slot rate maps (``channel.slot_rates``, the node's exact b-bit phases
in every slot) is the trajectory reference of the STAR flight ids with ``star_bits``. Its plan is
``score_plan``'s, it is exact against brute force on a tiny grid, the env replays it, and its
optimum orders as the phase grids nest (1 <= 2 <= 3 bits <= continuous); the planners that plan
continuous phases refuse bits, naming ``dp``."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from baselines import dp, registry
from ios_uav_env import ScenarioConfig, score_plan
from ios_uav_env.envs.single import IOSUAVEnv
from tests.baselines.test_dp import _brute_force, _tiny
from tests.tolerances import PLANNER_REL, RATE_REL

#: The paper's geometry on a short mission and a 40 x 20 surface (a few seconds per DP).
SMALL = ScenarioConfig(surface="star", T=40.0, ios_shape=(40, 20))


@pytest.mark.parametrize("bits", [1, 2, 3])
def test_the_dp_plan_is_score_plans_and_the_env_replays_it(bits):
    config = SMALL.replace(star_bits=bits)
    plan = dp.solve(config, resolution=5.0)
    score = score_plan(config, plan.trajectory)
    assert plan.feasible and score.feasible and plan.scheme == "dp"
    assert plan.info["dp_objective"] == pytest.approx(score.rate, rel=PLANNER_REL)
    assert plan.mean_rate == pytest.approx(score.rate, rel=PLANNER_REL)
    env = IOSUAVEnv(config, arrival_guard=False)
    _, info = env.reset(seed=0)
    rates = [info["rate"]]
    for a, b in itertools.pairwise(plan.trajectory):
        _, _, terminated, _, info = env.step((b - a) / config.D)
        rates.append(info["rate"])
    assert terminated and info["feasible"]
    assert float(np.mean(rates)) == pytest.approx(plan.mean_rate, rel=RATE_REL)


@pytest.mark.parametrize("bits", [1, 2])
def test_the_dp_equals_brute_force_on_a_tiny_grid(bits):
    config, resolution, margin = _tiny("star").replace(star_bits=bits), 2.5, 2.5
    _, _, rates = dp.rate_map(config, resolution, margin)
    assert rates.size < 60 and np.ptp(rates) > 0.01  # a small, non-flat problem
    expected = _brute_force(config, resolution, margin)
    plan = dp.solve(config, resolution=resolution, margin=margin)
    assert plan.info["dp_objective"] == pytest.approx(expected, rel=1e-12, abs=1e-12)
    assert plan.mean_rate == pytest.approx(expected, rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("seed", range(4))
def test_the_optimum_orders_as_the_phase_grids_nest(seed):
    """On drawn scenarios (the node on either side, either end of the flight): every grid cell's
    b-bit rate is at most its (b + 1)-bit and its continuous rate, so the DP's optima order the
    same way, one bit strictly below continuous phases."""
    rng = np.random.default_rng(seed)
    config = SMALL.replace(
        T=60.0, ground_node=(float(rng.uniform(-250.0, 250.0)), float(rng.uniform(-80.0, 80.0))),
        q0=(-400.0, float(rng.uniform(-60.0, 60.0))), qF=(400.0, float(rng.uniform(-60.0, 60.0))),
    )  # fmt: skip
    if config.ground_node[0] == 0.0:  # (off the surface plane)
        config = config.replace(ground_node=(1.0, config.ground_node[1]))
    values = [dp.solve(config.replace(star_bits=b), resolution=12.5).info["dp_objective"] for b in (1, 2, 3)]
    values.append(dp.solve(config, resolution=12.5).info["dp_objective"])
    for low, high in itertools.pairwise(values):
        assert low <= high * (1 + PLANNER_REL)
    assert values[0] < values[-1]


def test_the_continuous_phase_planners_refuse_bits_naming_dp():
    config = SMALL.replace(star_bits=2)
    handlers = {p.name for p in registry.handlers(config)}
    assert handlers == {"dp", "dp-bound", "tour", "fixed", "loiter", "hover"}
    for name in ("sca", "mpc", "dp-clairvoyant", "dp-miso"):
        with pytest.raises(registry.PlannerMismatch, match=rf"planner '{name}'.*star_bits=2.*use dp \("):
            registry.check(name, config)
    plan = registry.solve("hover", config)
    assert plan.mean_rate == pytest.approx(score_plan(config, plan.trajectory).rate, rel=PLANNER_REL)


def test_several_nodes_plan_with_a_bound_above_the_b_bit_plan():
    """K = 2 (a node on each side): dp's best plan on the b-bit maps, scored by ``score_plan``, lies
    below its certified bound (the continuous phases' relaxation, above every b-bit rate)."""
    config = SMALL.replace(ground_nodes=((-100.0, -20.0), (100.0, 30.0)), star_bits=2)
    plan = dp.solve(config, resolution=12.5)
    score = score_plan(config, plan.trajectory)
    assert score.feasible and 0 < score.rate <= plan.info["upper_bound"]
    assert plan.mean_rate == pytest.approx(score.rate, rel=PLANNER_REL)
    continuous = dp.solve(config.replace(star_bits=None), resolution=12.5)
    assert score.rate < score_plan(continuous.config, continuous.trajectory).rate
