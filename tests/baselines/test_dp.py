"""DP planner: exact against brute force, feasible, scored by the one model, ordered by surface."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.ndimage import maximum_filter

from baselines import dp
from baselines.fixed import fly_hover_fly, straight_line
from ios_uav_env import IOSUAVEnv, ScenarioConfig, average_rate, check_trajectory, slot_rates

SMALL = ScenarioConfig(T=40, ios_shape=(10, 6))


def _tiny(surface: str = "ios") -> ScenarioConfig:
    """D = 5 m, 4 moves, IOS between q0 and qF, G nearby: a grid of a few dozen cells."""
    return ScenarioConfig(
        surface=surface, T=5, v_max=5, q0=(-6.0, 1.0), qF=(6.0, -1.0), ground_node=(-4.0, -3.0),
        ios_center=(0.0, 0.0, 40.0), ios_shape=(10, 6),
    )  # fmt: skip


def _brute_force(config: ScenarioConfig, resolution: float, margin: float) -> float:
    """Best mean rate over every grid path, by enumeration with continuous distance checks."""
    xs, ys, _ = dp.grid_axes(config, resolution, margin)
    cells = np.array([(x, y) for y in ys for x in xs])
    rates = slot_rates(config, cells)
    q0, q_f, d_max = np.array(config.q0), np.array(config.qF), config.D
    near = [np.flatnonzero(np.linalg.norm(cells - c, axis=1) <= d_max + 1e-9) for c in cells]
    start = int(np.flatnonzero(np.all(cells == q0, axis=1))[0])
    r0, r_f = slot_rates(config, np.array([q0, q_f]))
    best = -math.inf
    free = config.N - 2

    def extend(path: list[int]) -> None:
        nonlocal best
        if len(path) == free + 1:
            if np.linalg.norm(cells[path[-1]] - q_f) <= d_max:
                best = max(best, r0 + rates[path[1:]].sum() + r_f)
            return
        for nxt in near[path[-1]]:
            extend([*path, int(nxt)])

    extend([start])
    return best / config.N


@pytest.mark.parametrize("surface", ["ios", "none"])
def test_dp_equals_brute_force_on_tiny_grid(surface: str) -> None:
    config, resolution, margin = _tiny(surface), 2.5, 2.5
    _, _, rates = dp.rate_map(config, resolution, margin)
    assert rates.size < 60 and np.ptp(rates) > 0.01  # a small, non-flat problem
    expected = _brute_force(config, resolution, margin)
    plan = dp.solve(config, resolution=resolution, margin=margin)
    assert plan.info["dp_objective"] == pytest.approx(expected, rel=1e-12, abs=1e-12)
    assert plan.mean_rate == pytest.approx(expected, rel=1e-12, abs=1e-12)
    assert plan.feasible


@pytest.mark.parametrize(("resolution", "radius"), [(2.5, 25.0), (3.0, 25.0), (5.0, 25.0), (1.0, 3.7)])
def test_disk_max_equals_footprint_maximum_filter(resolution: float, radius: float) -> None:
    rng = np.random.default_rng(0)
    values = rng.normal(size=(23, 31))
    values[rng.random(values.shape) < 0.3] = -np.inf
    offsets = dp.disk_offsets(resolution, radius)
    assert np.all(np.hypot(*offsets.T) * resolution <= radius + 1e-9)
    r = int(np.abs(offsets).max())
    footprint = np.zeros((2 * r + 1, 2 * r + 1), dtype=bool)
    footprint[offsets[:, 0] + r, offsets[:, 1] + r] = True
    want = maximum_filter(values, footprint=footprint, mode="constant", cval=-np.inf)
    np.testing.assert_array_equal(dp.disk_max(values, offsets), want)


def test_disk_offsets_are_the_exact_disk_sorted_by_length() -> None:
    off = dp.disk_offsets(2.5, 25.0)
    assert len(off) == sum(1 for i in range(-10, 11) for j in range(-10, 11) if i * i + j * j <= 100)
    lengths = (off**2).sum(axis=1)
    assert np.all(np.diff(lengths) >= 0) and tuple(off[0]) == (0, 0)


def test_dp_plan_is_feasible_and_its_objective_is_the_models_score() -> None:
    plan = dp.solve(SMALL, resolution=5.0)
    report = check_trajectory(SMALL, plan.trajectory)
    assert report.feasible and report.max_step <= SMALL.D + 1e-9
    assert plan.mean_rate == average_rate(SMALL, plan.trajectory)
    assert abs(plan.info["dp_objective"] - plan.mean_rate) <= 1e-9
    assert plan.scheme == "dp" and plan.trajectory.shape == (SMALL.N, 2)
    again = dp.solve(SMALL, resolution=5.0)  # deterministic, ties included
    np.testing.assert_array_equal(again.trajectory, plan.trajectory)


def test_dp_beats_fixed_trajectories() -> None:
    plan = dp.solve(SMALL, resolution=5.0)
    assert plan.mean_rate >= fly_hover_fly(SMALL).mean_rate
    assert plan.mean_rate >= straight_line(SMALL).mean_rate


def test_dp_optimum_orders_ios_ris_none() -> None:
    config = SMALL.replace(ios_shape=(100, 20))  # M = 2000: large enough for the surface to matter
    rates = {s: dp.solve(config.replace(surface=s), resolution=5.0).mean_rate for s in ("ios", "ris", "none")}
    assert rates["ios"] > rates["ris"] + 0.05
    assert rates["ris"] > rates["none"] + 0.05


def test_dp_hovers_on_the_grid_peak_when_time_allows() -> None:
    config = ScenarioConfig(surface="none", T=60, ios_shape=(10, 6))  # G lies on the 5 m grid
    plan = dp.solve(config, resolution=5.0)
    at_g = np.all(plan.trajectory == np.array(config.ground_node), axis=1).sum()
    assert at_g >= config.N - 1 - 2 * math.ceil(800 / 25)  # all the spare time, at least


def test_dp_two_slots_is_the_direct_move() -> None:
    config = ScenarioConfig(T=2, q0=(0.0, 0.0), qF=(10.0, 5.0), ios_shape=(10, 6))
    plan = dp.solve(config)
    np.testing.assert_array_equal(plan.trajectory, [config.q0, config.qF])
    assert plan.feasible and plan.info["dp_objective"] == pytest.approx(plan.mean_rate, abs=1e-12)


def test_dp_off_grid_final_point() -> None:
    config = SMALL.replace(qF=(401.3, 17.9))
    plan = dp.solve(config, resolution=5.0)
    assert plan.feasible and np.array_equal(plan.trajectory[-1], config.qF)


def test_dp_tight_horizon_off_axis_is_a_clear_error() -> None:
    # 4 moves of exactly D at 30 degrees: grid moves along that direction are shorter than D
    d = 100.0
    config = ScenarioConfig(T=5, q0=(0.0, 0.0), qF=(d * math.cos(math.pi / 6), d * math.sin(math.pi / 6)),
                            ios_shape=(10, 6))  # fmt: skip
    with pytest.raises(ValueError, match="too tight"):
        dp.solve(config, resolution=5.0)


@pytest.mark.parametrize("resolution", [0, -1.0, 25.5, math.nan, math.inf])
def test_bad_resolution(resolution: float) -> None:
    with pytest.raises(ValueError, match="resolution"):
        dp.solve(SMALL, resolution=resolution)


@pytest.mark.parametrize("margin", [-1.0, math.nan])
def test_bad_margin(margin: float) -> None:
    with pytest.raises(ValueError, match="margin"):
        dp.solve(SMALL, resolution=5.0, margin=margin)


def test_grid_covers_the_box_and_is_anchored_at_q0() -> None:
    xs, ys, (iy0, ix0) = dp.grid_axes(SMALL, 3.0, 50.0)
    x_min, x_max, y_min, y_max = dp.grid_box(SMALL, 50.0)
    assert (xs[ix0], ys[iy0]) == SMALL.q0
    assert xs[0] <= x_min and xs[-1] >= x_max and ys[0] <= y_min and ys[-1] >= y_max
    assert (x_min, x_max, y_min, y_max) == (-450.0, 450.0, -70.0, 70.0)


def test_env_replay_reproduces_the_dp_rate() -> None:
    plan = dp.solve(SMALL, resolution=5.0)
    env = IOSUAVEnv(SMALL, arrival_guard=False)
    _, info = env.reset(seed=0)
    rates = [info["rate"]]
    for a, b in itertools.pairwise(plan.trajectory):
        _, _, terminated, _, info = env.step((b - a) / SMALL.D)
        rates.append(info["rate"])
    assert terminated and info["feasible"]
    assert np.mean(rates) == pytest.approx(plan.mean_rate, rel=1e-9)
    assert info["average_rate"] == pytest.approx(plan.mean_rate, rel=1e-9)
