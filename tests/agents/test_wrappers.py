"""agents.wrappers: the action repeat and the exploring starts on a single env (their batched forms
are in test_vec_env.py)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env  # noqa: F401
from agents.wrappers import ActionRepeat, ExploringStarts
from ios_uav_env.envs.policies import full_speed_move
from ios_uav_env.model.trajectory import check_trajectory

MULTI_ID = "ios_uav_env/IOSUAV-MultiNode-v0"


def test_action_repeat_holds_the_action_and_sums_the_rewards() -> None:
    plain, wrapped = gym.make(MULTI_ID, T=60), ActionRepeat(gym.make(MULTI_ID, T=60), 4)
    plain.reset(seed=0)
    wrapped.reset(seed=0)
    action = np.array([0.6, 0.1, 1.0, -1.0, 0.0], dtype=np.float32)
    steps = [plain.step(action) for _ in range(4)]
    obs, reward, terminated, _, info = wrapped.step(action)
    assert reward == pytest.approx(sum(s[1] for s in steps), rel=1e-12) and not terminated
    np.testing.assert_array_equal(obs, steps[-1][0])
    steps = 1
    while not terminated:  # 59 slots: 14 more decisions, the last of 3 slots
        _, _, terminated, _, info = wrapped.step(action)
        steps += 1
    assert steps == 15 and info["slot"] == 60


def test_exploring_starts_begin_part_way_along_a_feasible_flight() -> None:
    env = ExploringStarts(gym.make(MULTI_ID, T=60), prob=1.0, max_moves=20, box=((100, 100), (0, 0)))
    obs, info = env.reset(seed=3)
    slot = int(info["slot"])
    assert 2 <= slot <= 21 and obs[6] < 1.0  # time_left: the prefix's moves are gone
    path = env.unwrapped.trajectory
    moves = np.diff(path, axis=0)
    np.testing.assert_allclose(moves, moves[:1].repeat(slot - 1, 0))  # a straight line
    assert np.hypot(*(path[1] - path[0])) == pytest.approx(env.unwrapped.config.D)  # full speed
    np.testing.assert_allclose(env.unwrapped.shares[:, 1:], 1 / 3)  # equal shares
    again, _ = env.reset(seed=3)
    np.testing.assert_array_equal(again, obs)  # seeded by reset
    terminated = False
    while not terminated:
        _, _, terminated, _, info = env.step(env.action_space.sample())
    assert info["slot"] == 60 and check_trajectory(env.unwrapped.config, env.unwrapped.trajectory).feasible
    never = ExploringStarts(gym.make(MULTI_ID, T=60), prob=0.0)
    np.testing.assert_array_equal(never.reset(seed=3)[0], gym.make(MULTI_ID, T=60).reset(seed=3)[0])


def test_full_speed_move_flies_at_full_speed_then_lands_on_the_target() -> None:
    start, targets = np.zeros((2, 2)), np.array([[100.0, 0.0], [0.0, 10.0]])
    moves = full_speed_move(targets - start, np.array([[25.0], [25.0]]))  # one D per row
    np.testing.assert_allclose(moves, [[1.0, 0.0], [0.0, 0.4]])


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [({"prob": 1.5}, "prob"), ({"max_moves": 0}, "max_moves"), ({"box": ((1, 0), (0, 1))}, "box")],
)
def test_exploring_starts_refuse_bad_arguments(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=f"ExploringStarts {field}"):
        ExploringStarts(gym.make(MULTI_ID), **kwargs)


def test_exploring_starts_can_head_for_the_node_peaks() -> None:
    from ios_uav_env.envs.multi import node_peaks

    env = ExploringStarts(gym.make(MULTI_ID), prob=1.0, max_moves=60, peak_prob=1.0, peak_noise=0.0)
    cfg = env.unwrapped.config
    peaks = np.array([p[:2] for p in node_peaks(cfg)])
    q0, reached = np.asarray(cfg.q0), 0
    for seed in range(12):
        _, info = env.reset(seed=seed)
        here = info["position"]
        # on the straight flight from q0 to one of the peaks (at it once the prefix is long enough)
        t = np.clip(((here - q0) @ (peaks - q0).T) / np.sum((peaks - q0) ** 2, axis=1), 0, 1)
        gaps = np.hypot(*(q0 + t[:, None] * (peaks - q0) - here).T)
        assert gaps.min() < 1e-6
        reached += bool(np.min(np.hypot(*(peaks - here).T)) < 1e-6)
    assert reached >= 3
