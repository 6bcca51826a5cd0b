"""The multi-node env with moving, roughly known nodes (``ios_uav_env/IOSUAV-MultiNode-Mobile-v0``)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env
from ios_uav_env import MULTINODE_MOBILE_ID, ScenarioConfig, score_plan
from ios_uav_env.envs.knowledge import REPORT_CLIP
from ios_uav_env.envs.multi import DEFAULT_NODES, MultiNodeEnv, sample_multinode, share_scores
from ios_uav_env.envs.multi_mobile import N_BASE
from ios_uav_env.envs.multi_vector import MultiNodeVectorEnv
from ios_uav_env.model.mobility import GaussMarkov
from ios_uav_env.model.motion import node_bounds, node_paths
from ios_uav_env.model.reports import measured_rates, position_reports
from ios_uav_env.model.scenarios import ScenarioRanges
from ios_uav_env.model.schedule import node_rates, scheduled_rates
from tests.envs.test_multi_vector import RANDOM, replay_gap

WALK = GaussMarkov()
SHORT = ScenarioConfig(T=40.0, ios_shape=(100, 20), ground_nodes=DEFAULT_NODES[:2], motion=WALK)
RANGES = ScenarioRanges(T=(40.0, 60.0), ios_rows=(20, 20), base=ScenarioConfig(motion=WALK))
ACTIONS = np.random.default_rng(3).uniform(-1.2, 1.2, (64, 6))


def fly(env: gym.Env, seed: int, options: dict | None = None) -> tuple[list[np.ndarray], list[float], dict]:
    obs, info = env.reset(seed=seed, options=options)
    width = env.action_space.shape[0]
    observations, rewards, terminated, t = [obs], [], False, 0
    while not terminated:
        obs, reward, terminated, _, info = env.step(ACTIONS[t % len(ACTIONS), :width])
        observations.append(obs)
        rewards.append(reward)
        t += 1
    return observations, rewards, info


def block(obs: np.ndarray, env: MultiNodeEnv, k: int) -> np.ndarray:
    """Node k's observation block (mask, dx, dy, side, served, rate) of every slot."""
    width = len(env.node_features)
    return np.asarray(obs)[:, N_BASE + width * k : N_BASE + width * (k + 1)]


def test_the_id_is_registered_with_its_batched_form_and_has_its_batched_form():
    env = gym.make(MULTINODE_MOBILE_ID)
    assert env.unwrapped.mobile and env.unwrapped.ranges.base.motion == WALK
    assert env.unwrapped.options.knowledge == "reports" and env.unwrapped.random_nodes == (2, 4)
    vec = gym.make_vec(MULTINODE_MOBILE_ID, num_envs=2, vectorization_mode="vector_entry_point")
    assert vec.envs[0].view == "node_blocks" and vec.single_observation_space == env.observation_space
    assert MULTINODE_MOBILE_ID in ios_uav_env.MULTINODE_MOBILE_IDS
    assert len(ios_uav_env.envs.multi.BASE_FEATURES) == N_BASE


@pytest.mark.parametrize("knowledge", ["exact", "reports", "rates"])
def test_a_seeded_episode_reproduces_bit_for_bit(knowledge):
    runs = [MultiNodeEnv(random_nodes=(2, 4), ranges=RANGES, knowledge=knowledge) for _ in range(2)]
    (obs_a, rew_a, _), (obs_b, rew_b, _) = (fly(env, 11) for env in runs)
    assert np.array_equal(np.array(obs_a), np.array(obs_b)) and rew_a == rew_b
    assert np.array_equal(runs[0].paths, runs[1].paths)
    assert np.array_equal(runs[0].measured_rates, runs[1].measured_rates, equal_nan=True)
    other = MultiNodeEnv(random_nodes=(2, 4), ranges=RANGES, knowledge=knowledge)
    fly(other, 12)
    assert other.config != runs[0].config


def test_the_reward_and_the_score_are_the_true_paths_rates():
    """The return is N min_k R_k on the true paths with the agent's own shares (score_plan's),
    the nodes did walk, and the static kernels would have scored another value."""
    env = MultiNodeEnv(SHORT)
    _, rewards, info = fly(env, 4)
    q, shares, paths = env.trajectory, env.shares, env.paths
    assert np.ptp(paths[:, :, 0], axis=0).min() > 5.0  # metres walked by every node
    score = score_plan(env.config, q, shares, paths=paths, best_schedule=False).rate
    np.testing.assert_allclose(info["min_rate"], score, rtol=1e-12)
    np.testing.assert_allclose(sum(rewards), env.config.N * score, rtol=1e-9)
    static = scheduled_rates(env.config.replace(motion=None), q, shares).min()
    assert abs(static - score) > 1e-6
    assert info["best_schedule_rate"] >= score - 1e-12  # the best shares for the same flight, on the paths


def test_reports_and_measured_rates_are_the_models_draws_in_order():
    """Replaying the generator through the model's functions (the scenario, the paths, then per
    slot every node's report and every node's faded sample) gives the env's reports, its clipped
    report features, its measured rates and the served tally."""
    env = MultiNodeEnv(random_nodes=(2, 4), ranges=RANGES, knowledge="reports", report_sigma=12.0)
    observations, _, _ = fly(env, 8)
    rng = np.random.default_rng(8)
    cfg = sample_multinode(rng, RANGES, (2, 4))
    assert cfg == env.config and cfg.K >= 2
    paths = node_paths(cfg, rng)
    np.testing.assert_array_equal(paths, env.paths)
    lo, hi = node_bounds(cfg)
    q, shares, k_n = env.trajectory, env.shares, cfg.K
    tally = np.zeros(k_n)
    for n in range(cfg.N):
        report = position_reports(paths[n], rng, 12.0)
        measured = measured_rates(cfg, np.repeat(q[n : n + 1], k_n, 0), np.repeat(paths[n : n + 1], k_n, 0),
                                  np.arange(k_n), rng)  # fmt: skip
        clipped = np.clip(report, lo - REPORT_CLIP * 12.0, hi + REPORT_CLIP * 12.0)
        np.testing.assert_array_equal(env.reports[n], clipped)
        # the LoS phase 2 pi d / lambda is ~3e4 rad: one ulp of it moves cos/sin by ~1e-12
        np.testing.assert_allclose(env.measured_rates[:, n], measured, rtol=1e-9)
        told = np.minimum(env.measured_rates[:, n], env._rate_clip)
        tally += shares[:, n] * told
        for k in range(k_n):
            feats = block(observations, env, k)[n]
            np.testing.assert_array_equal(feats[1:3], np.float32((clipped[k] - q[n]) / 400.0))
            assert feats[4] == np.float32(tally[k] / cfg.N) and feats[5] == np.float32(told[k])


def test_what_each_knowledge_mode_tells():
    exact, rates = MultiNodeEnv(SHORT, knowledge="exact"), MultiNodeEnv(SHORT, knowledge="rates")
    obs_exact, _, _ = fly(exact, 2)
    obs_rates, _, _ = fly(rates, 2)
    q, paths = exact.trajectory, exact.paths
    truth = node_rates(SHORT, q, paths)
    served = np.cumsum(exact.shares * truth, axis=1) / SHORT.N
    for k in range(SHORT.K):
        feats = block(obs_exact, exact, k)
        np.testing.assert_array_equal(feats[:, 1:3], np.float32((paths[:, k] - q) / 400.0))
        np.testing.assert_allclose(feats[:, 5], truth[k].astype(np.float32), rtol=1e-6)
        np.testing.assert_allclose(feats[:, 4], served[k].astype(np.float32), rtol=1e-6)
        assert not block(obs_rates, rates, k)[:, 1:3].any()  # no position at all
    assert np.isnan(exact.measured_rates).all() and np.isnan(exact.reports).all()
    assert not np.isnan(rates.measured_rates).any()  # softmax shares: every node is served


def test_still_nodes_known_exactly_are_the_static_env():
    """Motion with zero speed and spread keeps the nodes in place: the per-slot kernels are the
    static ones bit for bit, so the episode is the static env's, observation for observation."""
    still = SHORT.replace(motion=GaussMarkov(speed=0.0, sigma=0.0))
    mobile, static = MultiNodeEnv(still), MultiNodeEnv(SHORT.replace(motion=None))
    assert mobile.mobile and not static.mobile
    obs_m, rew_m, info_m = fly(mobile, 0)
    obs_s, rew_s, info_s = fly(static, 0)
    assert rew_m == rew_s and info_m["min_rate"] == info_s["min_rate"]
    assert info_m["best_schedule_rate"] == pytest.approx(info_s["best_schedule_rate"], rel=1e-12)
    # the node features: float64 (w - q) / L here, the kernel's own float32 cast there
    np.testing.assert_allclose(np.array(obs_m), np.array(obs_s), rtol=1e-6, atol=1e-7)


def test_the_env_and_run_online_share_the_episodes_draws():
    """Two walking nodes, a pinned scenario and one seed: the env draws what MPC's run_online
    draws (the paths, then per slot the reports and every node's faded sample), so an agent and
    the planner face the same truth and noise. Flying MPC's trajectory with its shares (the
    share-score inverse), the env reports and measures the same values."""
    from baselines.mpc import MPC, run_online

    config = ScenarioConfig(
        ground_nodes=((-60.0, -20.0), (80.0, -40.0)), T=20.0, q0=(-100.0, 20.0), qF=(100.0, 20.0),
        ios_shape=(10, 6), motion=WALK,
    )  # fmt: skip
    run = run_online(config, MPC(k=10), 4)
    env = MultiNodeEnv(config, knowledge="reports")
    env.reset(seed=4, options={"config": config})
    np.testing.assert_array_equal(env.paths, run.paths)
    q, scores = run.trajectory, share_scores(np.maximum(run.shares, 1e-12))
    for n in range(1, config.N):
        move = (q[n] - q[n - 1]) / config.D
        env.step(np.concatenate([move / max(1.0, float(np.hypot(*move))), scores[:, n]]))
    np.testing.assert_allclose(env.trajectory, q, atol=1e-9)
    np.testing.assert_array_equal(env.reports, run.reports)
    served = ~np.isnan(run.measured)
    assert served.sum() >= config.N  # MPC served someone in every slot
    np.testing.assert_allclose(env.measured_rates[served], run.measured[served], rtol=1e-9)


@pytest.mark.parametrize("mode", ["next_step", "same_step"])
def test_the_batch_is_the_single_envs_step_for_step(mode):
    gap = replay_gap(RANDOM, mode, extra={"motion": WALK, "knowledge": "reports"})
    assert gap <= 1e-9


def test_rows_of_different_surface_widths_swap_their_own_kernels():
    """A row loaded after another grows the rows' surface nodes; the first row's per-slot kernels
    are then padded with zero weight, and both rows still step as their single envs."""
    small = SHORT.replace(ios_shape=(10, 6))
    configs = [small, SHORT]
    vec = MultiNodeVectorEnv(2, random_nodes=(2, 4), ranges=RANGES, knowledge="reports")
    singles = [MultiNodeEnv(random_nodes=(2, 4), ranges=RANGES, knowledge="reports") for _ in configs]
    obs, _ = vec.reset(seed=5, options={"configs": configs})
    expected = [
        env.reset(seed=5 + i, options={"config": c})[0]
        for i, (env, c) in enumerate(zip(singles, configs, strict=True))
    ]
    assert np.abs(obs - np.array(expected)).max() <= 1e-9
    for t in range(10):
        actions = ACTIONS[t : t + 1, :6].repeat(2, axis=0)
        obs, reward, *_ = vec.step(actions)
        for i, env in enumerate(singles):
            o, r, *_ = env.step(actions[i])
            assert np.abs(o - obs[i]).max() <= 1e-9 and abs(r - reward[i]) <= 1e-9


def test_observations_stay_in_the_space_with_noisy_reports():
    env = MultiNodeEnv(random_nodes=(2, 4), ranges=RANGES, knowledge="reports", report_sigma=40.0)
    for seed in range(3):
        observations, _, _ = fly(env, seed)
        assert all(env.observation_space.contains(o) for o in observations)
    pinned = MultiNodeEnv(SHORT, knowledge="reports", report_sigma=40.0)
    observations, _, _ = fly(pinned, 0)
    assert all(pinned.observation_space.contains(o) for o in observations)


def test_a_drawn_node_next_to_the_ios_plane_walks_from_its_margin():
    ranges = ScenarioRanges(ground_x=(-0.5, 0.5), base=ScenarioConfig(motion=WALK))
    cfg = sample_multinode(np.random.default_rng(0), ranges, (3, 3))
    assert all(abs(x) == WALK.plane_margin for x, _ in cfg.nodes)


def test_errors_name_the_field():
    with pytest.raises(ValueError, match="peak_hint"):
        MultiNodeEnv(SHORT, peak_hint=True)
    with pytest.raises(ValueError, match="motion model"):
        MultiNodeEnv(SHORT.replace(motion=None)).reset(options={"config": SHORT})
    with pytest.raises(ValueError, match="filter_estimate"):
        MultiNodeEnv(SHORT, filter_estimate=True)


def test_the_filter_estimate_is_closer_to_the_truth_than_the_reports():
    env = MultiNodeEnv(SHORT.replace(T=60.0), knowledge="reports", report_sigma=20.0, filter_estimate=True)
    observations, _, _ = fly(env, 5)
    q, paths, reports = env.trajectory, env.paths, env.reports
    told = np.stack([block(observations, env, k)[:, 1:3] * 400.0 for k in range(2)], axis=1) + q[:, None]
    err_filter = np.linalg.norm(told - paths, axis=2)[10:].mean()
    err_report = np.linalg.norm(reports - paths, axis=2)[10:].mean()
    assert err_filter < 0.7 * err_report
