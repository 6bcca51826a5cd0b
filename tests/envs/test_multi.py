"""The multi-node env (ios_uav_env/envs/multi.py): checkers, the return equals the agent's
own max-min score, info, bounds, seeding, pinned scenarios, errors, and its step is the
kernel of the batched env on one row."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env
from ios_uav_env import ScenarioConfig, maxmin_rate, rate_peak, scheduled_rates
from ios_uav_env.envs import multi_kernels
from ios_uav_env.envs.multi import (
    DEFAULT_NODES,
    MULTI_INFO_KEYS,
    NODE_FEATURES,
    NODE_PEAK_FEATURES,
    MultiNodeEnv,
    rate_potential,
    share_scores,
)
from ios_uav_env.model.scenarios import ScenarioRanges

IDS = sorted(ios_uav_env.MULTINODE_IDS)
SMALL = ScenarioConfig(T=60.0, ios_shape=(100, 20), ground_nodes=((-100.0, -20.0), (120.0, 40.0)))


def rollout(env, seed: int, actions=None, options=None) -> dict:
    obs, info = env.reset(seed=seed, options=options)
    rng = np.random.default_rng(seed)
    out = {"obs": [obs], "infos": [info], "rewards": []}
    done = False
    while not done:
        a = rng.uniform(-1.2, 1.2, env.action_space.shape) if actions is None else actions(obs)
        obs, reward, terminated, truncated, info = env.step(a)
        out["obs"].append(obs)
        out["infos"].append(info)
        out["rewards"].append(reward)
        done = terminated or truncated
    return out


@pytest.mark.parametrize("env_id", IDS)
def test_return_is_n_times_the_agents_own_max_min_score(env_id):
    env = gym.make(env_id).unwrapped
    for seed in (0, 1):
        out = rollout(env, seed)
        cfg, last = env.config, out["infos"][-1]
        own = scheduled_rates(cfg, env.trajectory, env.shares).min()  # the one scorer
        assert sum(out["rewards"]) == pytest.approx(cfg.N * own, rel=1e-12)  # the guard: no penalty
        assert last["min_rate"] == pytest.approx(own, rel=1e-12)
        assert last["best_schedule_rate"] == pytest.approx(maxmin_rate(cfg, env.trajectory), rel=1e-12)
        assert last["best_schedule_rate"] >= own - 1e-12 and last["feasible"]
        np.testing.assert_allclose(env.shares.sum(axis=0), 1.0, rtol=1e-12)


@pytest.mark.parametrize("beta", [5.0, 40.0])
def test_softmin_shaping_keeps_the_return_and_rewards_the_least_served(beta):
    plain, shaped = MultiNodeEnv(SMALL), MultiNodeEnv(SMALL, softmin_beta=beta)
    a, b = rollout(plain, 3), rollout(shaped, 3)
    np.testing.assert_array_equal(plain.trajectory, shaped.trajectory)  # the rewards differ, not the episode
    assert sum(b["rewards"]) == pytest.approx(SMALL.N * b["infos"][-1]["min_rate"], rel=1e-12)
    assert sum(b["rewards"]) == pytest.approx(sum(a["rewards"]), rel=1e-12)
    assert b["rewards"][:-1] != pytest.approx(a["rewards"][:-1])  # a denser signal than the minimum's
    rates = np.array([0.2, 0.5, 0.9])
    assert rates.min() <= rate_potential(rates, beta) <= rates.min() + np.log(3) / beta
    assert rate_potential(np.full(3, 0.4), beta) == pytest.approx(0.4, abs=1e-15)
    assert rate_potential(rates, 0.0) == 0.2
    # serving the least-served node earns more than serving the best-served one
    assert rate_potential(rates + [0.1, 0, 0], beta) > rate_potential(rates + [0, 0, 0.1], beta)
    for bad in (-1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="softmin_beta"):
            MultiNodeEnv(SMALL, softmin_beta=bad)


def test_info_keys_and_types_are_fixed_and_padded():
    env = MultiNodeEnv(SMALL, max_nodes=4)
    out = rollout(env, 3)
    for info in out["infos"]:
        assert tuple(info) == MULTI_INFO_KEYS
        assert all(hasattr(v, "dtype") and np.all(np.isfinite(v)) for v in info.values())
        assert info["shares"].shape == (4,) and info["node_rates"].shape == (4,)
        assert np.all(info["shares"][2:] == 0) and np.all(info["node_rates"][2:] == 0)
    assert out["infos"][0]["slot"] == 1 and out["infos"][-1]["slot"] == SMALL.N
    assert all(i["best_schedule_rate"] == 0.0 for i in out["infos"][:-1])


def test_observation_layout_mask_side_and_bounds():
    env = MultiNodeEnv(max_nodes=4, random_nodes=(2, 4))
    for seed in range(4):
        out = rollout(env, seed)
        k = env.config.K
        for obs in out["obs"]:
            assert env.observation_space.contains(obs)
            blocks = obs[12:].reshape(4, len(NODE_FEATURES))
            assert np.all(blocks[:k, 0] == 1.0) and np.all(blocks[k:] == 0.0)
        sides = out["obs"][0][12:].reshape(4, -1)[:k, 3]
        expected = [1.0 if x > env.config.ios_center[0] else -1.0 for x, _ in env.config.nodes]
        np.testing.assert_array_equal(sides, expected)
        served = out["obs"][-1][12:].reshape(4, -1)[:k, 4]
        np.testing.assert_allclose(served, scheduled_rates(env.config, env.trajectory, env.shares), rtol=1e-6)


def test_peak_hint_is_each_nodes_own_peak_within_the_bounds():
    env = MultiNodeEnv(max_nodes=4, random_nodes=(2, 4), peak_hint=True)
    width = len(NODE_FEATURES) + len(NODE_PEAK_FEATURES)
    assert env.observation_space.shape == (12 + 4 * width,)
    for seed in range(3):
        out = rollout(env, seed)
        cfg, k = env.config, env.config.K
        for obs, q in zip(out["obs"][::10], env.trajectory[::10], strict=True):
            assert env.observation_space.contains(obs)
            blocks = obs[12:].reshape(4, width)
            for j in range(k):
                peak = rate_peak(cfg.node_config(j))
                np.testing.assert_allclose(blocks[j, 6:8], (np.array(peak[:2]) - q) / 400.0, atol=1e-6)
                assert blocks[j, 8] == pytest.approx(peak.rate, rel=1e-6)
            assert np.all(blocks[k:] == 0.0)


def test_same_seed_same_episode_and_new_scenarios_per_reset():
    a = rollout(MultiNodeEnv(random_nodes=(2, 4)), 5)
    b = rollout(MultiNodeEnv(random_nodes=(2, 4)), 5)
    assert a["rewards"] == b["rewards"]
    assert all(np.array_equal(x, y) for x, y in zip(a["obs"], b["obs"], strict=True))
    env = MultiNodeEnv(random_nodes=(2, 4))
    env.reset(seed=0)
    first = env.config
    env.reset()
    assert env.config != first


def test_a_score_action_serves_the_chosen_node():
    env = MultiNodeEnv(SMALL)
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([0.0, 0.0, 1.0, -1.0]))
    assert info["shares"][0] > 0.9999 and info["shares"].sum() == pytest.approx(1.0)


def test_share_scores_invert_the_envs_share_map():
    rng = np.random.default_rng(0)
    env = MultiNodeEnv(
        ScenarioConfig(T=60.0, ios_shape=(100, 20), ground_nodes=((-100.0, 0.0), (50.0, 9.0), (9.0, 80.0)))
    )
    env.reset(seed=0)
    for _ in range(5):
        shares = rng.dirichlet(np.ones(3)) + 1e-3  # every ratio within exp(-2 sharpness)
        shares /= shares.sum()
        scores = share_scores(shares, env.share_sharpness)
        assert scores.max() == 1.0 and np.all(scores >= -1.0)
        _, _, _, _, info = env.step(np.concatenate([[0.0, 0.0], scores]))
        np.testing.assert_allclose(info["shares"], shares, rtol=1e-9)
    # a zero share reads as the smallest score; columns are slots
    np.testing.assert_array_equal(
        share_scores(np.array([[1.0, 0.0], [0.0, 0.5]]), 5.0), [[1.0, -1.0], [-1.0, 1.0]]
    )
    for bad in ([0.5, -0.1], [np.nan, 1.0], [0.0, 0.0], [[[1.0]]]):
        with pytest.raises(ValueError, match="shares must be"):
            share_scores(np.array(bad), 5.0)


def test_pinned_scenarios_and_errors():
    env = MultiNodeEnv(max_nodes=3)
    assert env.config.nodes == DEFAULT_NODES
    env.reset(options={"config": ScenarioConfig(ground_nodes=DEFAULT_NODES[:2])})
    assert env.config.K == 2
    with pytest.raises(ValueError, match="max_nodes = 3"):
        env.reset(options={"config": ScenarioConfig(ground_nodes=(*DEFAULT_NODES, (10.0, 50.0)))})
    with pytest.raises(ValueError, match="does not fit"):
        env.reset(options={"config": ScenarioConfig(ground_nodes=((-100.0, -20.0), (3000.0, 0.0)))})
    env.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(2))
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([np.nan, 0.0, 0.0, 0.0, 0.0]))
    with pytest.raises(TypeError, match="unexpected keyword argument 'frameskip'"):
        MultiNodeEnv(frameskip=1)
    with pytest.raises(ValueError, match="max_nodes"):
        MultiNodeEnv(max_nodes=2)
    with pytest.raises(
        ValueError, match="channel='rician', knowledge='reports'.* a measured rate is the slot's own"
    ):
        MultiNodeEnv(channel="rician", knowledge="reports")
    with pytest.raises(ValueError, match="energy_reference .* needs objective='energy_efficiency'"):
        MultiNodeEnv(energy_reference=1e4)


def test_rgb_array_frames_show_the_episode():
    pytest.importorskip("matplotlib")
    env = gym.make("ios_uav_env/IOSUAV-MultiNode-v0", render_mode="rgb_array")
    env.reset(seed=0)
    for _ in range(5):
        env.step(env.action_space.sample())
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3 and frame.std() > 10


def test_run_episode_scores_the_agents_own_shares():
    from ios_uav_env.envs.rollout import run_episode

    env = gym.make("ios_uav_env/IOSUAV-MultiNode-v0")
    rng = np.random.default_rng(0)
    episode = run_episode(env, lambda obs: rng.uniform(-1, 1, 5), seed=0)
    u = env.unwrapped
    assert episode.average_rate == scheduled_rates(u.config, u.trajectory, u.shares).min()
    assert episode.feasible and episode.steps == u.config.N - 1
    assert episode.episode_return == pytest.approx(u.config.N * episode.average_rate, rel=1e-12)


@pytest.mark.parametrize("guard", [True, False])
def test_the_single_env_steps_through_the_kernel_on_one_row(guard, monkeypatch):
    """One implementation of the step: each reset and step of MultiNodeEnv is one call of the
    kernels of multi_kernels (the batched env's, tests/envs/test_multi_vector.py) on its one
    row, and what it returns is what they wrote."""
    calls = []

    def spy(name):
        kernel = getattr(multi_kernels, name)

        def call(*args):
            kernel(*args)
            calls.append((name, args))

        return call

    for name in ("reset_rows", "step_rows", "step_rows_batched"):
        monkeypatch.setattr(multi_kernels, name, spy(name))
    kwargs = {"random_nodes": (2, 4), "ranges": ScenarioRanges(T=(40.0, 60.0)), "softmin_beta": 10.0,
              "peak_hint": True, "arrival_guard": guard}  # fmt: skip
    env, rng = MultiNodeEnv(**kwargs), np.random.default_rng(3)
    obs, info = env.reset(seed=0)
    (name, args), *_ = calls
    assert len(calls) == 1 and name == "reset_rows" and args[0].tolist() == [0]
    np.testing.assert_array_equal(obs, args[9][0])  # reset_rows(rows, ..., obs, info, share_path)
    assert info["min_rate"] == args[10][0, 4] and info["slot"] == 1
    for n in range(1, env.config.N):
        obs, reward, terminated, _, info = env.step(rng.uniform(-1.3, 1.3, env.action_space.shape))
        name, args = calls[-1]
        assert len(calls) == n + 1 and name == "step_rows" and args[0].shape[0] == 1
        np.testing.assert_array_equal(obs, args[10][0])  # step_rows(actions, ..., obs, reward, ...)
        assert reward == args[11][0] and terminated == args[12][0] == (n == env.config.N - 1)
        np.testing.assert_array_equal(info["position"], args[1][0, 0:2])  # state: x, y
    assert info["best_schedule_rate"] == maxmin_rate(env.config, env.trajectory) > 0


def test_a_step_needs_a_running_episode():
    env = MultiNodeEnv(SMALL)
    assert env.trajectory.shape == (0, 2) and env.shares.shape == (2, 0)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(4))
    env.reset(seed=0)
    for _ in range(SMALL.N - 1):
        env.step(np.zeros(4))
    assert env.trajectory.shape == (SMALL.N, 2) and env.shares.shape == (2, SMALL.N)
    with pytest.raises(RuntimeError, match=f"ended at slot N = {SMALL.N}"):
        env.step(np.zeros(4))
    env.reset()
    assert env.trajectory.shape == (1, 2) and env.shares.shape == (2, 1)


def test_best_schedule_false_skips_the_episode_end_schedule():
    """best_schedule=False: NaN at the end (as the batched env's), nothing timed; True: the value."""
    cfg = ScenarioConfig(ground_nodes=((-100.0, -20.0), (150.0, -60.0)), T=40.0, ios_shape=(8, 6))
    ends = {}
    for flag in (True, False):
        env = MultiNodeEnv(cfg, best_schedule=flag)
        env.reset(seed=0)
        terminated = False
        while not terminated:
            _, _, terminated, _, info = env.step(np.zeros(4))
        ends[flag] = (info["best_schedule_rate"], env.score_seconds)
    assert np.isnan(ends[False][0]) and ends[False][1] == 0.0 and ends[True][0] > 0.0
    with pytest.raises(ValueError, match="best_schedule must be True or False"):
        MultiNodeEnv(cfg, best_schedule="no")
