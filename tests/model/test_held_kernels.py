"""``channel.hold_path_kernels``: while its handle lives, ``path_kernels`` of the same config and
path returns copies of the held kernels instead of projecting the surface again (the multi-node
env's score of an episode finds its track's kernels), the same arrays bit for bit. A moving-node
episode projects the surface once at reset (its track's kernels, every node's path in one call,
each node's rows its own ``path_kernels``; no static kernels that the track overwrites), and the
batched env's score takes the track's kernels as they are
(``schedule.node_rates``' ``kernels``)."""

from __future__ import annotations

import gc

import numpy as np
import pytest

import ios_uav_env as ie
from ios_uav_env.envs.knowledge import start_nodes_track
from ios_uav_env.envs.multi import MultiNodeEnv
from ios_uav_env.envs.multi_vector import MultiNodeVectorEnv
from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model import channel, rate_kernels, schedule, surface
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.motion import node_paths
from ios_uav_env.model.scenarios import ScenarioRanges
from ios_uav_env.model.schedule import node_rates, reported_maxmin_rate
from tests.tolerances import PLANNER_REL

WALK = {"kind": "gauss_markov"}
CONFIG = ScenarioConfig(T=40.0, ios_shape=(100, 20), ground_nodes=((40.0, 30.0), (-50.0, 60.0)), motion=WALK)


@pytest.fixture
def projections(monkeypatch):
    """The number of surface projections made so far (``surface.ground_weights`` calls, and the
    ``surface.path_weights_into`` calls that wrote a path's weights)."""
    calls = []
    real, real_into = surface.ground_weights, surface.path_weights_into

    def counted(*args):
        calls.append(1)
        return real(*args)

    def counted_into(*args):
        written = real_into(*args)
        if written:
            calls.append(1)
        return written

    monkeypatch.setattr(rate_kernels, "ground_weights", counted)
    monkeypatch.setattr(rate_kernels, "path_weights_into", counted_into)
    return calls


@pytest.fixture
def built(monkeypatch):
    """The paths whose kernels ``schedule`` asked ``path_kernels`` for so far (held or projected)."""
    calls = []
    real = schedule.path_kernels

    def counted(config, grounds):
        calls.append(1)
        return real(config, grounds)

    monkeypatch.setattr(schedule, "path_kernels", counted)
    return calls


def test_held_kernels_are_returned_as_copies_while_their_handle_lives(projections):
    node = CONFIG.node_config(1)
    path = node_paths(CONFIG, np.random.default_rng(2))[:, 1]
    nodes, params = ie.path_kernels(node, path)
    assert len(projections) == 1
    handle = channel.hold_path_kernels(node, path, nodes, params)
    again, again_params = ie.path_kernels(node, path.copy())  # (a path equal by value)
    assert len(projections) == 1
    assert again is not nodes and np.array_equal(again, nodes) and np.array_equal(again_params, params)
    again[:] = 0.0  # a copy: the held kernels do not change
    assert np.array_equal(ie.path_kernels(node, path)[0], nodes)
    ie.path_kernels(node, path + 1.0)  # another path: projected
    ie.path_kernels(CONFIG.node_config(0), path)  # another node: projected
    assert len(projections) == 3
    del handle
    gc.collect()
    fresh, _ = ie.path_kernels(node, path)  # gone with its handle: projected again, the same bits
    assert len(projections) == 4 and np.array_equal(fresh, nodes)


def test_the_episode_score_reuses_the_tracks_kernels(projections, built):
    """The single env's episode score takes its track's kernels as they are (no ``path_kernels``
    call, held or not), equal bit for bit to the score that builds them."""
    env = MultiNodeEnv(CONFIG, knowledge="reports")
    env.reset(seed=3)
    assert len(projections) == 1  # the track's kernels, one projection of every node's path, and no other
    actions = np.random.default_rng(3).uniform(-1.0, 1.0, (CONFIG.N, 2 + CONFIG.K))
    terminated, t = False, 0
    while not terminated:
        _, _, terminated, _, info = env.step(actions[t])
        t += 1
    assert len(projections) == 1 and not built  # the best schedule projected nor asked nothing
    kept = env.track.held
    env.track.held = ()  # (drop the handles: the score then projects the paths again)
    del kept
    gc.collect()
    fresh = reported_maxmin_rate(env.config, env.trajectory, env.truth)
    assert len(projections) == 1 + CONFIG.K  # (the score projects each node's path)
    assert info["best_schedule_rate"] == fresh  # bit for bit


def test_a_moving_episode_projects_once_at_each_reset(projections):
    """Every reset of moving nodes on a new scenario (a drawn one, or a new config pinned) builds
    its track's kernels only: one projection of every node's path, in the single env; the batch's
    rows (compiled) project none at reset (each slot's kernels are computed in the row,
    ``envs.node_weights``), their tracks one when their kernels are first read."""
    ranges = ScenarioRanges(T=(40.0, 60.0), base=ScenarioConfig(motion=WALK))
    env = MultiNodeEnv(random_nodes=(2, 4), ranges=ranges, knowledge="reports")
    for seed in range(3):
        env.reset(seed=seed)
        assert len(projections) == 1
        projections.clear()
    env.reset(options={"config": CONFIG.replace(T=50.0)})
    assert len(projections) == 1
    projections.clear()
    vec = MultiNodeVectorEnv(3, random_nodes=(2, 4), ranges=ranges, knowledge="rates")
    vec.reset(seed=4)
    assert len(projections) == (0 if HAVE_NUMBA else vec.num_envs)
    projections.clear()
    for env in vec.envs:
        assert env.track.nodes.shape[:2] == (env.config.K, env.config.N)
    assert len(projections) == (vec.num_envs if HAVE_NUMBA else 0)


@pytest.mark.parametrize("width", [0, 90])
def test_a_tracks_kernels_are_each_nodes_own_path_kernels(width):
    """The track projects every node's path in one call: node k's kernels are those of
    ``path_kernels(config.node_config(k), paths[:, k])`` bit for bit, padded (width 90) with
    surface nodes of zero weight."""
    track = start_nodes_track(CONFIG, np.random.default_rng(7), 5.0, width)
    track.held = ()  # (no handles: path_kernels below projects each path again)
    gc.collect()
    own = ie.path_kernels(CONFIG.node_config(0), track.paths[:, 0])[0].shape[2]
    assert track.nodes.shape == (CONFIG.K, CONFIG.N, 3, max(width, own))
    for k in range(CONFIG.K):
        nodes, params = ie.path_kernels(CONFIG.node_config(k), track.paths[:, k].copy())
        assert np.array_equal(track.nodes[k, :, :, :own], nodes) and np.array_equal(track.params[k], params)
        assert (track.nodes[k, :, 2, own:] == 0.0).all() and (track.nodes[k, :, 1, own:] == 1.0).all()


def test_the_batched_score_takes_the_tracks_kernels(projections, built):
    """At each episode end the batched env scores a moving row on its track's kernels as they are:
    no surface projected and no kernels asked of ``path_kernels`` (held or not), the value the
    score that builds them gets (to the LP's reassociation)."""
    vec = MultiNodeVectorEnv(2, CONFIG, knowledge="reports")
    vec.reset(seed=5)
    # (one per row; compiled: none, each slot's kernels computed in the row, envs.node_weights)
    made = 0 if HAVE_NUMBA else 2
    assert len(projections) == made
    rng = np.random.default_rng(5)
    for _ in range(CONFIG.N - 1):
        _, _, terminated, _, info = vec.step(rng.uniform(-1.0, 1.0, vec.action_space.shape))
    assert terminated.all() and not built and len(projections) == made
    for i, env in enumerate(vec.envs):
        env.track.held = ()  # (no handles: the score below builds the kernels again)
        fresh = reported_maxmin_rate(env.config, vec.trajectories[i], env.truth)
        # the batched rows solve the max-min LP compiled on the rates they kept, the fresh score
        # by the scorer's own LP: the same optimum, summed in another order
        assert info["best_schedule_rate"][i] == pytest.approx(fresh, rel=PLANNER_REL)
    assert len(built) == 2 * CONFIG.K


def test_node_rates_take_given_kernels_as_they_are(built):
    """``node_rates(..., kernels)``: the rates of the built kernels bit for bit, without building
    them (views of padded arrays included); kernels of the wrong count or shape are refused."""
    q = np.linspace((-100.0, 0.0), (100.0, 50.0), CONFIG.N)
    paths = node_paths(CONFIG, np.random.default_rng(6))
    expected = node_rates(CONFIG, q, paths)
    assert len(built) == CONFIG.K
    kernels = [ie.path_kernels(CONFIG.node_config(k), paths[:, k]) for k in range(CONFIG.K)]
    padded = []
    for nodes, params in kernels:  # (a track's layout: wider arrays, each node's view of its own width)
        wide = np.zeros((*nodes.shape[:2], nodes.shape[2] + 5))
        wide[..., : nodes.shape[2]] = nodes
        padded.append((wide[..., : nodes.shape[2]], params))
    built.clear()
    for given in (kernels, padded):
        assert node_rates(CONFIG, q, paths, given).tobytes() == expected.tobytes()
    assert not built
    with pytest.raises(ValueError, match="one \\(nodes, params\\) pair per node"):
        node_rates(CONFIG, q, paths, kernels[:1])
    with pytest.raises(ValueError, match="node 1's kernels must have shapes"):
        node_rates(CONFIG, q, paths, [kernels[0], (kernels[1][0][:-1], kernels[1][1])])
