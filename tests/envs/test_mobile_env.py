"""Moving, roughly known nodes in the single-node env (ios_uav_env/envs/knowledge.py): the id,
the truth it scores on, the reports and measured rates against the model's functions, the
static special case, the batch, seeding and errors."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env
from ios_uav_env import MOBILE_ID, ScenarioConfig, score_plan
from ios_uav_env.envs.knowledge import REPORT_CLIP, observe_slot, start_track
from ios_uav_env.envs.random_env import RandomIOSUAVEnv
from ios_uav_env.envs.single import IOSUAVEnv
from ios_uav_env.envs.single_vector import RandomIOSUAVVectorEnv
from ios_uav_env.model.mobility import GaussMarkov
from ios_uav_env.model.motion import node_bounds, node_paths
from ios_uav_env.model.reports import measured_rates, position_reports
from ios_uav_env.model.scenarios import ScenarioRanges, sample_scenario
from ios_uav_env.model.schedule import node_rates

WALK = GaussMarkov()
SHORT = ScenarioConfig(T=40.0, ios_shape=(100, 20), motion=WALK)
RANGES = ScenarioRanges(T=(40.0, 60.0), ios_rows=(20, 20), base=ScenarioConfig(motion=WALK))


def fly(env: gym.Env, seed: int, actions: np.ndarray) -> tuple[list[np.ndarray], list[float], dict]:
    obs, info = env.reset(seed=seed)
    observations, rewards, terminated, t = [obs], [], False, 0
    while not terminated:
        obs, reward, terminated, _, info = env.step(actions[t % len(actions)])
        observations.append(obs)
        rewards.append(reward)
        t += 1
    return observations, rewards, info


ACTIONS = np.random.default_rng(3).uniform(-1.2, 1.2, (64, 2))


def test_the_mobile_id_is_registered_with_its_batched_form_and_has_its_batched_form():
    env = gym.make(MOBILE_ID)
    assert env.unwrapped.mobile and env.unwrapped.config.motion is not None
    assert env.unwrapped.options.knowledge == "reports"
    vec = gym.make_vec(MOBILE_ID, num_envs=2, vectorization_mode="vector_entry_point")
    assert vec.envs[0].draws and vec.single_observation_space == env.observation_space
    assert MOBILE_ID in ios_uav_env.MOBILE_IDS


@pytest.mark.parametrize("knowledge", ["exact", "reports", "rates"])
def test_a_seeded_episode_reproduces_bit_for_bit(knowledge):
    runs = [RandomIOSUAVEnv(RANGES, knowledge=knowledge) for _ in range(2)]
    (obs_a, rew_a, _), (obs_b, rew_b, _) = (fly(env, 11, ACTIONS) for env in runs)
    assert np.array_equal(np.array(obs_a), np.array(obs_b)) and rew_a == rew_b
    assert np.array_equal(runs[0].paths, runs[1].paths)
    assert np.array_equal(runs[0].reports, runs[1].reports, equal_nan=True)
    other = RandomIOSUAVEnv(RANGES, knowledge=knowledge)
    fly(other, 12, ACTIONS)
    assert not np.array_equal(other.paths[:, 0], runs[0].paths[:, 0])


def test_the_reward_and_the_score_are_the_true_paths_rates():
    """Step n's reward is r(q[n+1]; w[n+1]) (guard on: no penalties), the episode's average rate
    is score_plan's on the true paths, and the node did move (so a static kernel would differ)."""
    env = IOSUAVEnv(SHORT)
    _, rewards, info = fly(env, 4, ACTIONS)
    q, paths = env.trajectory, env.paths
    assert np.ptp(paths[:, 0, 0]) > 5.0  # metres walked
    truth = node_rates(env.config, q, paths)[0]
    # compiled kernel vs numpy: the same formula, summed in another order
    np.testing.assert_allclose(rewards, truth[1:], rtol=1e-12)
    np.testing.assert_allclose(info["average_rate"], score_plan(env.config, q, paths=paths).rate, rtol=1e-12)
    static = node_rates(env.config.replace(motion=None), q)[0]
    assert np.max(np.abs(static[1:] - np.asarray(rewards))) > 1e-6


def test_reports_and_measured_rates_are_the_models_draws_in_order():
    """Replaying the env's generator through the model's functions (the scenario, the paths,
    then per slot a report and a measured rate) gives the env's reports, its clipped report
    features and its measured rates."""
    env = RandomIOSUAVEnv(RANGES, knowledge="reports", report_sigma=12.0)
    observations, _, _ = fly(env, 8, ACTIONS)
    rng = np.random.default_rng(8)
    cfg = sample_scenario(rng, RANGES)
    assert cfg == env.config
    paths = node_paths(cfg, rng)
    np.testing.assert_array_equal(paths, env.paths)
    lo, hi = (b[0] for b in node_bounds(cfg))
    q = env.trajectory
    for n in range(cfg.N):
        report = position_reports(paths[n], rng, 12.0)
        measured = measured_rates(cfg, q[n : n + 1], paths[n : n + 1], np.array([0]), rng)[0]
        clipped = np.clip(report[0], lo - REPORT_CLIP * 12.0, hi + REPORT_CLIP * 12.0)
        np.testing.assert_array_equal(env.reports[n, 0], clipped)
        # the LoS phase 2 pi d / lambda is ~3e4 rad: one ulp of it moves cos/sin by ~1e-12
        np.testing.assert_allclose(env.measured_rates[n], measured, rtol=1e-9)
        feature = np.float32((clipped - q[n]) / env.options.length_scale)
        np.testing.assert_array_equal(observations[n][4:6], feature)
        assert observations[n][10] == np.float32(min(measured, env._rate_clip))


def test_what_each_knowledge_mode_tells():
    exact, rates = IOSUAVEnv(SHORT, knowledge="exact"), IOSUAVEnv(SHORT, knowledge="rates")
    obs_exact, _, _ = fly(exact, 2, ACTIONS)
    obs_rates, _, _ = fly(rates, 2, ACTIONS)
    q, w = exact.trajectory, exact.paths[:, 0]
    np.testing.assert_array_equal(np.array(obs_exact)[:, 4:6], np.float32((w - q) / 400.0))
    truth = node_rates(SHORT, q, exact.paths)[0]
    np.testing.assert_allclose(np.array(obs_exact)[:, 10], truth.astype(np.float32), rtol=1e-6)
    assert np.isnan(exact.measured_rates).all() and np.isnan(exact.reports).all()
    assert not np.array(obs_rates)[:, 4:6].any()  # no position at all
    np.testing.assert_array_equal(np.array(obs_rates)[:, 10], rates.measured_rates.astype(np.float32))
    assert np.isnan(rates.reports).all()


def test_a_still_node_through_the_mobile_path_is_the_static_env():
    """Motion with zero speed and spread keeps the node in place: the per-slot kernels are then
    the static kernel bit for bit, so the episode is today's env's, observation for observation."""
    still = SHORT.replace(motion=GaussMarkov(speed=0.0, sigma=0.0))
    mobile, static = IOSUAVEnv(still), IOSUAVEnv(SHORT.replace(motion=None))
    assert mobile.mobile and not static.mobile
    obs_m, rew_m, info_m = fly(mobile, 0, ACTIONS)
    obs_s, rew_s, info_s = fly(static, 0, ACTIONS)
    assert rew_m == rew_s and info_m["average_rate"] == info_s["average_rate"]
    # the node features: float64 (w - q) / L here, the kernel's own float32 cast there
    np.testing.assert_allclose(np.array(obs_m), np.array(obs_s), rtol=1e-6, atol=1e-7)
    np.testing.assert_array_equal(np.array(obs_m)[:, 6:], np.array(obs_s)[:, 6:])


def test_reports_are_clipped_to_the_widened_rectangle():
    rng = np.random.default_rng(0)
    track = start_track(SHORT, rng, sigma=1e5)  # a report 100 km off
    told, _ = observe_slot(track, 0, np.zeros(2), "reports", 1e5, np.inf, rng)
    assert np.all(told >= track.lo) and np.all(told <= track.hi)
    lo, hi = (b[0] for b in node_bounds(SHORT))
    np.testing.assert_allclose(track.hi - hi, REPORT_CLIP * 1e5)
    np.testing.assert_allclose(lo - track.lo, REPORT_CLIP * 1e5)
    _, rate = observe_slot(track, 1, np.zeros(2), "rates", 1e5, 1e-9, rng)  # the space's rate bound
    assert rate == 1e-9 and track.measured[1] > 1e-9  # the record keeps the unclipped sample


def test_observations_stay_in_the_space_with_noisy_reports_and_fading():
    """(The measured rates are the faded samples: the Rician channel with them is refused.)"""
    with pytest.raises(
        ValueError, match="channel='rician', knowledge='reports'.* a measured rate is the slot's own"
    ):
        RandomIOSUAVEnv(RANGES, knowledge="reports", channel="rician")
    env = RandomIOSUAVEnv(RANGES, knowledge="reports", report_sigma=40.0)
    for seed in range(3):
        observations, _, _ = fly(env, seed, ACTIONS)
        assert all(env.observation_space.contains(o) for o in observations)


def test_the_batch_is_the_single_envs_step_for_step():
    from tests.envs.test_single_vector import replay

    kwargs = {"knowledge": "reports", "report_sigma": 20.0}
    vec = RandomIOSUAVVectorEnv(3, RANGES, **kwargs)
    singles = [RandomIOSUAVEnv(RANGES, **kwargs) for _ in range(3)]
    actions = np.random.default_rng(1).uniform(-1.4, 1.4, (110, 3, 2))
    assert replay(vec, singles, actions, seed=7) <= 1e-9


def test_a_node_drawn_next_to_the_ios_plane_walks_from_its_margin():
    """A node drawn within plane_margin of the IOS plane (x = 0) is moved out to the margin on its
    side (it would start outside its motion rectangle); the other draws are unchanged."""
    base = SHORT.replace(motion=GaussMarkov())
    for x, side in ((0.4, 1.0), (-0.2, -1.0), (0.0, 1.0)):
        ranges = ScenarioRanges(ground_x=(x, x), ground_y=(5.0, 5.0), base=base)
        drawn = sample_scenario(0, ranges)
        assert drawn.ground_node == (side * base.motion.plane_margin, 5.0)
        if x != 0.0:  # the static config refuses a node on the plane
            still = sample_scenario(0, dataclasses.replace(ranges, base=base.replace(motion=None)))
            assert dataclasses.replace(drawn, ground_node=still.ground_node, motion=None) == still
    far = ScenarioRanges(ground_x=(3.0, 3.0), base=base)
    assert sample_scenario(0, far).ground_node[0] == 3.0
    # the mobile id's batched resets draw such nodes among 256 rows (seed 0 did before)
    gym.make_vec(MOBILE_ID, num_envs=256, vectorization_mode="vector_entry_point").reset(seed=0)


def test_errors_name_the_field():
    with pytest.raises(ValueError, match="knowledge must be one of"):
        IOSUAVEnv(knowledge="psychic")
    with pytest.raises(ValueError, match="report_sigma"):
        IOSUAVEnv(SHORT, knowledge="reports", report_sigma=-1.0)
    with pytest.raises(ValueError, match="peak_hint"):
        IOSUAVEnv(SHORT, peak_hint=True)
    with pytest.raises(ValueError, match="motion model"):
        IOSUAVEnv(SHORT.replace(motion=None)).reset(options={"config": SHORT})
    env = IOSUAVEnv(SHORT, knowledge="reports")
    wide = SHORT.replace(motion=GaussMarkov(box=((-2000.0, 2000.0), (-2000.0, 2000.0))))
    with pytest.raises(ValueError, match="motion rectangle"):
        env.reset(options={"config": wide})


@pytest.mark.parametrize("knowledge", ["exact", "reports", "rates"])
def test_every_mobile_suite_scenario_fits_the_mobile_ids_space(knowledge):
    """A pinned scenario of the family is accepted whatever it draws, also one whose rate bound
    is the family's own (the space's float32 rounding of the same value must not refuse it)."""
    from ios_uav_env.benchmark.suite import load_suite

    env = gym.make(MOBILE_ID, knowledge=knowledge).unwrapped
    for scenario in load_suite("mobile-v1"):
        env.check_scenario(scenario.config)


def test_the_filter_estimate_is_the_kalman_filter_of_the_raw_reports():
    """filter_estimate: features 4-5 are NodeFilter's estimate after each raw report (replayed
    from the generator), clipped as a report is; closer to the truth than the reports."""
    from ios_uav_env.model.kalman import NodeFilter

    sigma = 20.0
    env = IOSUAVEnv(SHORT, knowledge="reports", report_sigma=sigma, filter_estimate=True)
    observations, _, _ = fly(env, 5, ACTIONS)
    rng = np.random.default_rng(5)
    paths = node_paths(SHORT, rng)
    lo, hi = (b[0] for b in node_bounds(SHORT))
    q, told, filt = env.trajectory, [], None
    for n in range(SHORT.N):
        report = position_reports(paths[n], rng, sigma)
        rng.standard_normal(2)  # the measured rate's draws
        filt = NodeFilter.start(SHORT, report, sigma) if filt is None else (filt.step(report) or filt)
        estimate = np.clip(filt.position[0], lo - REPORT_CLIP * sigma, hi + REPORT_CLIP * sigma)
        np.testing.assert_array_equal(observations[n][4:6], np.float32((estimate - q[n]) / 400.0))
        told.append(estimate)
    error = np.linalg.norm(np.array(told) - paths[:, 0], axis=1).mean()
    raw = np.linalg.norm(env.reports[:, 0] - paths[:, 0], axis=1).mean()
    assert error < 0.7 * raw
    with pytest.raises(ValueError, match="filter_estimate .* needs knowledge='reports'"):
        IOSUAVEnv(SHORT, filter_estimate=True)
