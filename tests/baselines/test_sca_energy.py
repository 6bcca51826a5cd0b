"""SCA for the energy efficiency (baselines.sca_energy): feasible, monotone, scored by the model,
the surrogate a lower bound, Dinkelbach's update and stopping rule, the slack's identity, inputs."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("cvxpy")

import ios_uav_env as ie  # noqa: E402
from baselines import dp_energy, sca_energy  # noqa: E402
from baselines.energy_bound import check_terms, induced_ratio, terms_power  # noqa: E402
from baselines.fixed import straight_line  # noqa: E402
from ios_uav_env import ScenarioConfig  # noqa: E402

# T = 40 s, q0 -> qF 300 m apart around a 10 x 6 surface with the amplitude of the default 6000
# elements (as tests/baselines/test_sca.py): ~16 moves of transit at the maximum-range speed, the
# rest near the rate peak, where the best plan loiters.
TINY = ScenarioConfig(
    T=40, q0=(-150.0, 20.0), qF=(150.0, 20.0), ios_shape=(10, 6), g_element=1e4, objective="energy_efficiency"
)
ITERS = 10


@pytest.fixture(scope="module")
def runs():
    """Per surface: the energy DP's plan on a 5 m grid and SCA from it, every iterate recorded."""
    out = {}
    for surface in ("ios", "ris", "none"):
        config = TINY.replace(surface=surface)
        start = dp_energy.solve_ee(config, resolution=5.0)
        out[surface] = (start, sca_energy.solve(config, init=start, max_iters=ITERS, record_iterates=True))
    return out


def _solves(plan):
    return [h for h in plan.history if h["iteration"] > 0]


@pytest.mark.parametrize("surface", ["ios", "ris", "none"])
def test_plan_and_every_iterate_are_feasible_and_scored_by_the_model(runs, surface):
    _, plan = runs[surface]
    config = plan.config
    assert plan.scheme == {"ios": "ia-ee", "ris": "ra-ee", "none": "cuc-ee"}[surface]
    assert plan.feasible
    np.testing.assert_array_equal(plan.trajectory[[0, -1]], [config.q0, config.qF])
    scored = ie.score_plan(config, plan.trajectory)
    assert plan.energy_efficiency == scored.energy_efficiency
    assert plan.energy == pytest.approx(ie.energy(config, plan.trajectory), rel=1e-12)
    for h in plan.history:  # every recorded iterate, re-scored independently
        q = np.asarray(h["trajectory"])
        again = ie.score_plan(config, q)
        assert h["energy_efficiency"] == pytest.approx(again.energy_efficiency, rel=1e-12)
        assert h["mean_rate"] == pytest.approx(again.rate, rel=1e-12)
        if h["accepted"]:
            assert again.feasible, (h["iteration"], again.report)


@pytest.mark.parametrize("surface", ["ios", "ris", "none"])
def test_accepted_ee_never_decreases_and_beats_the_start(runs, surface):
    start, plan = runs[surface]
    accepted = [h["energy_efficiency"] for h in plan.history if h["accepted"]]
    assert len(accepted) >= 3
    assert np.all(np.diff(accepted) >= -1e-12 * accepted[0])
    assert accepted[0] == start.energy_efficiency
    # off the DP's grid SCA does strictly better than the grid's optimum it started from
    assert plan.energy_efficiency > start.energy_efficiency * (1 + 1e-4)
    assert plan.energy_efficiency == max(accepted)


@pytest.mark.parametrize("surface", ["ios", "ris", "none"])
def test_surrogate_bounds_the_dinkelbach_objective_from_below(runs, surface):
    """At each solve: G_lambda(q^l) = 0 <= surrogate optimum <= G_lambda(q^(l+1)) (scaled by
    B dt N; lambda = EE(q^l) with one SCA step per lambda), to the solver's accuracy."""
    _, plan = runs[surface]
    for h in _solves(plan):
        scale = h["mean_rate"]
        assert h["surrogate"] >= -1e-7 * scale, h
        assert h["surrogate"] <= h["objective"] + 1e-7 * scale, h
        # the recorded objective is the model's G_lambda / (B dt N) of the new iterate
        config = plan.config
        expected = h["mean_rate"] - h["lambda"] * h["energy"] / (config.bandwidth_hz * config.T)
        assert h["objective"] == pytest.approx(expected, rel=1e-12, abs=1e-15)


def test_dinkelbach_update_and_stopping_rule():
    """lambda is the EE of the last accepted iterate; the start stops when the relative EE gain
    of a step, (EE - lambda) / lambda, falls below tol (or no step improves)."""
    config = TINY
    start = dp_energy.solve_ee(config, resolution=5.0)
    tol = 1e-3
    plan = sca_energy.solve(config, init=start, tol=tol, max_iters=60)
    solves = _solves(plan)
    assert plan.info["starts"][0]["stop"] == "converged"
    last_ee = start.energy_efficiency
    for h in solves:
        assert h["lambda"] == last_ee  # Dinkelbach's update, before this solve
        if h["accepted"]:
            assert h["residual"] == pytest.approx(
                (h["energy_efficiency"] - h["lambda"]) / h["lambda"], rel=1e-12
            )
            last_ee = h["energy_efficiency"]
    final = solves[-1]
    assert (final["accepted"] and final["residual"] < tol) or not final["accepted"]
    assert all(h["residual"] >= tol for h in solves[:-1] if h["accepted"])
    tighter = sca_energy.solve(config, init=start, tol=tol / 10, max_iters=60)
    assert tighter.energy_efficiency >= plan.energy_efficiency


def test_the_slack_identity_and_the_terms_of_the_model():
    """y(V)^2 = sqrt(1 + V^4 / (4 v0^4)) - V^2 / (2 v0^2) satisfies 1 / y^2 = y^2 + V^2 / v0^2
    (Zeng-Xu-Zhang's slack), and P(V) by terms is the model's propulsion_power."""
    k = check_terms(TINY)
    v = np.linspace(0.0, 40.0, 81)
    y = induced_ratio(v, k["v0"])
    np.testing.assert_allclose(1.0 / y**2, y**2 + (v / k["v0"]) ** 2, rtol=1e-12)
    direct = np.sqrt(np.sqrt(1.0 + v**4 / (4.0 * k["v0"] ** 4)) - v**2 / (2.0 * k["v0"] ** 2))
    np.testing.assert_allclose(y[:20], direct[:20], rtol=1e-12)  # (cancellation beyond)
    np.testing.assert_allclose(terms_power(v, k), ie.propulsion_power(v, TINY.propulsion), rtol=1e-13)
    assert terms_power(0.0, k) == pytest.approx(k["p0"] + k["pi"], rel=1e-15)


def test_default_starts_are_the_loiter_and_the_coarse_energy_dp():
    starts = dict(sca_energy.default_starts(TINY))
    assert set(starts) == {"loiter", "dp5"}
    for q in starts.values():
        assert ie.check_trajectory(TINY, q).feasible


def test_inputs_are_checked():
    line = straight_line(TINY)
    with pytest.raises(ValueError, match=r"2 ground node\(s\) \(it takes K = 1\)"):
        sca_energy.solve(TINY.replace(ground_nodes=((-100.0, -20.0), (100.0, 40.0))), init=line)
    with pytest.raises(ValueError, match="energy_budget_j"):
        sca_energy.solve(TINY.replace(energy_budget_j=1e6), init=line)
    with pytest.raises(ValueError, match="inner_iters"):
        sca_energy.solve(TINY, init=line, inner_iters=0)
    with pytest.raises(ValueError, match="tol"):
        sca_energy.solve(TINY, init=line, tol=0.0)
    bad = line.trajectory.copy()
    bad[5] += 100.0
    with pytest.raises(ValueError, match="feasible"):
        sca_energy.solve(TINY, init=bad)
