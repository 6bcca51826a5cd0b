"""The reachable rate peak (ios_uav_env/model/peak.py) and the env's ``peak_hint`` features."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from ios_uav_env import (
    RANDOM_ENV_ID,
    ScenarioConfig,
    check_trajectory,
    rate_peak,
    sample_scenario,
    slot_rates,
)
from ios_uav_env.envs.observation import INSTANCE_NAMES, OBS_NAMES, PEAK_NAMES
from ios_uav_env.model.peak import reachable

DEFAULT = ScenarioConfig()
SMALL = DEFAULT.replace(ios_shape=(100, 20))  # M = 2000: quicker, same geometry


def random_reachable(config: ScenarioConfig, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    pts = rng.uniform((-600.0, -400.0), (600.0, 400.0), size=(n, 2))
    return pts[reachable(config, pts)]


def test_paper_scenario_peak_is_the_transmissive_hover_point():
    peak = rate_peak(DEFAULT)
    # the IA plan hovers at (100, 0) (results/claims.md): the rate map's best point there
    assert (peak.x, peak.y) == pytest.approx((100.0, 0.0), abs=1.0)
    assert peak.rate == pytest.approx(slot_rates(DEFAULT, np.array([peak.x, peak.y]))[0], rel=1e-12)


@pytest.mark.parametrize("surface", ["ios", "ris", "none"])
def test_no_reachable_point_beats_the_peak(surface):
    cfg = SMALL.replace(surface=surface, ground_node=(60.0, 40.0), T=80.0)
    peak = rate_peak(cfg)
    assert reachable(cfg, np.array([[peak.x, peak.y]]))[0]
    rates = slot_rates(cfg, random_reachable(cfg, 4000, seed=1))
    assert rates.max() <= peak.rate + 1e-3  # the fine grid is 1 m: a random point may edge it by a hair
    assert rates.max() >= peak.rate - 0.05  # and the samples do come near it (the test can fail)


def test_a_higher_uav_widens_the_search_to_the_surfaces_farther_peak():
    # at 250 m the surface's link peaks ~300 m from the IOS: beyond a fixed 200 m box
    cfg = SMALL.replace(uav_altitude=250.0, ground_node=(30.0, 0.0), q0=(-400, 150), qF=(400, 150))
    peak = rate_peak(cfg)
    assert peak.x < -250.0  # a fixed 200 m box around the IOS and G ends at x = -200
    rates = slot_rates(cfg, random_reachable(cfg, 4000, seed=2))
    assert rates.max() <= peak.rate + 1e-3
    assert rate_peak(cfg, margin=200.0).rate < 0.9 * peak.rate  # what the fixed box found (-13%)


def test_a_far_away_ground_node_keeps_the_search_within_reach():
    import time

    cfg = SMALL.replace(surface="none", ground_node=(50_000.0, 0.0))
    start = time.perf_counter()
    peak = rate_peak(cfg)
    assert time.perf_counter() - start < 5.0  # a box around G would have ~10^8 points
    assert reachable(cfg, np.array([[peak.x, peak.y]]))[0] and peak.x > 300.0  # as near G as it can


def test_without_a_surface_the_peak_is_above_g():
    cfg = DEFAULT.replace(surface="none", ground_node=(37.0, -52.0))
    peak = rate_peak(cfg)
    assert (peak.x, peak.y) == pytest.approx((37.0, -52.0), abs=0.5)


def test_an_out_of_reach_g_gives_a_peak_on_the_reach_boundary_that_fly_hover_fly_visits():
    from baselines.fixed import fly_hover_fly

    cfg = SMALL.replace(surface="none", ground_node=(0.0, 150.0), T=36.0, q0=(-400, -100), qF=(400, -100))
    peak = rate_peak(cfg)
    assert not reachable(cfg, np.array([cfg.ground_node]))[0]
    assert reachable(cfg, np.array([[peak.x, peak.y]]))[0] and peak.y < 150.0
    plan = fly_hover_fly(cfg, (peak.x, peak.y))
    assert check_trajectory(cfg, plan.trajectory).feasible
    assert np.min(np.linalg.norm(plan.trajectory - [peak.x, peak.y], axis=1)) < 1e-9  # it gets there


def test_peak_is_deterministic_and_validates_its_arguments():
    assert rate_peak(SMALL) == rate_peak(SMALL)
    for kwargs, match in (
        ({"resolution": 0}, "resolution"),
        ({"resolution": float("nan")}, "resolution"),
        ({"margin": -1.0}, "margin"),
        ({"refine": 10.0}, "refine"),
        ({"refine": -1.0}, "refine"),
    ):
        with pytest.raises(ValueError, match=match):
            rate_peak(SMALL, **kwargs)


# --- the env's peak_hint ---------------------------------------------------------------------
def test_peak_hint_appends_the_peak_relative_to_the_uav():
    env = gym.make("ios_uav_env/IOSUAV-v0", peak_hint=True, config=SMALL)
    assert env.observation_space.shape == (len(OBS_NAMES) + len(PEAK_NAMES),) == (14,)
    peak = rate_peak(SMALL)
    obs, _ = env.reset(seed=0)
    for _ in range(5):
        q = env.unwrapped.trajectory[-1]
        np.testing.assert_allclose(obs[11:13] * 400.0 + q, (peak.x, peak.y), atol=1e-3)
        assert obs[13] == pytest.approx(peak.rate, rel=1e-6)
        assert env.observation_space.contains(obs)
        obs, *_ = env.step(np.array([0.7, -0.3], dtype=np.float32))


def test_random_env_with_peak_hint_passes_the_checker_and_follows_each_scenario():
    env = gym.make(RANDOM_ENV_ID, peak_hint=True)
    assert env.observation_space.shape == (len(OBS_NAMES) + len(INSTANCE_NAMES) + len(PEAK_NAMES),) == (20,)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)
    plain = gym.make(RANDOM_ENV_ID)
    for seed in range(3):
        obs, _ = env.reset(seed=seed)
        base, _ = plain.reset(seed=seed)
        assert np.array_equal(obs[:17], base)  # the hint only appends
        peak = rate_peak(env.unwrapped.config)
        np.testing.assert_allclose(obs[17:19] * 400.0 + env.unwrapped.config.q0, (peak.x, peak.y), atol=1e-3)
    cfg = sample_scenario(np.random.default_rng(5))
    obs, _ = env.reset(options={"config": cfg})
    assert obs[19] == pytest.approx(rate_peak(cfg).rate, rel=1e-6)


def test_bad_peak_hint_is_refused():
    with pytest.raises(ValueError, match="peak_hint"):
        gym.make("ios_uav_env/IOSUAV-v0", peak_hint="yes")


def test_the_compiled_search_finds_the_same_peaks():
    from ios_uav_env.model.channel import rate_kernel

    rng = np.random.default_rng(3)
    for _ in range(8):
        cfg = sample_scenario(rng)
        pts = random_reachable(cfg, 200, 0)
        np.testing.assert_allclose(rate_kernel(cfg).rates(pts), slot_rates(cfg, pts), rtol=1e-12)
        for side in (None, "front", "behind"):
            a, b = rate_peak(cfg, side=side), rate_peak(cfg, side=side, compiled=True)
            assert (a is None) == (b is None)
            if a is not None:
                assert (a.x, a.y) == (b.x, b.y) and a.rate == pytest.approx(b.rate, rel=1e-12)
