"""The peak search's branch and bound (ios_uav_env/model/peak_search.py): the exhaustive search's
point and rate, a bound that holds, the exhaustive tie rule, and the plain-Python kernels."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model.channel import PARAMS, rate_kernel, rate_point
from ios_uav_env.model.config import ScenarioConfig, scene_box
from ios_uav_env.model.peak import Peak, _axis, _ellipse_box, _exhaustive, rate_peak, search_margin
from ios_uav_env.model.peak_search import block_bound, decreasing_order, fine_axis, grid_argmax, straight_line
from ios_uav_env.model.scenarios import DEFAULT_RANGES, ScenarioRanges, sample_scenario
from tests.processes import run_without_numba


def _grids(config: ScenarioConfig, resolution: float = 10.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The coarse grid and line of ``rate_peak`` on ``config``."""
    x0, x1, y0, y1 = scene_box(config, search_margin(config), ends=False)
    box_lo, box_hi = _ellipse_box(config)
    lo, hi = np.maximum((x0, y0), box_lo), np.minimum((x1, y1), box_hi)
    xs, ys = _axis(lo[0], hi[0], resolution), _axis(lo[1], hi[1], resolution)
    return xs, ys, np.linspace(config.q0, config.qF, config.N)


def _scenarios(count: int, seed: int) -> list[ScenarioConfig]:
    """Draws of the default family and of tight horizons, and every surface kind."""
    rng = np.random.default_rng(seed)
    tight = ScenarioRanges(T=(34.0, 80.0), ground_x=(-500.0, 500.0), ground_y=(-300.0, 300.0))
    out = [sample_scenario(rng, tight if i % 3 == 0 else DEFAULT_RANGES) for i in range(count)]
    return out + [c.replace(surface="none") for c in out[:6]]


def _same_rate(a: float, b: float) -> bool:
    """Equal but for the last bits: the exhaustive search's kernel (``RateKernel.rates``, called from
    Python) may run another compiled specialisation of ``channel.rates_at`` (numba picks one by the
    arrays' layout, among those the process compiled first) than the one the compiled search
    calls, whose vectorised node sums round differently by an ulp or so."""
    return math.isclose(a, b, rel_tol=1e-14, abs_tol=0.0)


def _exhaustive_peak(config: ScenarioConfig, side: str | None) -> Peak | None:
    """``rate_peak(config, side=side, compiled=True)`` with every point's rate evaluated."""
    xs, ys, line = _grids(config)
    best = _exhaustive(config, xs, ys, line, side, True)
    if best is not None:
        fx, fy = best.x + np.arange(-10, 11) * 1.0, best.y + np.arange(-10, 11) * 1.0
        fine = _exhaustive(config, fx, fy, np.zeros((0, 2)), side, True)
        best = fine if fine is not None and fine.rate > best.rate else best
    return best


@pytest.mark.skipif(not HAVE_NUMBA, reason="rate_peak prunes where numba compiles it")
@pytest.mark.parametrize("side", [None, "front", "behind"])
def test_branch_and_bound_returns_the_exhaustive_point_and_rate(side):
    for config in _scenarios(40, seed=side is None):
        ours, theirs = rate_peak(config, side=side, compiled=True), _exhaustive_peak(config, side)
        assert (ours is None) == (theirs is None)
        if ours is not None:  # the same point; the same rate but for the last bit (_same_rate)
            assert (ours.x, ours.y) == (theirs.x, theirs.y) and _same_rate(ours.rate, theirs.rate)


@pytest.mark.slow_without_numba
@pytest.mark.parametrize("block", [1, 3, 8, 13])
def test_every_block_size_finds_the_same_point(block):
    code = {None: 0, "front": 1, "behind": -1}
    for config in _scenarios(8, seed=block):
        xs, ys, line = _grids(config)
        k, q0, qf = rate_kernel(config), np.asarray(config.q0, float), np.asarray(config.qF, float)
        for side in (None, "front", "behind"):
            i, rate = grid_argmax(xs, ys, line, q0, qf, config.D, config.N - 1, config.ios_center[0],
                                  config.ground_node[0], code[side], k.nodes, k.params, block)  # fmt: skip
            best, grid = _exhaustive(config, xs, ys, line, side, True), xs.size * ys.size
            if best is None:
                assert i == -1 and rate == -math.inf
                continue
            point = (xs[i % xs.size], ys[i // xs.size]) if i < grid else tuple(line[i - grid])
            assert point == (best.x, best.y) and _same_rate(rate, best.rate)


def test_the_compiled_line_and_fine_axis_are_numpys_bit_for_bit():
    rng = np.random.default_rng(4)
    for x0, y0, xf, yf in [(-400.0, 0.0, 400.0, 0.0), (-400.0, 31.7, -400.0, -55.2), (3.0, 3.0, 3.0, 3.0)]:
        for num in (2, 3, 61, 200):
            expected = np.linspace((x0, y0), (xf, yf), num)
            assert np.array_equal(straight_line(x0, y0, xf, yf, num), expected)
    for _ in range(50):
        x0, y0, xf, yf = rng.uniform(-500.0, 500.0, 4)
        num = int(rng.integers(2, 250))
        assert np.array_equal(straight_line(x0, y0, xf, yf, num), np.linspace((x0, y0), (xf, yf), num))
        centre, step = rng.uniform(-500.0, 500.0), rng.choice([1.0, 0.3, 2.5])
        assert np.array_equal(fine_axis(centre, 10, step), centre + np.arange(-10, 11) * step)


def test_the_bound_holds_over_its_box_and_is_tight_on_a_point():
    rng = np.random.default_rng(5)
    worst_gap = 0.0
    for config in _scenarios(12, seed=7):
        k = rate_kernel(config)
        for _ in range(40):
            x0, y0 = rng.uniform(-500.0, 500.0), rng.uniform(-300.0, 300.0)
            w, h = rng.choice([0.0, 1.0, 10.0, 80.0]), rng.choice([0.0, 1.0, 10.0, 80.0])
            bound = block_bound(x0, x0 + w, y0, y0 + h, k.nodes, k.params)
            xs, ys = rng.uniform(x0, x0 + w, 30), rng.uniform(y0, y0 + h, 30)
            for x, y in zip([x0, x0 + w, *xs], [y0, y0 + h, *ys], strict=True):
                assert rate_point(x, y, k.nodes, k.params) <= bound
            if w == h == 0.0:  # a one-point box: the bound is the rate, widened by 1e-9
                rate = rate_point(x0, y0, k.nodes, k.params)
                worst_gap = max(worst_gap, bound / rate - 1.0)
    assert 0.0 < worst_gap < 1e-8


def test_a_box_across_the_plane_takes_the_larger_side_factor():
    config = ScenarioConfig(ground_node=(-80.0, 10.0), epsilon=0.9)  # strong transmission
    k = rate_kernel(config)
    x_c = config.ios_center[0]
    bound = block_bound(x_c - 1.0, x_c + 100.0, -5.0, 5.0, k.nodes, k.params)
    behind = max(rate_point(x_c + u, 0.0, k.nodes, k.params) for u in np.linspace(1.0, 100.0, 200))
    assert behind <= bound


def test_ties_go_to_the_first_point_as_argmax_does():
    # a constant rate: direct term k (d^2 + z^2)^0, no surface; every reachable point ties
    params = np.zeros(len(PARAMS))
    params[PARAMS.index("k_direct")], params[PARAMS.index("eta")] = 1.0, 1.0
    nodes = np.zeros((3, 1))
    xs, ys = np.arange(-5.0, 6.0) * 10.0, np.arange(-3.0, 4.0) * 10.0
    q0, qf = np.array([-50.0, -30.0]), np.array([50.0, 30.0])
    for block in (1, 3, 4):
        i, rate = grid_argmax(xs, ys, np.zeros((0, 2)), q0, qf, 10.0, 40, 0.0, 1.0, 0, nodes, params, block)
        assert (i, rate) == (0, 1.0)  # point 0 is q0 itself, reachable
        i, _ = grid_argmax(xs, ys, np.zeros((0, 2)), q0, qf, 10.0, 40, 0.0, 1.0, 1, nodes, params, block)
        assert i == 6  # G's side (x > 0): the first such point is column 6 of row 0


@pytest.mark.parametrize("n", [0, 1, 2, 7, 40, 300])
def test_blocks_are_visited_by_decreasing_bound_ties_by_index_nan_last(n):
    """The visiting order is numpy's stable argsort of -bounds: a wrong order would stop the
    search before a block that holds the peak; ties and NaN (last) included."""
    rng = np.random.default_rng(n)
    for values in (rng.normal(size=n), rng.integers(0, 3, size=n).astype(float), np.full(n, 2.0)):
        values[rng.random(n) < 0.2] = np.nan
        values[rng.random(n) < 0.1] = -np.inf
        order = decreasing_order(values)
        assert order.dtype == np.int64
        np.testing.assert_array_equal(order, np.argsort(-values, kind="stable"))


def test_a_negative_weight_disables_pruning():
    config = ScenarioConfig()
    k = rate_kernel(config)
    nodes = k.nodes.copy()
    nodes[2, 0] = -nodes[2, 0]
    assert block_bound(-10.0, 10.0, -10.0, 10.0, nodes, k.params) == math.inf
    assert math.isfinite(block_bound(-10.0, 10.0, -10.0, 10.0, k.nodes, k.params))


def test_the_peak_of_the_paper_scenario_is_found_by_both_searches():
    config = ScenarioConfig()
    assert rate_peak(config, compiled=True) == rate_peak(config, compiled=True)
    a, b = rate_peak(config), rate_peak(config, compiled=True)
    assert (a.x, a.y) == (b.x, b.y) and a.rate == pytest.approx(b.rate, rel=1e-12)


def test_the_plain_python_kernels_agree_with_the_exhaustive_search():
    """Without numba the same kernels run as Python: coarse 40 m grids keep them quick."""
    code = """
import json, sys
import numpy as np
from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model.channel import rate_kernel
from ios_uav_env.model.peak import _axis, _ellipse_box, _exhaustive, search_margin
from ios_uav_env.model.peak_search import grid_argmax
from ios_uav_env.model.config import ScenarioConfig, scene_box
assert not HAVE_NUMBA
out = []
for c in json.load(sys.stdin):
    config = ScenarioConfig.from_dict(c)
    x0, x1, y0, y1 = scene_box(config, search_margin(config), ends=False)
    lo_, hi_ = _ellipse_box(config)
    lo, hi = np.maximum((x0, y0), lo_), np.minimum((x1, y1), hi_)
    xs, ys = _axis(lo[0], hi[0], 40.0), _axis(lo[1], hi[1], 40.0)
    line = np.linspace(config.q0, config.qF, config.N)
    k = rate_kernel(config)
    i, rate = grid_argmax(xs, ys, line, np.asarray(config.q0, float), np.asarray(config.qF, float), config.D,
                          config.N - 1, config.ios_center[0], config.ground_node[0], 0, k.nodes, k.params, 4)
    grid = xs.size * ys.size
    point = [xs[i % xs.size], ys[i // xs.size]] if i < grid else line[i - grid].tolist()
    best = _exhaustive(config, xs, ys, line, None, True)
    out.append([float(point[0]), float(point[1]), rate, best.x, best.y, best.rate])
print(json.dumps(out))
"""
    configs = [c.to_dict() for c in _scenarios(3, seed=11)[:3]]
    for x, y, rate, bx, by, brate in json.loads(run_without_numba(code, stdin=json.dumps(configs))):
        assert (x, y, rate) == (bx, by, brate)


def _numpy_ellipse_box(config: ScenarioConfig) -> tuple[np.ndarray, np.ndarray]:
    """The box's numpy form (the reference of ``peak._ellipse_box``'s scalar one)."""
    q0, qf = np.asarray(config.q0, float), np.asarray(config.qF, float)
    a = 0.5 * (config.N - 1) * config.D + config.D
    c = 0.5 * float(np.linalg.norm(qf - q0))
    b = math.sqrt(max(a * a - c * c, 0.0))
    u = (qf - q0) / (2.0 * c) if c > 0 else np.array([1.0, 0.0])
    half = np.sqrt((a * u) ** 2 + (b * u[::-1]) ** 2)
    centre = 0.5 * (q0 + qf)
    return centre - half, centre + half


def test_the_search_box_is_the_numpy_box_bit_for_bit():
    from ios_uav_env.model.surface import _axes

    configs = _scenarios(60, seed=9) + [ScenarioConfig(), ScenarioConfig(qF=(-400.0, 0.0), T=30.0)]
    for config in configs + [c.replace(ios_shape=(7, 13), uav_altitude=250.0) for c in configs[:5]]:
        lo, hi = _ellipse_box(config)
        np_lo, np_hi = _numpy_ellipse_box(config)
        assert lo == tuple(np_lo) and hi == tuple(np_hi)
        if config.surface != "none":
            _, zs = _axes(config)
            expected = max(200.0, 2.0 * math.sqrt(3.0) * (config.uav_altitude - float(np.min(zs))))
            assert search_margin(config) == expected
