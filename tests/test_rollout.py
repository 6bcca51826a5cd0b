"""Episode loops (ios_uav_env/rollout.py): one batched rollout gives each row the single env's
episode, scored by the same scorer."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from ios_uav_env import RANDOM_ENV_ID, ScenarioConfig
from ios_uav_env.policies import HoverAt
from ios_uav_env.rollout import batch_policy, run_episode, run_episodes

MULTINODE_ENV_ID = "ios_uav_env/IOSUAV-MultiNode-v0"
SHORT = ScenarioConfig(T=40.0, ios_shape=(100, 20))
CONFIGS = [SHORT, SHORT.replace(T=55.0, surface="ris"), SHORT.replace(ground_node=(60.0, 40.0))]


def make_vec(env_id: str, num_envs: int, **kwargs):
    return gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **kwargs)


def test_each_row_is_the_single_envs_episode_scored_alike():
    policy = HoverAt("peak")
    episodes = run_episodes(
        make_vec(RANDOM_ENV_ID, 3, **policy.env_kwargs), policy, seed=[0] * 3, options={"configs": CONFIGS}
    )
    env = gym.make(RANDOM_ENV_ID, **policy.env_kwargs)
    for cfg, batched in zip(CONFIGS, episodes, strict=True):
        single = run_episode(env, policy, seed=0, options={"config": cfg})
        assert batched.config == cfg and batched.steps == single.steps == cfg.N - 1
        np.testing.assert_array_equal(batched.trajectory, single.trajectory)
        assert batched.average_rate == single.average_rate and batched.feasible
        assert batched.episode_return == pytest.approx(single.episode_return, rel=1e-12)
        assert batched.seconds > 0.0
    # rows of different horizons: each keeps its own first episode, not the autoreset's next one
    assert [len(e.trajectory) for e in episodes] == [c.N for c in CONFIGS]


def test_multinode_rows_are_scored_with_their_own_shares():
    rng = np.random.default_rng(3)
    vec = make_vec(MULTINODE_ENV_ID, 2, best_schedule=False)
    actions = rng.uniform(-1, 1, (200, 2, vec.single_action_space.shape[0]))
    step = iter(range(200))

    def scripted(obs: np.ndarray) -> np.ndarray:
        return actions[next(step)]

    scripted.batched = True  # type: ignore[attr-defined]
    episodes = run_episodes(vec, scripted, seed=4)
    for i, batched in enumerate(episodes):
        env = gym.make(MULTINODE_ENV_ID)
        moves = iter(actions[:, i])
        single = run_episode(env, lambda obs, moves=moves: next(moves), seed=4 + i)
        np.testing.assert_allclose(batched.trajectory, single.trajectory, atol=1e-9)
        assert batched.average_rate == pytest.approx(single.average_rate, rel=1e-9)  # own min_k R_k


def test_one_observation_policies_are_run_per_row_and_bad_envs_refused():
    calls = []

    def one(obs: np.ndarray) -> np.ndarray:
        calls.append(obs.shape)
        return np.zeros(2)

    act = batch_policy(one)
    assert act(np.zeros((3, 11))).shape == (3, 2) and calls == [(11,)] * 3
    hover = HoverAt("ground")
    assert batch_policy(hover) is hover  # batched = True: called on the batch
    with pytest.raises(ValueError, match="next_step"):
        run_episodes(make_vec("ios_uav_env/IOSUAV-v0", 2, autoreset_mode="same_step"), hover)
