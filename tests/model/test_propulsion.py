"""The rotary-wing propulsion model, a plan's energy and energy efficiency, and the objective's
config fields: spot values of P(V), the two characteristic speeds, a hand-computed plan."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import ios_uav_env as ie
from ios_uav_env import PropulsionModel, ScenarioConfig, energy, energy_efficiency, propulsion_power
from ios_uav_env.benchmark.suite import SUITES, load_suite, suite_path

TABLE_I = {"P0": 79.8563, "P_i": 88.6279, "U_tip": 120.0, "v0": 4.03, "d0": 0.6, "rho": 1.225, "s": 0.05}


def hand_power(v: float) -> float:
    """Eq. (12) of Zeng, Xu, Zhang 2019 written out with the Table I constants."""
    p0, pi, u, v0 = 79.8563, 88.6279, 120.0, 4.03
    induced = pi * math.sqrt(math.sqrt(1 + v**4 / (4 * v0**4)) - v**2 / (2 * v0**2))
    return p0 * (1 + 3 * v**2 / u**2) + induced + 0.5 * 0.6 * 1.225 * 0.05 * 0.503 * v**3


def test_defaults_are_table_one():
    m = PropulsionModel()
    assert {k: getattr(m, k) for k in TABLE_I} == TABLE_I and m.A == 0.503


def test_hover_power_is_p0_plus_pi():
    assert propulsion_power(0.0) == pytest.approx(79.8563 + 88.6279, rel=1e-15)
    assert PropulsionModel().hover_power == pytest.approx(168.4842, rel=1e-15)


def test_power_at_a_hand_computed_speed():
    # V^2 = 1.5 v0^2: x = V^2 / (2 v0^2) = 3/4, sqrt(1 + x^2) - x = 5/4 - 3/4 = 1/2
    m = PropulsionModel()
    v = math.sqrt(1.5) * m.v0
    expected = m.P0 * (1 + 4.5 * m.v0**2 / m.U_tip**2) + m.P_i / math.sqrt(2) + m.drag_coefficient * v**3
    assert propulsion_power(v) == pytest.approx(expected, rel=1e-13)
    assert propulsion_power(25.0) == pytest.approx(hand_power(25.0), rel=1e-12)


def test_power_is_vectorised_and_stable_at_high_speed():
    v = np.array([[0.0, 5.0], [10.0, 300.0]])
    p = propulsion_power(v)
    assert p.shape == (2, 2)
    assert np.allclose(p.ravel()[:3], [hand_power(0.0), hand_power(5.0), hand_power(10.0)], rtol=1e-13)
    # the naive form loses the induced term to cancellation at 300 m/s; ours keeps it positive
    m = PropulsionModel()
    x = 300.0**2 / (2 * m.v0**2)
    induced = p[1, 1] - m.P0 * (1 + 3 * 300.0**2 / m.U_tip**2) - m.drag_coefficient * 300.0**3
    assert induced == pytest.approx(m.P_i / math.sqrt(2 * x), rel=1e-6)
    with pytest.raises(ValueError, match="speed"):
        propulsion_power(-1.0)


def test_minimum_power_speed_is_a_minimiser_near_ten_metres_per_second():
    v = ie.min_power_speed()
    assert v == pytest.approx(10.2, abs=0.05)  # Zeng et al. 2019: V_mp about 10.2 m/s
    assert propulsion_power(v) == pytest.approx(126.0, abs=0.05)  # below hover's 168.48 W
    for dv in (1e-3, 1e-2, 0.5):
        assert hand_power(v - dv) > hand_power(v) < hand_power(v + dv)


def test_maximum_range_speed_is_a_minimiser_of_energy_per_metre():
    v = ie.max_range_speed()
    assert v == pytest.approx(18.3, abs=0.05)  # Zeng et al. 2019: V_mr about 18.3 m/s
    per_metre = lambda s: hand_power(s) / s  # noqa: E731
    for dv in (1e-3, 1e-2, 0.5):
        assert per_metre(v - dv) > per_metre(v) < per_metre(v + dv)
    assert v > ie.min_power_speed()


def test_power_is_convex_above_the_minimum_power_speed():
    # the least-energy bound of ScenarioConfig.least_energy relies on it
    v = np.linspace(ie.min_power_speed(), 60.0, 2000)
    assert np.all(np.diff(propulsion_power(v), 2) > 0)


def _hand_plan() -> tuple[ScenarioConfig, np.ndarray]:
    config = ScenarioConfig(
        surface="none", T=4.0, q0=(0.0, 20.0), qF=(30.0, 20.0), ground_node=(0.0, 0.0), bandwidth_hz=2e6
    )
    q = np.array([[0.0, 20.0], [10.0, 20.0], [10.0, 20.0], [30.0, 20.0]])  # moves of 10, 0 and 20 m
    return config, q


def test_energy_and_energy_efficiency_of_a_hand_computed_plan():
    config, q = _hand_plan()
    e = 1.0 * (hand_power(10.0) + hand_power(0.0) + hand_power(20.0))
    assert energy(config, q) == pytest.approx(e, rel=1e-12)
    # no surface: r(q) = log2(1 + eta d^-alpha), d the 3-D UAV-G distance (z_U = 100 m, G at z = 0)
    eta = 0.1 / 1e-11
    rates = [math.log2(1 + eta * (x * x + 20.0**2 + 100.0**2) ** -2.5) for x, _ in q]
    bits = 2e6 * 1.0 * sum(rates)  # B dt sum_n R[n]
    assert energy_efficiency(config, q) == pytest.approx(bits / e, rel=1e-10)
    scored = ie.score_plan(config, q)
    assert scored.energy == pytest.approx(e, rel=1e-12) and scored.report.energy == scored.energy
    assert scored.energy_efficiency == pytest.approx(bits / e, rel=1e-10)
    assert scored.objective_value == scored.rate  # objective "rate"
    ee = ie.score_plan(config.replace(objective="energy_efficiency"), q)
    assert ee.objective_value == pytest.approx(bits / e, rel=1e-10)


def test_energy_efficiency_orders_the_surfaces_for_one_plan():
    config = ScenarioConfig(T=60.0, ios_shape=(10, 6))
    q = np.linspace(config.q0, config.qF, config.N)
    ee = {s: energy_efficiency(config.replace(surface=s), q) for s in ("ios", "ris", "none")}
    assert ee["ios"] >= ee["ris"] >= ee["none"] > 0
    assert ee["ios"] > ee["none"]


def test_several_nodes_score_the_worst_node_bits_per_joule():
    config = ScenarioConfig(T=60.0, ios_shape=(10, 6), ground_nodes=((-100.0, -20.0), (150.0, -60.0)))
    q = np.linspace(config.q0, config.qF, config.N)
    scored = ie.score_plan(config, q)
    assert scored.energy_efficiency == pytest.approx(1e6 * 60.0 * scored.rate / scored.energy, rel=1e-14)
    assert energy_efficiency(config, q) == pytest.approx(scored.energy_efficiency, rel=1e-12)


@pytest.mark.parametrize("name", list(TABLE_I) + ["A"])
@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, math.inf, True, "1"])
def test_a_bad_constant_is_refused_naming_it(name, bad):
    with pytest.raises(ValueError, match=rf"PropulsionModel\.{name} must be a finite number > 0"):
        PropulsionModel(**{name: bad})


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"bandwidth_hz": 0.0}, "bandwidth_hz must be a finite number > 0"),
        ({"bandwidth_hz": -1e6}, "bandwidth_hz must be a finite number > 0"),
        ({"bandwidth_hz": math.nan}, "bandwidth_hz"),
        ({"objective": "energy"}, r"objective must be one of \('rate', 'energy_efficiency'\)"),
        ({"energy_budget_j": 0.0}, "energy_budget_j must be None or a finite number > 0"),
        ({"energy_budget_j": math.inf}, "energy_budget_j must be None or a finite number > 0"),
        ({"propulsion": 3.0}, "propulsion must be a PropulsionModel"),
        ({"propulsion": {"P0": 80.0, "p1": 1.0}}, r"propulsion has unknown constants \['p1'\]"),
        ({"propulsion": {"v0": -4.0}}, r"PropulsionModel\.v0 must be a finite number > 0"),
    ],
)
def test_bad_objective_fields_are_refused_naming_the_field(changes, match):
    with pytest.raises(ValueError, match=match):
        ScenarioConfig(**changes)


def test_least_energy_and_the_budget_refusal():
    config = ScenarioConfig()  # 800 m in 149 moves: 5.4 m/s < V_mp, so the bound flies at V_mp
    least = 149 * hand_power(ie.min_power_speed())
    assert config.least_energy() == pytest.approx(least, rel=1e-12)
    assert config.least_energy_speed() == ie.min_power_speed()
    with pytest.raises(ValueError, match=r"energy_budget_j=.* is below the least energy .* >= 18774\.40556"):
        config.replace(energy_budget_j=0.999 * least)
    assert config.replace(energy_budget_j=least).energy_budget_j == least
    tight = ScenarioConfig(T=40.0)  # 800 m in 39 moves: 20.5 m/s, above V_mp: the straight line
    line = np.linspace(tight.q0, tight.qF, tight.N)
    assert tight.least_energy() == pytest.approx(energy(tight, line), rel=1e-12)
    # every feasible flight costs at least the bound: a fly-hover-fly and random detours
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = line + np.vstack([[0, 0], rng.normal(0, 3, (tight.N - 2, 2)), [0, 0]])
        if ie.check_trajectory(tight, q).feasible:
            assert energy(tight, q) >= tight.least_energy() * (1 - 1e-12)


def test_the_budget_enters_feasibility():
    config = ScenarioConfig(ios_shape=(10, 6))  # the line at 5.4 m/s costs more than the least energy
    line = np.linspace(config.q0, config.qF, config.N)
    e = energy(config, line)
    assert e > config.least_energy()
    assert ie.score_plan(config.replace(energy_budget_j=e), line).feasible
    over = ie.score_plan(config.replace(energy_budget_j=e * (1 - 1e-6)), line)
    assert not over.feasible and over.report.worst_violation == 0.0
    assert over.report.energy_excess == pytest.approx(e * 1e-6, rel=1e-6)
    assert "energy budget exceeded" in str(over.report)
    assert ie.score_plan(config, line).report.energy_excess == 0.0


def test_defaults_are_left_out_of_to_dict():
    d = ScenarioConfig().to_dict()
    assert not {"propulsion", "bandwidth_hz", "objective", "energy_budget_j"} & set(d)
    explicit = ScenarioConfig(propulsion=PropulsionModel(), bandwidth_hz=1e6, objective="rate")
    assert (
        explicit.to_dict() == d and explicit == ScenarioConfig() and hash(explicit) == hash(ScenarioConfig())
    )


def test_shipped_suites_configs_are_unchanged():
    for name in SUITES:
        records = json.loads(suite_path(name).read_text())["scenarios"]
        suite = load_suite(name)  # checks the file's registered hash
        for rec, scenario in zip(records, suite, strict=True):
            assert scenario.config.to_dict() == rec["config"]


def test_non_default_fields_round_trip():
    config = ScenarioConfig(
        propulsion=PropulsionModel(P0=70.0, A=0.6),
        bandwidth_hz=2e6,
        objective="energy_efficiency",
        energy_budget_j=3e4,
    )
    d = json.loads(json.dumps(config.to_dict()))
    assert d["propulsion"]["P0"] == 70.0 and d["objective"] == "energy_efficiency"
    back = ScenarioConfig.from_dict(d)
    assert back == config and hash(back) == hash(config) and isinstance(back.propulsion, PropulsionModel)
    assert config.replace(energy_budget_j=None).to_dict().keys() == d.keys() - {"energy_budget_j"}
