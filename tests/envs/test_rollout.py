"""Episode loops (ios_uav_env/envs/rollout.py): one batched rollout gives each row the single env's
episode, scored by the same scorer."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from ios_uav_env import RANDOM_ENV_ID, ScenarioConfig
from ios_uav_env.envs.policies import HoverAt
from ios_uav_env.envs.rollout import batch_policy, run_episode, run_episodes

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


class _Repeating:
    """A batched policy that decides every ``repeat`` slots: each call returns fresh random actions."""

    batched = True

    def __init__(self, repeat: int, act_dim: int, seed: int = 0):
        self.repeat, self.act_dim, self.rng, self.calls = repeat, act_dim, np.random.default_rng(seed), 0

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        self.calls += 1
        return self.rng.uniform(-1, 1, (*np.shape(obs)[:-1], self.act_dim))


def test_a_policy_with_repeat_holds_each_action_for_that_many_slots():
    env = gym.make(MULTINODE_ENV_ID, T=60)  # 59 moves: 12 decisions at repeat 5, the last of 4 slots
    dim = env.action_space.shape[0]
    policy = _Repeating(5, dim)
    episode = run_episode(env, policy, seed=0)
    assert policy.calls == 12 and episode.steps == 59
    shares = env.unwrapped.shares[:, 1:]  # slot 1 is shared equally before any action
    for start in range(0, 59, 5):  # each decision's shares are held for its slots
        block = shares[:, start : start + 5]
        np.testing.assert_array_equal(block, np.repeat(block[:, :1], block.shape[1], axis=1))
    assert not np.array_equal(shares[:, 0], shares[:, 5])
    # the batched loop holds them alike: row i is the single episode of the same held actions
    batched = _Repeating(5, dim)
    rows = run_episodes(make_vec(MULTINODE_ENV_ID, 2, T=60, best_schedule=False), batched, seed=0)
    assert batched.calls == 12
    actions = _Repeating(5, dim).rng.uniform(-1, 1, (12, 2, dim))
    held = iter(np.repeat(actions[:, 1], 5, axis=0))
    single = run_episode(env, lambda obs: next(held), seed=1)
    np.testing.assert_allclose(rows[1].trajectory, single.trajectory, atol=1e-9)
    assert rows[1].average_rate == pytest.approx(single.average_rate, rel=1e-9)
    policy.repeat = 0
    with pytest.raises(ValueError, match="repeat must be an integer >= 1"):
        run_episode(env, policy, seed=0)
