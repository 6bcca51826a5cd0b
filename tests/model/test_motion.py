"""Node motion: the Gauss-Markov paths, the motion field of the config, rates and scores on paths."""

import json
import math

import numpy as np
import pytest

import ios_uav_env as ie
from ios_uav_env import ScenarioConfig
from ios_uav_env.benchmark.suite import SUITES, load_suite, suite_path
from ios_uav_env.model.motion import (
    GaussMarkov,
    node_bounds,
    node_config_at,
    node_paths,
    reflect,
    static_paths,
)
from ios_uav_env.model.reports import measured_rates, position_reports

NODES = ((-100.0, -20.0), (150.0, 30.0))
SMALL = {"ios_shape": (10, 6), "T": 40.0, "q0": (-300.0, 20.0), "qF": (300.0, 20.0)}


def _line(config):
    frac = np.arange(config.N) / (config.N - 1)
    return np.asarray(config.q0) + frac[:, None] * (np.asarray(config.qF) - np.asarray(config.q0))


def _moving(**motion):
    return ScenarioConfig(ground_nodes=NODES, motion=GaussMarkov(**motion), **SMALL)


# --- the config field --------------------------------------------------------------------


def test_static_default_is_left_out_of_to_dict():
    d = ScenarioConfig().to_dict()
    assert "motion" not in d
    explicit = ScenarioConfig(motion=None)
    assert explicit.to_dict() == d and explicit == ScenarioConfig()
    assert hash(explicit) == hash(ScenarioConfig())


def test_shipped_suites_configs_are_unchanged():
    """Every shipped config reads back as written; the static suites' carry no motion (the
    static default is left out of to_dict), the mobile suite's every one a motion."""
    for name in SUITES:
        records = json.loads(suite_path(name).read_text())["scenarios"]
        suite = load_suite(name)  # checks the file's registered hash
        for rec, scenario in zip(records, suite, strict=True):
            assert scenario.config.to_dict() == rec["config"]
            assert ("motion" in rec["config"]) == suite.mobile


def test_motion_round_trips_through_json():
    config = _moving(memory=0.8, speed=2.0, heading=0.5, sigma=0.3, box=((-400, 400), (-200, 200)))
    d = json.loads(json.dumps(config.to_dict()))
    assert d["motion"]["kind"] == "gauss_markov" and d["motion"]["box"] == [[-400.0, 400.0], [-200.0, 200.0]]
    back = ScenarioConfig.from_dict(d)
    assert back == config and hash(back) == hash(config) and isinstance(back.motion, GaussMarkov)
    assert config.replace(motion=None).to_dict().keys() == d.keys() - {"motion"}


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"memory": 1.0}, "memory must be a number in \\[0, 1\\)"),
        ({"memory": -0.1}, "memory"),
        ({"speed": -1.0}, "speed must be a finite number >= 0"),
        ({"sigma": math.nan}, "sigma"),
        ({"heading": "north"}, "heading"),
        ({"box": ((10, -10), (0, 1))}, "box must be"),
        ({"plane_margin": -1.0}, "plane_margin"),
        ({"plane_margin": 0.0}, "plane_margin must be a finite number > 0"),
    ],
)
def test_bad_motion_fields_are_refused(fields, message):
    with pytest.raises(ValueError, match=message):
        GaussMarkov(**fields)


def test_bad_motion_values_in_the_config_are_refused():
    with pytest.raises(ValueError, match="motion must be None"):
        ScenarioConfig(motion="walk")
    with pytest.raises(ValueError, match="unknown fields"):
        ScenarioConfig(motion={"memory": 0.5, "mass": 70})
    with pytest.raises(ValueError, match="starts outside its motion rectangle"):  # node outside the box
        ScenarioConfig(ground_nodes=NODES, motion=GaussMarkov(box=((-50, 200), (-50, 50))), **SMALL)
    with pytest.raises(ValueError, match="ground_nodes\\[0\\].*plane_margin"):  # inside the plane's strip
        ScenarioConfig(ground_nodes=((-0.5, 0.0), NODES[1]), motion=GaussMarkov(), **SMALL)
    with pytest.raises(ValueError, match="is empty"):  # the box lies on the other side of the plane
        ScenarioConfig(ground_node=(-100.0, 0.0), motion=GaussMarkov(box=((-0.5, 300), (-50, 50))), **SMALL)


# --- the paths ---------------------------------------------------------------------------


def test_static_paths_repeat_the_positions_and_draw_nothing():
    config = ScenarioConfig(ground_nodes=NODES, **SMALL)
    rng = np.random.default_rng(3)
    state = rng.bit_generator.state
    paths = node_paths(config, rng)
    assert paths.shape == (config.N, 2, 2) and np.array_equal(paths, static_paths(config))
    assert np.all(paths == np.asarray(NODES)) and rng.bit_generator.state == state


def test_paths_are_reproducible_from_the_generator():
    config = _moving()
    a, b = node_paths(config, np.random.default_rng(7)), node_paths(config, np.random.default_rng(7))
    assert np.array_equal(a, b) and not np.array_equal(a, node_paths(config, np.random.default_rng(8)))
    assert a.shape == (config.N, 2, 2) and np.array_equal(a[0], np.asarray(NODES))


def test_paths_follow_the_recursion_in_open_space():
    """Away from the walls w[n+1] - w[n] = v[n] dt with the draws of the module docstring."""
    motion = GaussMarkov(box=((-1e5, -1.0), (-1e5, 1e5)))
    config = ScenarioConfig(ground_node=NODES[0], motion=motion, **SMALL)
    m = config.motion
    paths = node_paths(config, np.random.default_rng(11))
    rng = np.random.default_rng(11)
    theta = rng.uniform(0, 2 * math.pi, 1)
    mean = m.speed * np.column_stack([np.cos(theta), np.sin(theta)])
    v = mean + m.sigma * rng.standard_normal((1, 2))
    w = np.asarray([NODES[0]])
    for n in range(config.N - 1):
        w = w + v * config.dt
        noise = math.sqrt(1 - m.memory**2) * m.sigma * rng.standard_normal((1, 2))
        v = m.memory * v + (1 - m.memory) * mean + noise
        np.testing.assert_allclose(paths[n + 1], w, rtol=0, atol=1e-9)


def test_stationary_speed_statistics():
    """Many nodes: the displacement per slot has mean m_k dt and std sigma dt per component."""
    k_nodes = 400
    nodes = tuple((-200.0 + 0.1 * i, 0.0) for i in range(k_nodes))
    config = ScenarioConfig(
        ground_nodes=nodes, ios_shape=(4, 4), T=30.0, q0=(-300.0, 20.0), qF=(300.0, 20.0),
        motion=GaussMarkov(heading=0.0, box=((-1e5, -1.0), (-1e5, 1e5))),
    )  # fmt: skip
    steps = np.diff(node_paths(config, np.random.default_rng(0)), axis=0)  # (N - 1, K, 2): v[n] dt
    m = config.motion
    se = m.sigma / math.sqrt(steps[:, :, 0].size)
    assert abs(steps[..., 0].mean() - m.speed) < 5 * se * math.sqrt(2 / (1 - m.memory))
    assert abs(steps[..., 1].mean()) < 5 * se * math.sqrt(2 / (1 - m.memory))
    # every slot's velocity has the stationary std sigma (each slot: K independent nodes)
    assert np.all(np.abs(steps[..., 1].std(axis=1) / m.sigma - 1) < 5 / math.sqrt(2 * k_nodes))


def test_nodes_stay_in_their_rectangle_and_off_the_plane():
    """A fast, noisy walk in a small box: every position inside the node's rectangle, on its own
    side of the IOS plane at least plane_margin away."""
    box = ((-60.0, 60.0), (-40.0, 40.0))
    config = ScenarioConfig(
        ground_nodes=((-30.0, 0.0), (20.0, 10.0)), motion=GaussMarkov(speed=8.0, sigma=6.0, box=box), **SMALL
    )
    paths = np.concatenate([node_paths(config, np.random.default_rng(s)) for s in range(5)])
    lo, hi = node_bounds(config)
    assert np.all((paths >= lo) & (paths <= hi))
    assert np.all(paths[:, 0, 0] <= -1.0) and np.all(paths[:, 1, 0] >= 1.0)
    assert np.ptp(paths[:, 0, 0]) > 30  # the nodes do move: the walls bound a real walk


def test_reflect_mirrors_and_flips():
    lo, hi = np.array([0.0]), np.array([10.0])
    p, flip = reflect(np.array([12.0]), lo, hi)
    assert p[0] == 8.0 and flip[0]
    p, flip = reflect(np.array([-3.0]), lo, hi)
    assert p[0] == 3.0 and flip[0]
    p, flip = reflect(np.array([-15.0]), lo, hi)  # mirrored twice: direction kept
    assert p[0] == 5.0 and not flip[0]
    p, flip = reflect(np.array([10.0]), lo, hi)
    assert p[0] == 10.0 and not flip[0]


# --- rates and scores on paths -----------------------------------------------------------


def test_static_paths_give_todays_rates_and_scores_bit_for_bit():
    config = ScenarioConfig(ground_nodes=NODES, **SMALL)
    q = _line(config)
    paths = static_paths(config)
    assert np.array_equal(ie.node_rates(config, q, paths), ie.node_rates(config, q))
    shares = np.full((2, config.N), 0.5)
    for s in (None, shares):
        a, b = ie.score_plan(config, q, s, paths), ie.score_plan(config, q, s)
        assert a.rate == b.rate and a.best_schedule_rate == b.best_schedule_rate
    one = ScenarioConfig(**SMALL)
    assert ie.score_plan(one, _line(one), paths=static_paths(one)).rate == ie.average_rate(one, _line(one))


def test_rates_on_paths_use_each_slots_position():
    config = _moving()
    q = _line(config)
    paths = node_paths(config, np.random.default_rng(2))
    rates = ie.node_rates(config, q, paths)
    for n in (0, 7, config.N - 1):
        for k in range(2):
            single = node_config_at(config, k, paths[n, k])
            assert single.ground_node == tuple(paths[n, k]) and single.motion is None
            # the compiled per-slot kernel against numpy's sum over the surface nodes
            assert rates[k, n] == pytest.approx(ie.slot_rates(single, q[n : n + 1])[0], rel=1e-12)
    assert not np.array_equal(rates, ie.node_rates(config, q))
    # the scorer on the true paths: its own shares, and the best schedule, both from these rates
    shares = np.vstack([np.ones(config.N), np.zeros(config.N)])
    shares[:, ::2] = shares[::-1, ::2]
    own = ie.score_plan(config, q, shares, paths)
    assert own.rate == pytest.approx(np.mean(shares * rates, axis=1).min(), rel=1e-12)
    assert own.best_schedule_rate == pytest.approx(ie.maxmin_schedule(rates).value, rel=1e-12)
    assert own.best_schedule_rate >= own.rate


@pytest.mark.parametrize(
    "fields",
    [
        {"surface": "ios"},
        {"surface": "ris"},
        {"surface": "none"},
        {"quadrature_nodes": 0},
        {"ios_shape": (40, 30)},
    ],
)
def test_path_kernels_are_each_slots_rate_kernel_bit_for_bit(fields):
    """One projection for every slot (only the surface weights and G's coordinates and side
    depend on G): the same arrays as a config per position, compressed or exact, any surface."""
    config = _moving().replace(**fields)
    path = node_paths(config, np.random.default_rng(4))[:, 1]
    nodes, params = ie.path_kernels(config.node_config(1), path)
    for n in range(config.N):
        kernel = ie.rate_kernel(node_config_at(config, 1, path[n]))
        np.testing.assert_array_equal(nodes[n], kernel.nodes)
        np.testing.assert_array_equal(params[n], kernel.params)
    rates = ie.rates_of_rows(_line(config), nodes, params)
    np.testing.assert_allclose(
        rates,
        ie.node_rates(config, _line(config), node_paths(config, np.random.default_rng(4)))[1],
        rtol=1e-12,
    )  # compiled vs numpy sums
    with pytest.raises(ValueError, match="grounds"):
        ie.path_kernels(config.node_config(1), np.zeros((3, 3)))
    # written into given arrays (a wider track's views): the same bits, its padding left alone
    wide, scalars = np.full((config.N, 3, nodes.shape[2] + 2), 7.0), np.zeros_like(params)
    got = ie.path_kernels(config.node_config(1), path, out=(wide[:, :, : nodes.shape[2]], scalars))
    assert np.array_equal(got[0], nodes) and got[1] is scalars and np.array_equal(scalars, params)
    assert np.all(wide[:, :, nodes.shape[2] :] == 7.0)
    with pytest.raises(ValueError, match="out must hold arrays of shapes"):
        ie.path_kernels(config.node_config(1), path, out=(wide, scalars))


def test_bad_paths_are_refused():
    config = _moving()
    q = _line(config)
    with pytest.raises(ValueError, match="paths must have shape"):
        ie.node_rates(config, q, np.zeros((config.N, 3, 2)))
    with pytest.raises(ValueError, match="finite"):
        ie.score_plan(config, q, paths=np.full((config.N, 2, 2), np.nan))


# --- reports -----------------------------------------------------------------------------


def test_position_reports_have_the_stated_noise():
    truth = np.zeros((2000, 2))
    z = position_reports(truth, np.random.default_rng(0), sigma=10.0)
    assert abs(z.std() / 10.0 - 1) < 5 / math.sqrt(2 * z.size)
    assert np.array_equal(position_reports(truth, np.random.default_rng(0), sigma=0.0), truth)
    with pytest.raises(ValueError, match="sigma"):
        position_reports(truth, np.random.default_rng(0), sigma=-1.0)


def test_measured_rates_are_the_channels_faded_draws():
    config = _moving()
    q = _line(config)
    paths = node_paths(config, np.random.default_rng(1))
    served = np.arange(config.N) % 2
    got = measured_rates(config, q, paths, served, np.random.default_rng(5))
    rng = np.random.default_rng(5)
    for n in range(config.N):
        node = node_config_at(config, int(served[n]), paths[n, served[n]])
        # the env's scalar draw (RateKernel.faded_rate: real, then imaginary part of h_SS)
        assert got[n] == pytest.approx(ie.rate_kernel(node).faded_rate(*q[n], rng), rel=1e-12)
    # Rician fading about the expected gain: the mean faded rate sits below the expected-gain rate
    # (Jensen) and close to it for kappa = 3
    many = measured_rates(config, np.repeat(q[:1], config.N, 0), np.repeat(paths[:1], config.N, 0),
                          np.zeros(config.N, int), np.random.default_rng(9))  # fmt: skip
    expected = ie.node_rates(config, q[:1], paths[:1])[0, 0]
    assert many.std() > 0 and many.mean() < expected * 1.05
    with pytest.raises(ValueError, match="served"):
        measured_rates(config, q, paths, np.full(config.N, 2), np.random.default_rng(0))
