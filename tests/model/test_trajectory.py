"""Scoring (eq. (9)) and constraint checks (eq. (10)) of trajectories."""

import numpy as np
import pytest

from ios_uav_env import ScenarioConfig, average_rate, check_trajectory, slot_rates

CFG = ScenarioConfig(T=40.0, ios_shape=(10, 6))


def straight(cfg: ScenarioConfig) -> np.ndarray:
    t = np.linspace(0.0, 1.0, cfg.N)[:, None]
    return (1 - t) * np.asarray(cfg.q0) + t * np.asarray(cfg.qF)


def test_average_rate_is_eq9_over_all_slots():
    q = straight(CFG)
    assert average_rate(CFG, q) == pytest.approx(slot_rates(CFG, q).sum() / CFG.N, rel=1e-14)
    # both end points count: moving the first way-point changes the average
    q2 = q.copy()
    q2[0] = CFG.ground_node
    assert average_rate(CFG, q2) > average_rate(CFG, q)


def test_straight_line_is_feasible():
    report = check_trajectory(CFG, straight(CFG))
    assert report.feasible and report.worst_violation < 1e-9
    assert report.max_step == pytest.approx(800.0 / (CFG.N - 1))


def test_violations_are_measured_in_metres():
    q = straight(CFG)
    q[-1] += (0.0, 3.0)
    r = check_trajectory(CFG, q)
    assert not r.feasible and r.end_error == pytest.approx(3.0)
    assert r.worst_violation >= 3.0 and "INFEASIBLE" in str(r)
    q = straight(CFG)
    q[0] += (0.5, 0.0)
    assert check_trajectory(CFG, q).start_error == pytest.approx(0.5)
    q = np.repeat(np.asarray(CFG.q0)[None], CFG.N, axis=0)
    q[-1] = CFG.qF  # one 800 m jump
    r = check_trajectory(CFG, q)
    assert r.step_excess == pytest.approx(800.0 - CFG.D) and not r.feasible


def test_tolerance_is_one_micrometre():
    q = straight(CFG)
    q[-1] += (5e-7, 0.0)
    assert check_trajectory(CFG, q).feasible
    q[-1] += (1e-6, 0.0)
    assert not check_trajectory(CFG, q).feasible


@pytest.mark.parametrize("bad", [np.zeros((CFG.N - 1, 2)), np.zeros((CFG.N, 3)), np.full((CFG.N, 2), np.nan)])
def test_bad_trajectories_raise(bad):
    with pytest.raises(ValueError, match="trajectory"):
        average_rate(CFG, bad)
    with pytest.raises(ValueError, match="trajectory"):
        check_trajectory(CFG, bad)
