"""dp-star's plan flown through the NOMA STAR flight env (``ios_uav_env/STARUAV-NOMA-v0``): the
move action expresses the plan, so the env's score (``score_plan`` of the flight) is the rate
dp-star reports; and no episode of the env, planned or not, scores above dp-star's certified bound
(nor does the env's own max-min)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from baselines.dp_star import solve
from ios_uav_env import STAR_NOMA_ID
from ios_uav_env.envs.star_noma import NOMA_CONFIG
from tests.tolerances import PLANNER_REL

#: The NOMA id's scenario on a short flight past a 4 x 4 surface (dp-star plans it in ~2 s).
SMALL = NOMA_CONFIG.replace(ios_shape=(4, 4), T=8.0, q0=(-150.0, -75.0), qF=(-150.0, 75.0))


@pytest.fixture(scope="module")
def plan():
    return solve(SMALL, resolution=12.5)


def _fly(env: gym.Env, moves: np.ndarray, weights: np.ndarray) -> dict:
    env.reset(seed=0)
    for move, a_w in zip(moves, weights, strict=True):
        _, _, done, _, info = env.step(np.array([*move, a_w]))
    assert done
    return info


def test_dp_stars_plan_flown_through_the_env_scores_what_dp_star_reports(plan):
    """The plan's moves / D as actions (the arrival guard leaves a feasible plan as it is, to
    rounding): the same flight, and its score is dp-star's rate whatever the weights flown."""
    env = gym.make(STAR_NOMA_ID, config=SMALL)
    q = plan.trajectory
    moves = np.diff(q, axis=0) / SMALL.D
    for weights in (np.zeros(len(moves)), np.random.default_rng(0).uniform(-1, 1, len(moves))):
        info = _fly(env, moves, weights)
        assert np.allclose(env.unwrapped.trajectory, q, rtol=0, atol=1e-9)
        assert info["score"] == pytest.approx(plan.mean_rate, rel=PLANNER_REL)
        assert info["min_rate"] <= info["score"] * (1 + PLANNER_REL)


def test_no_episode_scores_above_dp_stars_certified_bound(plan):
    bound = plan.info["upper_bound"]
    env = gym.make(STAR_NOMA_ID, config=SMALL)
    rng = np.random.default_rng(1)
    for _ in range(4):
        info = _fly(env, rng.uniform(-1, 1, (SMALL.N - 1, 2)), rng.uniform(-1, 1, SMALL.N - 1))
        assert info["min_rate"] <= info["score"] <= bound
