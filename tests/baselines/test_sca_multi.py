"""SCA inside block-coordinate descent for several ground nodes."""

import numpy as np
import pytest

pytest.importorskip("cvxpy")

import ios_uav_env as ie  # noqa: E402
from baselines import sca, sca_multi, tour  # noqa: E402
from baselines.fixed import straight_line_path  # noqa: E402
from ios_uav_env import ScenarioConfig  # noqa: E402

NODES = ((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0))
SMALL = {"ios_shape": (10, 6), "quadrature_nodes": 4}


@pytest.fixture(scope="module")
def config():
    return ScenarioConfig(ground_nodes=NODES, T=50.0, **SMALL)


@pytest.fixture(scope="module")
def plan(config):
    return sca.solve(config, max_iters=15)


@pytest.fixture(scope="module")
def tour_plan(config):
    return tour.solve(config)


def test_sca_is_feasible_monotone_and_beats_the_tour(config, plan, tour_plan):
    assert plan.scheme == "ia" and plan.feasible
    assert plan.mean_rate == ie.maxmin_rate(config, plan.trajectory)
    assert plan.mean_rate >= tour_plan.mean_rate - 1e-12
    for start in {h["start"] for h in plan.history}:
        accepted = [h["score"] for h in plan.history if h["start"] == start and h["accepted"]]
        assert all(b >= a for a, b in zip(accepted, accepted[1:], strict=False)), start
    shares = np.array(plan.info["shares"])
    assert ie.scheduled_rates(config, plan.trajectory, shares).min() == pytest.approx(
        plan.mean_rate, abs=1e-12
    )
    summary = {s["start"]: s for s in plan.info["starts"]}
    assert all(s["score"] >= s["init_score"] - 1e-12 for s in summary.values())
    assert summary["tour"]["score"] > summary["tour"]["init_score"]  # SCA improves the tour here


def test_a_worse_iterate_is_never_accepted(config, tour_plan, monkeypatch):
    """The exact-score check: feed a step that returns a worse feasible trajectory."""
    line = straight_line_path(config)
    monkeypatch.setattr(sca_multi, "_step", lambda surrogate, q, shares: (line, 0.0, "optimal"))
    monkeypatch.setattr(sca_multi, "default_starts", lambda c, *given: [("tour", tour_plan.trajectory)])
    plan = sca_multi.solve(config, max_iters=3)
    assert plan.mean_rate == pytest.approx(tour_plan.mean_rate, abs=1e-12)
    assert plan.info["starts"][0]["stop"] == "decrease"
    assert [h["accepted"] for h in plan.history] == [True, False]


@pytest.mark.parametrize("surface", ["ris", "none"])
def test_other_surfaces_two_nodes(surface):
    c = ScenarioConfig(ground_nodes=NODES[:2], T=60.0, surface=surface, **SMALL)
    plan = sca.solve(c, max_iters=5)
    assert plan.feasible and plan.scheme == {"ris": "ra", "none": "cuc"}[surface]
    assert plan.mean_rate >= tour.solve(c).mean_rate - 1e-12


def test_bad_arguments(config):
    with pytest.raises(ValueError, match="K >= 2"):
        sca_multi.solve(ScenarioConfig(T=40.0, **SMALL))
    with pytest.raises(ValueError, match="init\\[0\\] must be a feasible"):
        sca_multi.solve(config, init=np.zeros((config.N, 2)))
