"""The energy suite kind: a tiny suite frozen by ``python -m baselines.references energy --quick``
loads, its checks refuse a tampered file, and a policy or a plan file is scored on it by the
same ``evaluate`` / ``score_trajectories`` as % of the energy DP's EE and of the EE bound."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from baselines import loiter
from ios_uav_env import score_plan
from ios_uav_env.benchmark import SUITES, evaluate, load_suite, reference_results, score_trajectories
from ios_uav_env.benchmark.results import METRICS
from ios_uav_env.envs.policies import HoverAt
from ios_uav_env.envs.registration import ENERGY_IDS, RANDOM_ENV_ID
from tests.benchmark.quick_suites import freeze_quick, tampered
from tests.tolerances import PLANNER_REL


@pytest.fixture(scope="module")
def frozen(tmp_path_factory) -> Path:
    return freeze_quick(tmp_path_factory, "energy")


@pytest.fixture(scope="module")
def suite(frozen):
    return load_suite(frozen)


def test_the_quick_suite_loads_as_an_energy_suite(suite):
    assert suite.kind == "energy" and suite.energy and not suite.multi_node
    assert suite.normalizer == "dp" and suite.env_id in ENERGY_IDS
    assert suite.references == ("dp", "sca", "bound", "loiter", "hover")
    (s,) = suite.scenarios
    assert s.config.objective == "energy_efficiency" and s.config.K == 1 and s.config.T <= 45
    ub = s.value("bound")
    for r in ("dp", "sca", "loiter", "hover"):
        ref = s.reference[r]
        assert 0 < s.value(r) <= ub and ref["feasible"], r
        # each stored EE is B T R / E of the stored rate and energy
        assert s.value(r) == pytest.approx(s.config.bandwidth_hz * s.config.T * ref["rate"] / ref["energy"])
    assert s.value("sca") >= s.value("dp")  # SCA-EE starts from the DP plan and is monotone
    with pytest.raises(KeyError, match="bound is on EE"):
        s.rate("bound")


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (
            lambda d: d["scenarios"][0]["bound"].update(
                upper_bound=d["scenarios"][0]["sca"]["energy_efficiency"] * 0.99
            ),
            "bound.upper_bound .* is below sca",
        ),  # fmt: skip
        (lambda d: d.update(normalizer="sca"), r"energy suite must be one of \['dp'\], got 'sca'"),
        (lambda d: d.update(env_id=RANDOM_ENV_ID), "env_id of a energy suite must be one of"),
        (
            lambda d: d["scenarios"][0]["hover"].update(energy_efficiency=0.0),
            r"hover.energy_efficiency .* > 0",
        ),
        (lambda d: d["scenarios"][0]["config"].update(objective="rate"), "objective 'energy_efficiency'"),
        (lambda d: d.update(references=["dp", "sca", "loiter", "hover"]), "references of a energy suite"),
    ],
)
def test_the_checks_refuse_a_tampered_file(frozen, tmp_path, change, match):
    with pytest.raises(ValueError, match=match):
        load_suite(tampered(frozen, tmp_path, change))


def test_a_policy_is_scored_as_a_percentage_of_the_dp_energy_efficiency(suite):
    results = evaluate(HoverAt("peak"), suite)
    (r,) = results.scenarios
    s = suite[0]
    score = score_plan(s.config, r.trajectory)
    assert r.feasible and r.energy_efficiency == score.energy_efficiency == score.objective_value
    assert r.energy == score.energy and r.rate == score.rate
    assert r.pct_dp == pytest.approx(100 * score.energy_efficiency / s.value("dp"), rel=1e-12)
    assert r.pct_bound == pytest.approx(100 * score.energy_efficiency / s.value("bound"), rel=1e-12)
    assert 0 < r.pct_bound < 100  # a feasible plan never reaches the certified bound
    # the score is of the EE, not of the rate: hovering has the higher rate, the lower EE
    assert r.pct_dp < 100 < 100 * r.rate / s.reference["dp"]["rate"]
    a = results.aggregate
    assert (a.mean_pct_dp, a.p10_pct_dp, a.min_pct_dp) == (r.pct_dp,) * 3
    assert a.mean_energy_efficiency == r.energy_efficiency and a.feasible == 1
    assert set(r.to_dict()) == set(METRICS["energy"].columns())
    assert "% of DP mean" in results.summary() and "EE (bits/J)" in results.markdown()
    # the batched env, every scenario at once: the same plan and score
    at_once = evaluate(HoverAt("peak"), suite, at_once=True, batched=False)
    assert at_once.scenarios[0].energy_efficiency == pytest.approx(r.energy_efficiency, rel=1e-12)


def test_an_infeasible_plan_scores_zero_and_a_stored_plan_its_stored_share(suite):
    s = suite[0]
    straight = np.linspace(s.config.q0, s.config.qF, s.config.N)
    off = straight.copy()
    off[-1] += 50.0  # misses qF
    res = score_trajectories({0: off}, suite)
    assert not res.scenarios[0].feasible and res.scenarios[0].pct_dp == 0.0
    assert res.scenarios[0].energy_efficiency > 0  # still reported
    # the hover heuristic's plan, re-planned, scores the share the suite stores for it
    plan = loiter.hover(s.config)
    (r,) = score_trajectories({0: plan.trajectory}, suite).scenarios
    assert r.pct_dp == pytest.approx(100 * s.value("hover") / s.value("dp"), rel=PLANNER_REL)
    for name, pct in (("dp", 100.0), ("bound", 100.0)):
        ref = reference_results(suite, name).scenarios[0]
        assert getattr(ref, f"pct_{name}") == pytest.approx(pct, rel=1e-15)
        assert ref.energy_efficiency == s.value(name)
    assert math.isnan(reference_results(suite, "bound").scenarios[0].rate)


def test_the_rate_suites_are_unchanged():
    for name, kind, normalizer in (
        ("single-node-v1", "single-node", "dp"),
        ("multi-node-v1", "multi-node", "sca"),
    ):
        s = load_suite(name)
        assert s.sha256 == SUITES[name].sha256 and s.kind == kind and not s.energy
        assert s.normalizer == normalizer and s[0].value(normalizer) == s[0].rate(normalizer)
    assert not METRICS["single-node"].energy and not METRICS["multi-node"].energy
    assert "energy-v1" not in SUITES or load_suite("energy-v1").kind == "energy"
