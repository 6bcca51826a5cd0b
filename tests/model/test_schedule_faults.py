"""The certified max-min schedule at any scale of the rates: far nodes (rates of 1e-10 bps/Hz
and less) are scored, never below a schedule that is known to be feasible, and certified
relative to the rates' own scale."""

from __future__ import annotations

import numpy as np
import pytest

from ios_uav_env import ScenarioConfig
from ios_uav_env.model.schedule import (
    CERTIFY_TOL,
    dual_value,
    maxmin_rate,
    maxmin_schedule,
    node_rates,
    scheduled_rates,
)

pytest.importorskip("scipy")

SMALL = {"ios_shape": (10, 6), "T": 40.0}


def _line(config: ScenarioConfig) -> np.ndarray:
    frac = np.arange(config.N) / (config.N - 1)
    return np.asarray(config.q0) + frac[:, None] * (np.asarray(config.qF) - np.asarray(config.q0))


def _certified(best, r: np.ndarray, fixed: np.ndarray | None = None) -> None:
    """The returned schedule is feasible, scores its value, and its dual bound is within the
    relative tolerance of it."""
    assert np.all(best.shares >= 0) and np.all(best.shares.sum(axis=0) <= 1 + 1e-9)
    assert best.value == pytest.approx(np.mean(best.shares * r, axis=1).min(), rel=1e-12)
    assert best.dual_value == dual_value(r, best.weights, fixed)
    assert 0 < best.value <= best.dual_value * (1 + 1e-12)
    assert best.dual_value - best.value <= 2 * CERTIFY_TOL * best.dual_value


@pytest.mark.parametrize("y", [5e3, 1e4])
def test_a_far_node_is_scored_and_certified(y):
    """A node thousands of metres off (rates of 1e-9 .. 1e-10 bps/Hz): the score is certified and
    at least that of equal shares, never 0 or a "not certified" error."""
    c = ScenarioConfig(ground_nodes=((-100.0, -20.0), (1.0, y)), **SMALL)
    q = _line(c)
    r = node_rates(c, q)
    assert r[1].max() < 1e-8 < r[0].max()
    best = maxmin_schedule(r)
    _certified(best, r)
    equal = scheduled_rates(c, q, np.full((2, c.N), 0.5)).min()
    assert maxmin_rate(c, q) == pytest.approx(best.value, rel=1e-12)  # (the scorer's own solver)
    assert best.value >= equal > 0


@pytest.mark.parametrize("scale", [1e-10, 1e-13])
def test_the_value_scales_with_the_rates(scale):
    """V(c r) = c V(r): the same schedule problem in other units has the same answer."""
    r = np.random.default_rng(2).uniform(0.1, 2.0, (3, 30))
    reference = maxmin_schedule(r).value
    small = maxmin_schedule(scale * r)
    _certified(small, scale * r)
    assert small.value == pytest.approx(scale * reference, rel=1e-9)


@pytest.mark.parametrize("ratio", [1e-8, 1e-10, 1e-12, 1e-15])
def test_nodes_of_very_different_scales_keep_the_max_min_value(ratio):
    """One node's rates ``ratio`` times the others' (it is far away): the others need only a tiny
    share, and the value is the far node's own best (all of its time) up to that share, at
    least the equal-share value, certified."""
    rng = np.random.default_rng(5)
    r = rng.uniform(0.1, 2.0, (3, 30))
    r[1] *= ratio
    best = maxmin_schedule(r)
    _certified(best, r)
    assert best.value >= np.mean(r / 3, axis=1).min()
    assert best.value == pytest.approx(np.mean(r[1]), rel=1e-6)


def test_a_far_continuation_is_certified():
    """The continuation (fixed first slots) with a far node: certified by its own bound."""
    rng = np.random.default_rng(8)
    r = rng.uniform(0.1, 2.0, (2, 24))
    r[0] *= 1e-11
    fixed = np.full((2, 6), 0.5)
    best = maxmin_schedule(r, fixed)
    np.testing.assert_array_equal(best.shares[:, :6], fixed)
    _certified(best, r, fixed)
    equal = np.mean(np.full((2, 24), 0.5) * r, axis=1).min()
    assert best.value >= equal
