"""``NearestWorstNode`` on one UAV with walking nodes (ios_uav_env/benchmark/fleet_policies.py): the
tracker of several told node positions that the multi-node memory recipe clones
(``agents/hyperparams/fast_ppo_memory_multi.yml``), with its ``travel`` term."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env  # noqa: F401  (registers the ids)
from ios_uav_env import MULTINODE_MOBILE_ID
from ios_uav_env.benchmark.fleet_policies import NearestWorstNode
from ios_uav_env.envs.rollout import run_episode

#: The stored row of MPC(k=10) (the tour re-planned every 10 slots) on multi-node-mobile-v1, mean %
#: of the clairvoyant optimum (``python -m ios_uav_env.benchmark show --suite multi-node-mobile-v1``).
MPC_K10_MEAN = 65.91


@pytest.fixture(scope="module")
def env() -> gym.Env:
    return gym.make(MULTINODE_MOBILE_ID, filter_estimate=True)


def _obs(names: tuple[str, ...], **features: float) -> np.ndarray:
    obs = np.zeros(len(names), dtype=np.float32)
    for name, value in features.items():
        obs[names.index(name)] = value
    return obs


def test_it_serves_the_node_of_least_service_plus_travel(env):
    """Three nodes: node 0 under the UAV and served 0.5, node 1 served 0.3 one L away, node 2 served
    0 but 6 L away. With travel 0.1 node 1 needs it most (0.4 against 0.5 and 0.6), with travel 0
    the least served (node 2), with travel 1 the one it is on; the padding slot is never chosen.
    It reads the reported ids' served feature (``served_measured_<k>``) and takes a batch."""
    names = env.unwrapped.observation_names
    obs = _obs(names, mask_0=1, mask_1=1, mask_2=1, served_measured_0=0.5, dx_node_1=1.0,
               served_measured_1=0.3, dy_node_2=-6.0, served_measured_2=0.0)  # fmt: skip
    for travel, node in ((0.1, 1), (0.0, 2), (1.0, 0)):
        action = NearestWorstNode(travel=travel).bind(names)(obs)
        assert action.shape == env.action_space.shape and action.dtype == np.float32
        want = np.full(4, -1.0)
        want[node] = 1.0
        np.testing.assert_array_equal(action[2:], want)
    policy = NearestWorstNode(travel=0.1).bind(names)
    np.testing.assert_allclose(policy(obs)[:2], [1.0, 0.0])  # full speed to node 1
    np.testing.assert_array_equal(NearestWorstNode(travel=1.0).bind(names)(obs)[:2], [0.0, 0.0])  # on node 0
    batch = np.stack([obs, obs])
    np.testing.assert_array_equal(policy(batch), np.stack([policy(obs)] * 2))


def test_a_bad_travel_is_refused():
    with pytest.raises(ValueError, match="travel must be a finite number >= 0"):
        NearestWorstNode(travel=-0.1)
    with pytest.raises(ValueError, match="travel must be a finite number >= 0"):
        NearestWorstNode(travel=float("nan"))


def test_an_episode_is_feasible(env):
    episode = run_episode(env, NearestWorstNode(travel=0.2), seed=3)
    assert episode.feasible and episode.terminal_miss < 1e-6 and episode.average_rate > 0.0


def test_with_travel_it_beats_the_tour_mpc_on_the_frozen_suite():
    """On all 24 scenarios of multi-node-mobile-v1 (recorded 69.04 % of the optimum mean, 52.13 p10
    with travel 0.2; 26.54 mean with travel 0, which hops between nodes): above MPC(k=10)'s stored
    mean. The policy computes in float64 (no float32 network); another CPU moves the filtered
    estimates by ~1e-16 relative, far below the 3.1 points of margin."""
    from ios_uav_env.benchmark import evaluate

    a = evaluate(NearestWorstNode(travel=0.2), "multi-node-mobile-v1", env_kwargs={"filter_estimate": True})
    assert a.aggregate.feasible == 24 and a.aggregate.stats["mean_pct_optimum"] > MPC_K10_MEAN


@pytest.mark.parametrize("knowledge", ["exact", "filtered reports"])
def test_the_clairvoyant_optimum_is_above_the_tracker_on_every_scenario(knowledge):
    """The suite's normaliser is the best clairvoyant plan found, not a proven optimum; the online
    task's acceptance is that it holds at least 99.5 % (the grid's resolution) of every online row on
    every scenario, the tracker flown with exact knowledge of the nodes included (a task change,
    scored on the same true paths) and the bound above the optimum. Largest recorded: 97.8 % of the
    optimum (exact) and 90.1 % (filtered), so a normaliser that fell by 3 % on a scenario fails."""
    from ios_uav_env.benchmark import evaluate

    kwargs = {"knowledge": "exact"} if knowledge == "exact" else {"filter_estimate": True}
    res = evaluate(NearestWorstNode(travel=0.2), "multi-node-mobile-v1", env_kwargs=kwargs,
                   allow_task_change=knowledge == "exact")  # fmt: skip
    assert len(res.scenarios) == 24 and all(r.feasible for r in res.scenarios)
    for r in res.scenarios:
        assert r.pct["optimum"] <= 100.0 / 0.995, (r.index, r.pct)
        assert r.pct["bound"] <= r.pct["optimum"], (r.index, r.pct)
