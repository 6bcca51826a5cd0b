"""The SDMA flights of three and four users (``ios_uav_env/MISOUAV-SDMA-K3-v0``, ``-K4-v0``, the
keyword ``users``; ``envs.miso_sdma``): their scenarios and spaces, the refusals naming the
allowed range, the action's weights (the normalised shifted scores, then the nearest lattice
point, checked against a brute force over the lattice), each slot one of the scorer's settings,
the final score equal to ``score_plan`` and never below the env's own max-min. Seeded reproduction
and the batched rows: ``test_miso_sdma_env.py`` (parametrised over K)."""

from __future__ import annotations

import itertools
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from ios_uav_env import MISO_SDMA_ID, MISO_SDMA_RANDOM_ID, score_plan
from ios_uav_env.components import World
from ios_uav_env.envs.miso_sdma import SDMA_CONFIGS
from ios_uav_env.envs.registration import MISO_SDMA_K3_ID, MISO_SDMA_K4_ID
from ios_uav_env.envs.worlds import make_world
from ios_uav_env.model.miso import tdma_rates
from ios_uav_env.model.miso_sdma import slot_channel_at, slot_points
from tests.envs.test_star_noma import run
from tests.tolerances import PLANNER_REL

IDS = {3: MISO_SDMA_K3_ID, 4: MISO_SDMA_K4_ID}
LINK = {"kind": "multi_antenna", "antennas": 4}


def small(users: int):
    """The K-user scenario on a short flight (5 slots: fast to score)."""
    return SDMA_CONFIGS[users].replace(T=5.0, q0=(-250.0, -40.0), qF=(-250.0, 40.0))


def lattice_brute_force(users: int, levels: int) -> np.ndarray:
    """Every point of the simplex with coordinates multiples of 1 / levels (any order)."""
    rows = [c for c in itertools.product(range(levels + 1), repeat=users) if sum(c) == levels]
    return np.array(rows, dtype=float) / levels


@pytest.mark.parametrize("users", [3, 4])
def test_the_k_user_ids_run_their_scenario_with_a_block_per_user(users):
    env = gym.make(IDS[users])
    config = env.unwrapped.config
    assert config == SDMA_CONFIGS[users] and config.K == users and env.unwrapped.view == "miso_sdma"
    assert config.ground_nodes[:2] == SDMA_CONFIGS[2].ground_nodes  # (K = 2's users first)
    assert {x > 0 for x, _ in config.ground_nodes} == {True, False}  # both sides of the plane x = 0
    assert env.action_space.shape == (2 + users,) and env.observation_space.shape == (8 + 4 * users,)
    names = env.unwrapped.observation_names
    assert len(names) == 8 + 4 * users and names[-1] == f"sdma_rate_{users - 1}"
    assert gym.make(MISO_SDMA_ID, users=users).unwrapped.config == config  # the keyword, on the K = 2 id
    random = gym.make(MISO_SDMA_RANDOM_ID, users=users, score=False)
    obs, info = random.reset(seed=3)
    assert random.unwrapped.config.ground_nodes == config.ground_nodes and obs.shape == (8 + 4 * users,)
    assert -250.0 <= info["position_x"] <= -100.0
    world = make_world(World(link=LINK, nodes=users))
    assert world.unwrapped.config == config


def test_the_k_user_envs_refuse_what_they_do_not_run_naming_the_range():
    five = (*SDMA_CONFIGS[4].ground_nodes, (-30.0, -60.0))
    cases = [
        (MISO_SDMA_ID, {"users": 5}, r"users must be an integer in \[2, 4\].*got 5"),
        (MISO_SDMA_ID, {"users": 1}, r"users must be an integer in \[2, 4\]"),
        (MISO_SDMA_ID, {"users": True}, r"users must be an integer in \[2, 4\]"),
        (
            MISO_SDMA_K3_ID,
            {"ground_nodes": five},
            r"MISOUAV-SDMA-K3-v0 \(config\): ground_nodes must be K in \[2, 4\]",
        ),
        (MISO_SDMA_K3_ID, {"ground_nodes": SDMA_CONFIGS[2].ground_nodes}, r"users=3, but .* K = 2"),
        (MISO_SDMA_K4_ID, {"ios_shape": (20, 20)}, r"ios_shape must have M = M_y M_z in \[1, 256\]"),
        (MISO_SDMA_K4_ID, {"antennas": 1}, r"antennas must be an integer in \[2, 64\]"),
    ]
    for env_id, kwargs, message in cases:
        with pytest.raises(ValueError, match=message):
            gym.make(env_id, **kwargs)
    with pytest.raises(ValueError, match=r"unsupported world.*K in \[2, 4\]"):
        World(link=LINK, nodes=5).check()
    env = gym.make(MISO_SDMA_K3_ID, config=small(3))
    with pytest.raises(ValueError, match=r"options\[\"config\"\]: ground_nodes must be K = 3 users"):
        env.reset(options={"config": small(4)})
    with pytest.raises(ValueError, match=r"action must have shape \(5,\)"):
        env.reset(seed=0)
        env.step(np.zeros(3))
    vec = gym.make_vec(MISO_SDMA_K3_ID, num_envs=2, vectorization_mode="vector_entry_point", score=False)
    vec.reset(seed=0)
    with pytest.raises(
        ValueError, match=r"actions must have shape \(2, 5\) \(the move, then 3 user weights\)"
    ):
        vec.step(np.zeros((2, 3)))


@pytest.mark.parametrize(("users", "levels"), [(3, 4), (4, 2)])
def test_each_slot_is_the_nearest_lattice_weights_setting_one_of_the_scorers(users, levels):
    config = small(users)
    env = gym.make(IDS[users], config=config, score=False)
    _, info = env.reset(seed=0)
    lattice = lattice_brute_force(users, levels)
    rng = np.random.default_rng(1)
    vertex = -np.ones(users)
    vertex[users - 1] = 0.2  # user K - 1 alone
    scores = [vertex, -np.ones(users), rng.uniform(-1, 1, users), rng.uniform(-3, 3, users)]
    for a_w in scores:
        _, _, _, _, info = env.step(np.array([0.0, 1.0, *a_w]))
        w = np.array([info[f"weight_{k}"] for k in range(users)])
        p = (np.clip(a_w, -1, 1) + 1) / 2
        target = p / p.sum() if p.sum() > 0 else np.full(users, 1 / users)
        distances = np.linalg.norm(lattice - target, axis=1)
        assert w.sum() == pytest.approx(1.0, rel=1e-12)
        assert np.min(np.linalg.norm(lattice - w, axis=1)) <= 1e-12  # a lattice point,
        assert np.linalg.norm(w - target) <= distances.min() + 1e-12  # the nearest one
        rates = np.array([info[f"slot_rate_{k}"] for k in range(users)])
        assert (
            info["slot_value"] == pytest.approx(w @ rates, rel=1e-12)
            and info["slot_value"] <= info["slot_upper"]
        )
        q = np.array([[info["position_x"], info["position_y"]]])
        points = slot_points(config, q)[0][0]
        assert any(np.array_equal(rates, row) for row in points)  # the scorer's own setting
    weights = env.unwrapped.weights
    assert weights.shape == (config.N, users)
    np.testing.assert_array_equal(weights[1], np.eye(users)[users - 1])  # the vertex: user K - 1 alone
    np.testing.assert_array_equal(weights[2], weights[0])  # every a_k = -1: as slot 1, users alike


@pytest.mark.parametrize("users", [3, 4])
def test_a_vertex_serves_its_user_alone(users):
    config = small(users)
    env = gym.make(IDS[users], config=config, score=False)
    env.reset(seed=0)
    for k in range(users):
        a = -np.ones(2 + users)
        a[:2], a[2 + k] = (0.0, 0.5), 1.0
        _, _, _, _, info = env.step(a)
        rates = np.array([info[f"slot_rate_{j}"] for j in range(users)])
        alone = tdma_rates(slot_channel_at(config, np.array([info["position_x"], info["position_y"]])))
        assert info[f"weight_{k}"] == 1.0 and rates[k] == pytest.approx(alone[k], rel=1e-12)
        assert np.all(np.delete(rates, k) == 0.0)
        if info["slot"] == config.N:
            break


@pytest.mark.parametrize("users", [3, 4])
def test_the_score_is_score_plan_of_the_flight_and_bounds_the_envs_own_max_min(users):
    config = small(users)
    out = run(gym.make(IDS[users], config=config), 0)
    final = out["infos"][-1]
    assert len(out["rewards"]) == config.N - 1 and final["slot"] == config.N
    assert np.array_equal(out["trajectory"][[0, -1]], np.array([config.q0, config.qF]))
    assert final["score"] == score_plan(config, out["trajectory"]).rate
    assert all(info["score"] == 0.0 for info in out["infos"][:-1])
    rates = [final[f"rate_{k}"] for k in range(users)]
    assert final["min_rate"] == min(rates) and final["min_rate"] <= final["score"] * (1 + PLANNER_REL)
    assert sum(out["rewards"]) == pytest.approx(config.N * final["min_rate"], rel=PLANNER_REL)


@pytest.mark.parametrize("users", [3, 4])
def test_the_random_id_of_k_users_passes_the_checker_and_stays_in_its_space(users):
    env = gym.make(MISO_SDMA_RANDOM_ID, users=users, score=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=True)
    for seed in (0, 1):
        out = run(env, seed)
        assert all(env.observation_space.contains(obs) for obs in out["obs"])
        assert out["trajectory"][0, 0] == out["trajectory"][-1, 0]  # the drawn line's x, start and end
