"""Fixed trajectories: fly-hover-fly (IA-FT) and the straight line, feasible for every config."""

from __future__ import annotations

import math

import numpy as np
import pytest

from baselines.fixed import fly_hover_fly, fly_hover_fly_path, straight_line, straight_line_path
from ios_uav_env import ScenarioConfig, average_rate, check_trajectory

SMALL = dict(ios_shape=(10, 6))


def _random_configs(n: int, seed: int = 0):
    """Random valid scenarios, T from the minimum horizon up to a few extra moves."""
    rng = np.random.default_rng(seed)
    for i in range(n):
        q0, q_f, g = rng.uniform(-500, 500, size=(3, 2))
        if i % 5 == 0:
            q_f = q0 + rng.uniform(-20, 20, size=2)  # short missions
        v_max = float(rng.uniform(5, 40))
        base = ScenarioConfig(q0=tuple(q0), qF=tuple(q_f), ground_node=tuple(g), v_max=v_max, T=1000, **SMALL)
        t_min = base.min_horizon()
        extra = int(rng.choice([0, 0, 1, 2, int(rng.integers(0, 80))]))
        yield base.replace(T=t_min + extra), g


def test_fly_hover_fly_is_feasible_on_random_configs() -> None:
    hovered = tight = 0
    rng = np.random.default_rng(1)
    for config, g in _random_configs(400):
        hover = None if rng.random() < 0.7 else tuple(rng.uniform(-600, 600, size=2))
        traj, turn, slots = fly_hover_fly_path(config, hover)
        report = check_trajectory(config, traj)
        assert report.feasible, (config, hover, report)
        target = np.asarray(g if hover is None else hover)
        moves = math.ceil(np.linalg.norm(target - config.q0) / config.D - 1e-9) + math.ceil(
            np.linalg.norm(np.asarray(config.qF) - target) / config.D - 1e-9
        )
        if moves <= config.N - 1:  # time allows: it hovers at the target for all spare slots
            assert np.array_equal(turn, target)
            assert np.all(traj == target, axis=1).sum() >= config.N - moves
            hovered += 1
        else:
            assert slots <= 2  # at most one leftover move at the turning point
            tight += 1
    assert hovered > 50 and tight > 50  # both branches exercised


def test_fly_hover_fly_default_hovers_above_g() -> None:
    config = ScenarioConfig(**SMALL)  # T = 150 s
    plan = fly_hover_fly(config)
    k_out = math.ceil(math.dist(config.q0, config.ground_node) / config.D)  # 13
    k_back = math.ceil(math.dist(config.ground_node, config.qF) / config.D)  # 21
    at_g = np.all(plan.trajectory == np.array(config.ground_node), axis=1).sum()
    assert at_g == config.N - k_out - k_back == 116
    assert plan.info["reached_hover"] and plan.info["slots_at_turning_point"] == at_g
    assert plan.feasible and plan.scheme == "ia-ft"
    assert plan.mean_rate == average_rate(config, plan.trajectory)
    steps = np.linalg.norm(np.diff(plan.trajectory, axis=0), axis=1)
    np.testing.assert_allclose(steps[: k_out - 1], config.D)  # v_max out of q0 ...
    np.testing.assert_allclose(steps[-k_back:-1], config.D)  # ... and towards qF
    assert np.count_nonzero(steps == 0) == at_g - 1


def test_fly_hover_fly_tight_horizon_turns_back_early() -> None:
    config = ScenarioConfig(T=40, **SMALL)  # 39 moves >= 13 out + 21 back
    assert fly_hover_fly(config).info["reached_hover"]
    config = ScenarioConfig(T=34, **SMALL)  # 33 moves < 13 + 21
    plan = fly_hover_fly(config)
    assert plan.feasible and not plan.info["reached_hover"]
    turn = np.array(plan.info["turning_point"])
    direction = np.subtract(config.ground_node, config.q0)
    # the turning point lies on the segment q0 -> G
    cross = direction[0] * (turn - config.q0)[1] - direction[1] * (turn - config.q0)[0]
    assert abs(cross) < 1e-6 and 0 < np.dot(turn - config.q0, direction) < np.dot(direction, direction)


@pytest.mark.parametrize("hover", ["q0", "qF"])
def test_fly_hover_fly_degenerate_hover_points(hover: str) -> None:
    config = ScenarioConfig(T=60, **SMALL)
    plan = fly_hover_fly(config, getattr(config, hover))
    assert plan.feasible and plan.info["reached_hover"]


def test_fly_hover_fly_rejects_bad_hover() -> None:
    with pytest.raises(ValueError, match="hover"):
        fly_hover_fly(ScenarioConfig(**SMALL), hover=(1.0, 2.0, 3.0))
    with pytest.raises(ValueError, match="hover"):
        fly_hover_fly(ScenarioConfig(**SMALL), hover=(1.0, math.nan))


def test_straight_line() -> None:
    for config, _ in _random_configs(100, seed=3):
        traj = straight_line_path(config)
        assert check_trajectory(config, traj).feasible
        steps = np.linalg.norm(np.diff(traj, axis=0), axis=1)
        np.testing.assert_allclose(steps, math.dist(config.q0, config.qF) / (config.N - 1), atol=1e-9)
    plan = straight_line(ScenarioConfig(**SMALL))
    assert plan.feasible and plan.scheme == "line"
