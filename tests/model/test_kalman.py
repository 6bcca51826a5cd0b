"""The Kalman filter of the node positions: its covariance is its error, it beats the raw reports."""

import math

import numpy as np
import pytest

from ios_uav_env import ScenarioConfig
from ios_uav_env.model.kalman import NodeFilter, transition
from ios_uav_env.model.motion import GaussMarkov, node_paths
from ios_uav_env.model.reports import position_reports

K_NODES = 1500  # independent nodes of one scenario: the Monte Carlo samples, run as one filter
OPEN = ((-1e6, -1.0), (-1e6, 1e6))  # a box whose walls no node reaches: the linear model holds


def _crowd(heading=None, **motion):
    nodes = tuple((-300.0 + 0.1 * i, 0.0) for i in range(K_NODES))
    return ScenarioConfig(
        ground_nodes=nodes, ios_shape=(4, 4), T=30.0, q0=(-300.0, 20.0), qF=(300.0, 20.0),
        motion=GaussMarkov(heading=heading, box=OPEN, **motion),
    )  # fmt: skip


def _run(config, seed, sigma=10.0):
    rng = np.random.default_rng(seed)
    paths = node_paths(config, rng)
    reports = position_reports(paths, rng, sigma)
    f = NodeFilter.start(config, reports[0], sigma)
    err, raw, mse = [], [], []
    for n in range(config.N):
        if n:
            f.step(reports[n])
        err.append(np.sum((f.position - paths[n]) ** 2, axis=1))  # (K,) squared errors
        raw.append(np.sum((reports[n] - paths[n]) ** 2, axis=1))
        mse.append(f.position_mse)
    return np.array(err), np.array(raw), np.array(mse), f, paths


ERRATIC = {"memory": 0.6, "sigma": 4.0}


@pytest.mark.parametrize(("heading", "motion"), [(None, {}), (0.7, {}), (None, ERRATIC)])
def test_error_matches_the_covariance_and_beats_the_reports(heading, motion):
    """Over many nodes the mean squared position error at slots 1, 2, 5, 10 and N equals the
    trace of the filter's covariance within 5 standard errors, and it shrinks with reports
    (pedestrians, a known heading, and erratic walkers whose process noise dominates)."""
    config = _crowd(heading, **motion)
    err, raw, mse, _, _ = _run(config, seed=1)
    for n in (0, 1, 4, 9, config.N - 1):
        se = err[n].std() / math.sqrt(K_NODES)
        assert abs(err[n].mean() - mse[n]) < 5 * se, (n, err[n].mean(), mse[n], se)
    assert mse[0] == pytest.approx(2 * 10.0**2)  # the first report alone
    assert np.all(np.diff(mse[:5]) < 0) and mse[-1] < 0.5 * mse[0]
    assert err[-1].mean() < 0.5 * raw[-1].mean()  # the filter beats the raw report
    if heading is not None:  # a known heading: less to learn, a smaller error
        assert mse[-1] < _run(_crowd(None), seed=1)[2][-1]


def test_static_nodes_average_the_reports():
    config = ScenarioConfig(ground_nodes=((-100.0, 0.0), (50.0, 30.0)), ios_shape=(4, 4))
    rng = np.random.default_rng(0)
    z = position_reports(np.broadcast_to(np.asarray(config.nodes), (6, 2, 2)), rng, 10.0)
    f = NodeFilter.start(config, z[0], 10.0)
    for n in range(1, 6):
        f.step(z[n])
    np.testing.assert_allclose(f.position, z.mean(axis=0), rtol=0, atol=1e-9)
    assert f.position_var == pytest.approx(100.0 / 6)
    np.testing.assert_allclose(f.predict_paths(3), np.broadcast_to(f.position, (3, 2, 2)), atol=1e-9)


def test_predicted_paths_follow_the_mean_motion():
    """predict_paths(s) is F^s applied to the mean: with a known heading, speed s dt per slot in
    the heading's direction once the velocity has relaxed; the filter's state is unchanged."""
    config = _crowd(0.0, memory=0.5, sigma=0.2)
    err, _, _, f, paths = _run(config, seed=2)
    before = (f.mean.copy(), f.cov.copy(), f.slot)
    ahead = f.predict_paths(40)
    assert ahead.shape == (40, K_NODES, 2)
    np.testing.assert_allclose(ahead[-1] - ahead[-2], [[config.motion.speed * config.dt, 0.0]] * K_NODES,
                               atol=1e-6)  # fmt: skip
    f_, _ = transition(config)
    np.testing.assert_allclose(ahead[0], (f.mean @ f_.T)[:, :, 0])
    assert np.array_equal(f.mean, before[0]) and np.array_equal(f.cov, before[1]) and f.slot == before[2]


def test_the_estimate_is_mirrored_at_the_walls():
    box = ((-60.0, -1.0), (-50.0, 50.0))
    motion = GaussMarkov(heading=0.0, box=box)
    config = ScenarioConfig(ground_node=(-30.0, 0.0), ios_shape=(4, 4), motion=motion)
    f = NodeFilter.start(config, np.array([[-3.0, 0.0]]), 10.0)
    ahead = f.predict_paths(60)
    assert np.all((ahead[..., 0] >= -60.0) & (ahead[..., 0] <= -1.0))
    assert ahead[-1, 0, 0] < ahead[0, 0, 0]  # walked into the wall at x = -1 m and back


def test_bad_inputs_are_refused():
    config = _crowd()
    with pytest.raises(ValueError, match="reports must be"):
        NodeFilter.start(config, np.zeros((3, 2)))
    with pytest.raises(ValueError, match="report_sigma must be > 0"):
        NodeFilter.start(config, np.zeros((K_NODES, 2)), 0.0)
    f = NodeFilter.start(config, np.zeros((K_NODES, 2)))
    with pytest.raises(ValueError, match="steps"):
        f.predict_paths(-1)
