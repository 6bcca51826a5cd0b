"""The certified upper bound on the energy efficiency (baselines.energy_bound): its lower bounds
of the power and the move costs, the relaxation holding every plan, the bound above every plan,
Dinkelbach's stopping rule, smaller cells giving a smaller bound, inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest

import ios_uav_env as ie
from baselines import dp_energy, energy_bound, loiter
from baselines.energy_bound import (
    BOUND_SLACK,
    EnergyRelaxation,
    check_terms,
    move_cost_lower_bound,
    multipliers,
    power_slope,
    terms_power,
    tilted_power_lower_bound,
)
from baselines.fixed import fly_hover_fly, straight_line
from ios_uav_env import ScenarioConfig

# T = 24 s, q0 -> qF 200 m apart around a 10 x 6 surface with the amplitude of the default 6000
# elements: ~11 moves of transit, the rest near the rate peak.
SMALL = ScenarioConfig(
    T=24, q0=(-100.0, 20.0), qF=(100.0, 20.0), ios_shape=(10, 6), g_element=1e4, objective="energy_efficiency"
)
MARGIN = 100.0  # the planners' default box
COARSE, FINE = 25.0, 25.0 / 3.0  # D and D / 3: nested cells, one coarse cell of side D
TILTED = 5.0  # the cell side of the tests with multipliers


@pytest.fixture(scope="module")
def plans():
    """Feasible plans of SMALL: the energy DP (5 m grid), loiter, hover, line, fly-hover-fly."""
    return {
        "dp-ee": dp_energy.solve_ee(SMALL, resolution=5.0, margin=MARGIN),
        "loiter": loiter.loiter(SMALL),
        "hover": loiter.hover(SMALL),
        "line": straight_line(SMALL),
        "fhf": fly_hover_fly(SMALL),
    }


@pytest.fixture(scope="module")
def plain():
    """b = 0 at the fine cells: (the relaxation, its Dinkelbach result)."""
    relaxation = EnergyRelaxation(SMALL, FINE, MARGIN)
    return relaxation, relaxation.dinkelbach()


@pytest.fixture(scope="module")
def tilted(plans):
    """Multipliers from the energy DP's plan at TILTED: (the relaxation, its Dinkelbach result)."""
    ref = plans["dp-ee"]
    relaxation = EnergyRelaxation(SMALL, TILTED, MARGIN, multipliers(SMALL, ref))
    return relaxation, relaxation.dinkelbach(ref.energy_efficiency)


def _sampled_min(values: np.ndarray) -> np.ndarray:
    return np.min(values, axis=-1)


def test_power_lower_bounds_hold_and_are_tight():
    k = check_terms(SMALL)
    rng = np.random.default_rng(0)
    lo = rng.uniform(0.0, 30.0, 300)
    hi = lo + rng.uniform(0.0, 15.0, 300) * (rng.random(300) < 0.9)  # some degenerate intervals
    slope = rng.uniform(-15.0, 15.0, 300)
    bound = tilted_power_lower_bound(SMALL, lo, hi, slope)
    v = lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, 4001)[None, :]
    sampled = _sampled_min(terms_power(v, k) - slope[:, None] * v)
    assert np.all(bound <= sampled + 1e-9)
    assert np.all(bound >= sampled - 2e-3)  # W: within ~|I'| SPEED_TOL plus the sampling step
    # the slope of the terms is P'(V)
    vv = np.linspace(0.1, 30.0, 50)
    numeric = (terms_power(vv + 1e-6, k) - terms_power(vv - 1e-6, k)) / 2e-6
    np.testing.assert_allclose(power_slope(vv, k), numeric, rtol=1e-6, atol=1e-6)


def test_move_cost_bounds_every_move_of_its_box():
    """C(g, w, b) <= f(m) - b . (m - g) for every m of the box with |m| <= D (dense samples),
    and close to the sampled minimum."""
    rng = np.random.default_rng(1)
    d, dt = SMALL.D, SMALL.dt
    g = rng.uniform(-30.0, 30.0, (120, 2))
    w = rng.choice([1.25, 2.5, 5.0], 120)
    b = rng.uniform(-10.0, 10.0, (120, 2)) * (rng.random((120, 1)) < 0.8)  # some b = 0
    cost = move_cost_lower_bound(SMALL, g, w, b)
    t = np.linspace(-1.0, 1.0, 121)
    tx, ty = np.meshgrid(t, t)
    delta = np.column_stack([tx.ravel(), ty.ravel()])[None] * w[:, None, None]  # (M, S, 2)
    m = g[:, None, :] + delta
    r = np.linalg.norm(m, axis=2)
    f = dt * terms_power(np.minimum(r, d) / dt, check_terms(SMALL))
    values = np.where(r <= d, f - np.einsum("msj,mj->ms", delta, b), np.inf)
    sampled = _sampled_min(values)
    reachable = np.isfinite(sampled)
    np.testing.assert_array_equal(np.isfinite(cost), reachable | (cost < np.inf))
    assert np.all(cost[reachable] <= sampled[reachable] + 1e-9)
    # tight up to the sampling step (the sub-boxes stop at a sixteenth of the box)
    assert np.all(
        cost[reachable]
        >= sampled[reachable] - 0.1 * (1.0 + np.linalg.norm(b[reachable], axis=1)) * w[reachable]
    )


@pytest.mark.parametrize("kind", ["plain", "tilted"])
def test_every_plan_maps_into_the_relaxation(plans, plain, tilted, kind):
    """The image of every feasible plan is a relaxed path with no smaller rate sum and no larger
    energy bound, so U(mu) is above every plan's G_lambda / (B dt); U's recovered path adds up."""
    relaxation = (plain if kind == "plain" else tilted)[0]
    mus = [0.0, 0.9 * plans["dp-ee"].energy_efficiency / SMALL.bandwidth_hz]
    values = {mu: relaxation.value(mu) for mu in mus}
    for name, plan in plans.items():
        q = plan.trajectory
        rates, cost, states = relaxation.image(q)
        assert len(states) == SMALL.N - 2
        assert rates >= ie.slot_rates(SMALL, q).sum(), name
        assert cost <= ie.energy(SMALL, q) + 1e-9, name
        for mu, (u, path_rates, path_cost) in values.items():
            assert u >= rates - mu * cost - 1e-9, (name, mu)
            assert u == pytest.approx(path_rates - mu * path_cost, rel=1e-9, abs=1e-9)


@pytest.mark.parametrize("kind", ["plain", "tilted"])
def test_bound_is_above_every_plan_and_certified(plans, plain, tilted, kind):
    relaxation, (lam, ratio, u, records) = plain if kind == "plain" else tilted
    assert lam >= max(p.energy_efficiency for p in plans.values())
    scale = SMALL.bandwidth_hz * SMALL.dt
    assert u <= 0 and relaxation.value(lam / scale)[0] <= 0  # the certificate, again
    # Dinkelbach's stopping rule: the bound is the relaxation's root, up to BOUND_SLACK
    assert ratio <= lam <= ratio * (1 + 2 * BOUND_SLACK)
    assert relaxation.value(lam * (1 - 1e-6) / scale)[0] > 0
    # lambda rises while U > 0, each step above the ratio of the path found
    assert np.all(np.diff([r["lambda"] for r in records]) > 0)
    assert all(r["U"] > 0 for r in records[:-1]) and records[-1]["U"] <= 0
    assert all(b["lambda"] > a["path_ratio"] for a, b in zip(records, records[1:], strict=False))


def test_multipliers_tighten_the_bound(tilted):
    plain_here = EnergyRelaxation(SMALL, TILTED, MARGIN).dinkelbach()[0]
    assert tilted[1][0] < plain_here


def test_solve_returns_the_smallest_certified_bound(plans):
    ref = plans["dp-ee"]
    variants = ((1.0, 12), (0.5, 4))
    bound = energy_bound.solve(SMALL, resolution=FINE, margin=MARGIN, reference=ref, variants=variants)
    assert bound.upper_bound >= max(p.energy_efficiency for p in plans.values())
    assert bound.upper_bound <= bound.plain_bound and bound.certificate <= 0
    labels = {r["b"] for r in bound.iterations}
    assert labels == {"0", "1x12", "0.5x4"}
    finals = {label: [r for r in bound.iterations if r["b"] == label][-1]["lambda"] for label in labels}
    assert bound.upper_bound == min(finals.values()) and bound.plain_bound == finals["0"]
    winner = "0" if bound.variant is None else f"{bound.variant[0]:g}x{bound.variant[1]}"
    assert finals[winner] == bound.upper_bound
    alone = energy_bound.solve(SMALL, resolution=FINE, margin=MARGIN)
    assert alone.variant is None and alone.upper_bound == alone.plain_bound


def test_bound_decreases_towards_the_optimum_as_cells_shrink(plans, plain):
    """b = 0 and cells refined by 3 (each square a union of finer ones, the same coarse cells of
    side D): the bound cannot increase; it stays above the DP's plan and the gap shrinks."""
    dp_ee = plans["dp-ee"].energy_efficiency
    coarse = energy_bound.solve(SMALL, resolution=COARSE, margin=MARGIN).upper_bound
    fine = plain[1][0]
    assert dp_ee <= fine <= coarse * (1 + 1e-9)
    assert fine - dp_ee < 0.8 * (coarse - dp_ee)


def test_two_slots_give_the_only_plan():
    config = ScenarioConfig(
        T=2, q0=(-10.0, 20.0), qF=(10.0, 20.0), ios_shape=(10, 6), objective="energy_efficiency"
    )
    q = np.array([config.q0, config.qF])
    bound = energy_bound.solve(config)
    assert bound.upper_bound == pytest.approx(ie.energy_efficiency(config, q), rel=1e-8)
    assert bound.upper_bound >= ie.energy_efficiency(config, q)


def test_multipliers_cancel_an_oscillation():
    """The weights 1, 2, ..., 2, 1 cancel a gradient that flips every move: b = 0 along a
    back-and-forth loiter, while a straight leg keeps its gradient."""
    n = SMALL.N
    q = np.empty((n, 2))
    q[:, 1] = 20.0
    q[:8, 0] = -100.0 + 18.0 * np.arange(8)  # a straight leg at 18 m/s
    q[8:, 0] = q[7, 0] + 6.0 * (np.arange(n - 8) % 2)  # then 6 m back and forth
    b = multipliers(SMALL, q, window=4)
    k = check_terms(SMALL)
    assert b[2, 0] == pytest.approx(power_slope(18.0, k), rel=1 / 16)
    np.testing.assert_array_equal(b[12:-3], 0.0)
    np.testing.assert_array_equal(multipliers(SMALL, None), 0.0)


def test_inputs_are_checked(plans):
    with pytest.raises(ValueError, match=r"2 ground node\(s\) \(it takes K = 1\)"):
        energy_bound.solve(SMALL.replace(ground_nodes=((-100.0, -20.0), (100.0, 40.0))))
    with pytest.raises(ValueError, match="resolution"):
        energy_bound.solve(SMALL, resolution=SMALL.D + 1)
    with pytest.raises(ValueError, match="window"):
        energy_bound.solve(SMALL, reference=plans["line"], variants=((1.0, 3),))
    with pytest.raises(ValueError, match="scale"):
        energy_bound.solve(SMALL, reference=plans["line"], variants=((2.0, 12),))
    with pytest.raises(ValueError, match="reference"):
        energy_bound.solve(SMALL, reference=np.zeros((3, 2)))
    with pytest.raises(ValueError, match="start"):
        energy_bound.solve(SMALL, start=-1.0)
    with pytest.raises(RuntimeError, match="max_iters"):  # U(0) > 0: no certificate in one DP
        energy_bound.solve(SMALL, resolution=COARSE, margin=MARGIN, start=0.0, max_iters=1)
    assert math.isfinite(energy_bound.solve(SMALL, resolution=COARSE, margin=MARGIN).upper_bound)


def test_a_variant_whose_relaxed_energy_is_not_positive_is_left_out(plans, monkeypatch):
    """Multipliers far too large for the cells make a relaxed path's energy bound L <= 0: that
    variant gives no ratio, so solve leaves it out (named in ``skipped``) and the plain bound,
    certified whatever b does, stands; the relaxation itself refuses to iterate on it."""
    from baselines.energy_bound import dinkelbach

    huge = lambda config, reference, window: np.full((config.N - 1, 2), 1e6)  # noqa: E731
    monkeypatch.setattr(dinkelbach, "multipliers", huge)
    ref = plans["dp-ee"]
    bound = energy_bound.solve(SMALL, resolution=FINE, margin=MARGIN, reference=ref, variants=((1.0, 12),))
    assert bound.skipped == ((1.0, 12),) and bound.variant is None
    assert bound.upper_bound == bound.plain_bound >= ref.energy_efficiency
    with pytest.raises(dinkelbach.NonPositiveEnergy, match="energy bound L"):
        EnergyRelaxation(SMALL, FINE, MARGIN, huge(SMALL, ref, 12)).dinkelbach()
