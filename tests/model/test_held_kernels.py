"""``channel.hold_path_kernels``: while its handle lives, ``path_kernels`` of the same config and
path returns copies of the held kernels instead of projecting the surface again (the multi-node
env's score of an episode finds its track's kernels), the same arrays bit for bit."""

from __future__ import annotations

import gc

import numpy as np
import pytest

import ios_uav_env as ie
from ios_uav_env.envs.multi import MultiNodeEnv
from ios_uav_env.model import channel, rate_kernels, surface
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.motion import node_paths
from ios_uav_env.model.schedule import reported_maxmin_rate

WALK = {"kind": "gauss_markov"}
CONFIG = ScenarioConfig(T=40.0, ios_shape=(100, 20), ground_nodes=((40.0, 30.0), (-50.0, 60.0)), motion=WALK)


@pytest.fixture
def projections(monkeypatch):
    """The number of surface projections (``surface.ground_weights`` calls) made so far."""
    calls = []
    real = surface.ground_weights

    def counted(*args):
        calls.append(1)
        return real(*args)

    monkeypatch.setattr(rate_kernels, "ground_weights", counted)
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


def test_the_episode_score_reuses_the_tracks_kernels(projections):
    env = MultiNodeEnv(CONFIG, knowledge="reports")
    env.reset(seed=3)
    # the scenario's static node kernels (every node from one projection: model.node_kernels),
    # then the track's kernels, one projection per node
    assert len(projections) == 1 + CONFIG.K
    actions = np.random.default_rng(3).uniform(-1.0, 1.0, (CONFIG.N, 2 + CONFIG.K))
    terminated, t = False, 0
    while not terminated:
        _, _, terminated, _, info = env.step(actions[t])
        t += 1
    assert len(projections) == 1 + CONFIG.K  # the episode's best schedule projected nothing new
    kept = env.track.held
    env.track.held = ()  # (drop the handles: the score then projects the paths again)
    del kept
    gc.collect()
    fresh = reported_maxmin_rate(env.config, env.trajectory, env.truth)
    assert len(projections) == 1 + 2 * CONFIG.K
    assert info["best_schedule_rate"] == fresh  # bit for bit
