"""The one scorer of a plan, for any K: ios_uav_env.score_plan."""

import math

import numpy as np
import pytest

import ios_uav_env as ie
from ios_uav_env import ScenarioConfig, score_plan

NODES = ((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0))
SMALL = {"ios_shape": (10, 6), "T": 60.0}


def _line(config):
    return np.linspace(config.q0, config.qF, config.N)


def test_one_node_is_eq_9_exactly_and_needs_no_schedule():
    c = ScenarioConfig(**SMALL)
    q = _line(c)
    s = score_plan(c, q)
    assert s.rate == s.best_schedule_rate == ie.average_rate(c, q)
    assert s.own_shares and s.best is None and s.feasible == ie.check_trajectory(c, q).feasible
    with pytest.raises(ValueError, match="shares are for K > 1"):
        score_plan(c, q, np.ones((1, c.N)))


def test_several_nodes_own_shares_and_best_schedule():
    c = ScenarioConfig(ground_nodes=NODES, **SMALL)
    q = _line(c)
    equal = np.full((3, c.N), 1 / 3)
    own = score_plan(c, q, equal)
    assert own.rate == ie.scheduled_rates(c, q, equal).min() and own.own_shares
    assert own.best_schedule_rate == ie.maxmin_rate(c, q) > own.rate  # equal shares are not the best
    np.testing.assert_array_equal(own.best.shares, ie.best_schedule(c, q))
    best = score_plan(c, q)  # a plan given without shares: its best schedule, own_shares false
    assert best.rate == best.best_schedule_rate == ie.maxmin_rate(c, q) and not best.own_shares
    fast = score_plan(c, q, equal, best_schedule=False)  # the own score alone: no LP
    assert fast.rate == own.rate and math.isnan(fast.best_schedule_rate) and fast.best is None


def test_an_infeasible_plan_is_reported_as_such():
    c = ScenarioConfig(ground_nodes=NODES, **SMALL)
    q = _line(c)
    q[c.N // 2] += 500.0  # a jump faster than v_max
    s = score_plan(c, q)
    assert not s.feasible and s.report.worst_violation > 400.0


def test_shares_that_are_not_a_schedule_are_refused():
    c = ScenarioConfig(ground_nodes=NODES, **SMALL)
    with pytest.raises(ValueError, match="column sums"):
        score_plan(c, _line(c), np.ones((3, c.N)))
