"""The element-wise phase searches shared by the per-slot AOs (ios_uav_env.model.phase_sweep)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ios_uav_env.model.miso_noma import _value
from ios_uav_env.model.phase_sweep import add_rank_one, balanced, maxmin_sweep, sic_sweep, sweep_angle


def _problem(seed: int, M: int = 6, K: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Phases v (M,), cascades B (M, K, K) and r = sum_m v_m B_m + a direct part."""
    rng = np.random.default_rng(seed)
    v = np.exp(1j * rng.uniform(0, 2 * np.pi, M))
    B = rng.normal(size=(M, K, K)) + 1j * rng.normal(size=(M, K, K))
    r = np.einsum("m,mkj->kj", v, B) + 0.3 * (rng.normal(size=(K, K)) + 1j * rng.normal(size=(K, K)))
    return v, B, r


def test_sweep_angle_grid_then_alternating_halvings():
    n = 16
    for c in range(n):
        assert sweep_angle(c, n, 0.25, 9.0) == 0.25 + 2.0 * math.pi * c / n
    steps = [sweep_angle(n + i, n, 0.25, 1.0) - 1.0 for i in range(6)]
    h = 2 * math.pi / n
    assert steps == pytest.approx([-h / 2, h / 2, -h / 4, h / 4, -h / 8, h / 8], rel=1e-15)


def test_add_rank_one_in_place_and_into():
    _, B, r = _problem(0)
    out = np.empty_like(r)
    add_rank_one(out, r, 0.5 - 0.25j, B, 2)
    np.testing.assert_array_equal(out, r + (0.5 - 0.25j) * B[2])
    same = r.copy()
    add_rank_one(same, same, 0.5 - 0.25j, B, 2)
    np.testing.assert_array_equal(same, out)


def _min_sinr(r: np.ndarray, p: np.ndarray) -> float:
    g = np.abs(r) ** 2
    interference = g @ p - np.diag(g) * p + 1.0
    return float(np.min(np.diag(g) * p / interference))


@pytest.mark.parametrize("seed", range(4))
def test_maxmin_sweep_raises_the_min_sinr_and_keeps_r_current(seed):
    v, B, r = _problem(seed)
    p = np.full(3, 1 / 3)
    before = _min_sinr(r, p)
    direct = r - np.einsum("m,mkj->kj", v, B)
    v2, p2 = maxmin_sweep(v.copy(), B, r, p.copy(), 16, 8, 4)
    np.testing.assert_allclose(np.abs(v2), 1.0, rtol=1e-12)
    np.testing.assert_allclose(r, direct + np.einsum("m,mkj->kj", v2, B), rtol=1e-9, atol=1e-12)
    after = _min_sinr(r, p2)
    assert after > before  # a random start is never a fixed point of the search
    g, q = np.empty((3, 4)), np.empty(3)
    assert balanced(r, B, 0, 0j, p2, 0, g, q) == pytest.approx(after, rel=1e-12)


@pytest.mark.parametrize("total", [True, False])
def test_sic_sweep_raises_the_sic_objective(total):
    v, B, X = _problem(5)
    order = np.arange(3)
    out = np.empty(3)
    before = _value(X.copy(), order, total, out)
    direct = X - np.einsum("m,mkj->kj", v, B)
    v2 = sic_sweep(v.copy(), B, X, order, total, 16, 8)
    np.testing.assert_allclose(X, direct + np.einsum("m,mkj->kj", v2, B), rtol=1e-9, atol=1e-12)
    assert _value(X.copy(), order, total, out) > before
