"""The energy DP (Dinkelbach for the energy efficiency, the Lagrangian for a budget), the loiter
and hover heuristics, and ``python -m baselines --objective energy_efficiency``."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

import ios_uav_env as ie
from baselines import __main__ as cli
from baselines import dp, dp_energy, loiter
from baselines.grid import grid_axes
from ios_uav_env import ScenarioConfig

SMALL = ScenarioConfig(
    T=60.0, ios_shape=(10, 6), objective="energy_efficiency"
)  # 59 moves for 800 m: room to loiter
SMALL_RATE = SMALL.replace(objective="rate")  # the budget DP's problem: the best rate within a budget


@pytest.fixture(scope="module")
def small_ee():
    return dp_energy.solve_ee(SMALL, resolution=5.0)


def test_dinkelbach_increases_lambda_to_a_certified_stop(small_ee):
    plan = small_ee
    lams = [h["lambda"] for h in plan.history]
    assert all(b > a for a, b in itertools.pairwise(lams))  # strictly, until the stop
    assert all(h["F"] >= -1e-6 for h in plan.history)  # F(lam_k) >= 0: q_{k-1} attains 0
    assert plan.info["ee_gap"] <= 1e-9 and plan.feasible
    assert plan.energy_efficiency >= lams[-1] * (1 - 1e-12)
    assert plan.energy_efficiency == pytest.approx(ie.energy_efficiency(SMALL, plan.trajectory), rel=1e-12)


def test_dp_ee_beats_the_other_plans(small_ee):
    ee = small_ee.energy_efficiency
    rate_plan = dp.solve(SMALL_RATE, resolution=5.0).scored_on(
        SMALL
    )  # a grid path: never better (the theorem)
    assert ee >= rate_plan.energy_efficiency and rate_plan.mean_rate >= small_ee.mean_rate
    # off-grid heuristics: not a theorem at a coarse grid, but they fall short here by > 1 %
    for other in (loiter.loiter(SMALL), loiter.hover(SMALL)):
        assert other.feasible and ee > 1.01 * other.energy_efficiency, other.scheme


def test_dp_ee_equals_a_brute_force_over_a_tiny_grid():
    # 4 slots, 2 free way-points on a 7 x 3 grid (5 m): every grid path is enumerated
    config = ScenarioConfig(
        surface="none", T=4.0, v_max=10.0, q0=(0.0, 0.0), qF=(20.0, 0.0), ground_node=(10.0, 0.0),
        objective="energy_efficiency",
    )  # fmt: skip
    plan = dp_energy.solve_ee(config, resolution=5.0, margin=5.0)
    xs, ys, _ = grid_axes(config, 5.0, 5.0)
    cells = [np.array([x, y]) for y in ys for x in xs]
    best = -np.inf
    for a, b in itertools.product(cells, repeat=2):
        q = np.array([config.q0, a, b, config.qF])
        if ie.check_trajectory(config, q).feasible:
            best = max(best, ie.energy_efficiency(config, q))
    assert len(cells) == 21 and plan.energy_efficiency == pytest.approx(best, rel=1e-12)


def test_the_optimum_loiters_at_about_the_minimum_power_speed():
    plan = dp_energy.solve_ee(
        ScenarioConfig(T=90.0, ios_shape=(10, 6), objective="energy_efficiency"), resolution=5.0
    )
    speeds = np.linalg.norm(np.diff(plan.trajectory, axis=0), axis=1)
    v_mp = ie.min_power_speed()
    assert np.median(speeds) == pytest.approx(v_mp, rel=0.03)  # the 5 m grid's moves of 10 m
    assert np.count_nonzero(speeds == 0.0) == 0  # hovering costs 168 W > P(V_mp)


def test_budget_dp_respects_the_budget_and_its_rate_grows_with_it():
    rate_plan = dp.solve(SMALL_RATE, resolution=5.0)
    least = SMALL.least_energy()
    rates = []
    for frac in (0.85, 0.95, 1.0, 1.1):
        budget = max(frac * rate_plan.energy, least)
        plan = dp_energy.solve_budget(SMALL_RATE, budget, resolution=5.0)
        assert plan.feasible and plan.energy <= budget * (1 + ie.ENERGY_RTOL)
        assert plan.info["dual_bound"] >= plan.mean_rate * (1 - 1e-12) and plan.info["dual_gap"] >= -1e-12
        rates.append(plan.mean_rate)
    assert all(b >= a for a, b in itertools.pairwise(rates)) and rates[0] < rates[-1]
    assert rates[-1] == pytest.approx(rate_plan.mean_rate, rel=1e-12)  # the budget is inactive at 1.1


def test_budget_and_ee_arguments_are_checked():
    with pytest.raises(
        ValueError, match=r"energy_budget_j=None \(it maximises the rate within a budget: set one\)"
    ):
        dp_energy.solve_budget(SMALL_RATE)
    with pytest.raises(ValueError, match="tol must be a number in"):
        dp_energy.solve_ee(SMALL, resolution=5.0, tol=0.0)
    with pytest.raises(ValueError, match=r"energy_budget_j=100000 J \(it ignores an energy budget\)"):
        dp_energy.solve_ee(SMALL.replace(energy_budget_j=1e5))
    with pytest.raises(ValueError, match=r"2 ground node\(s\) \(it takes K = 1\)"):
        dp_energy.solve_ee(SMALL.replace(ground_nodes=((-100.0, -20.0), (150.0, -60.0))))
    with pytest.raises(ValueError, match="no grid path of resolution=25 m meets it"):
        dp_energy.solve_budget(SMALL_RATE, SMALL.least_energy(), resolution=25.0)


def test_loiter_beats_hover_on_the_default_scenario():
    config = ScenarioConfig()
    plan, base = loiter.loiter(config), loiter.hover(config)
    assert plan.feasible and base.feasible
    assert plan.energy_efficiency > 1.2 * base.energy_efficiency
    assert plan.info["peak"] == base.info["hover"] and plan.info["loiter_moves"] > 50
    speeds = np.linalg.norm(np.diff(plan.trajectory, axis=0), axis=1)
    assert np.isclose(speeds, ie.min_power_speed(), rtol=1e-9).sum() == plan.info["loiter_moves"]


@pytest.mark.parametrize("T", [33.0, 34.0, 40.0])
def test_loiter_is_feasible_on_tight_horizons(T):
    assert loiter.loiter(ScenarioConfig(T=T, ios_shape=(10, 6))).feasible


def test_cli_energy_efficiency(tmp_path, capsys):
    args = [
        "--objective",
        "energy_efficiency",
        "--scheme",
        "dp-ee",
        "loiter",
        "hover",
        "--T",
        "40",
        "--no-bound",
    ]
    status = cli.main([*args, "--M", "100", "--resolution", "5", "--out", str(tmp_path), "--no-plot"])
    out = capsys.readouterr().out
    assert status == 0 and "EE (bits/J)" in out
    for name in ("dp-ee", "loiter", "hover"):
        saved = json.loads((tmp_path / f"{name}_T40_M100.json").read_text())
        assert saved["scheme"] == name and saved["feasible"] and saved["energy_efficiency"] > 0
        assert f"{saved['energy_efficiency']:.2f}" in out
    with pytest.raises(SystemExit):
        cli.main(["--objective", "energy_efficiency", "--scheme", "ia", "--out", str(tmp_path)])
    assert "with --objective energy_efficiency choose from dp-ee" in capsys.readouterr().err
