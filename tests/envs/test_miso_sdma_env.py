"""The SDMA flight ids (``ios_uav_env/MISOUAV-SDMA-v0``, ``-Random-v0``; ``envs.miso_sdma``): the
worlds they run and the ones refused, the slot the env sets (the lattice weight's setting, below
its bound, one of the scorer's), the reward's telescoping to N min_k R_k, the final score equal
to ``score_plan`` of the flight and never below the env's own max-min, seeded reproduction and
the batched form's rows equal to the single env seeded seed + i, bit for bit."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from agents.scores import score_label
from ios_uav_env import MISO_SDMA_ID, MISO_SDMA_RANDOM_ID, ScenarioConfig, score_plan
from ios_uav_env.components import UnsupportedWorld, World
from ios_uav_env.envs.miso_sdma import SDMA_CONFIG, SDMA_CONFIGS
from ios_uav_env.envs.registration import MISO_SDMA_K3_ID, MISO_SDMA_K4_ID
from ios_uav_env.envs.worlds import make_world
from ios_uav_env.model.miso import tdma_rates
from ios_uav_env.model.miso_sdma import slot_channel_at, slot_points, weight_lattice
from tests.envs.test_star_noma import run
from tests.tolerances import PLANNER_REL

#: The SDMA scenario's surface, users and radio on a short flight (5 slots: fast to score).
SMALL = SDMA_CONFIG.replace(T=5.0, q0=(-250.0, -40.0), qF=(-250.0, 40.0))
MULTI_ID = "ios_uav_env/IOSUAV-MultiNode-v0"
FOUR = {"antennas": 4, "ground_nodes": SDMA_CONFIG.ground_nodes}
LINK = {"kind": "multi_antenna", "antennas": 4}


def test_the_ids_run_the_sdma_scenario_and_the_random_id_draws_its_line():
    env = gym.make(MISO_SDMA_ID)
    assert env.unwrapped.config == SDMA_CONFIG and env.unwrapped.view == "miso_sdma"
    assert env.action_space.shape == (3,) and env.observation_space.shape == (16,)
    assert env.unwrapped.observation_names[0] == "sdma_x"
    assert score_label(env).name == "min_rate"  # (the training scripts' label: a max-min of two users)
    random = gym.make(MISO_SDMA_RANDOM_ID, score=False)
    lines = {random.reset(seed=seed)[1]["position_x"] for seed in range(3)}
    assert len(lines) == 3 and all(-250.0 <= x <= -100.0 for x in lines)


def test_the_world_rule_lifts_only_what_the_env_runs():
    assert [World(link=LINK, nodes=k).check().nodes for k in (2, 3, 4)] == [2, 3, 4]
    refused = [
        World(link=LINK, nodes=5),
        World(link=LINK, nodes=2, motion="gauss_markov"),
        World(link=LINK, nodes=2, surface="ris"),
        World(link=LINK, nodes=2, objective="energy_efficiency"),
    ]
    for world in refused:
        with pytest.raises(UnsupportedWorld, match=r"multi_antenna with several nodes.*MISOUAV-SDMA-v0"):
            world.check()
    with pytest.raises(UnsupportedWorld, match=rf"{MULTI_ID}.*multi_antenna with several.*MISOUAV-SDMA-v0"):
        gym.make(MULTI_ID, config=ScenarioConfig(**FOUR))
    env = make_world(World(link=LINK, nodes=2))
    assert env.spec.id == MISO_SDMA_ID and env.unwrapped.config == SDMA_CONFIG


def test_the_sdma_id_refuses_what_it_does_not_run_naming_the_field():
    five = ((10.0, -10.0), (-120.0, -10.0), (-60.0, 30.0), (20.0, 30.0), (-30.0, -60.0))
    cases = [
        ({"antennas": 1}, r"antennas must be an integer in \[2, 64\]"),
        ({"ground_nodes": five}, r"ground_nodes must be K in \[2, 4\] users.*got K = 5"),
        ({"ios_shape": (20, 20)}, r"ios_shape must have M = M_y M_z in \[1, 256\]"),
        ({"surface": "ris"}, r"multi_antenna with several nodes"),
        ({"energy_budget_j": 1e6}, r"energy_budget_j must be None"),
        ({"channel": "rician"}, r"channel is an option this env does not have"),
        ({"frontier_points": 9}, r"frontier_points is the NOMA STAR env's argument"),
        ({"score": 1}, r"score must be True or False"),
    ]
    for kwargs, message in cases:
        with pytest.raises(ValueError, match=message):
            gym.make(MISO_SDMA_ID, **kwargs)
    with pytest.raises(ValueError, match=r"MISOUAV-SDMA-Random-v0 draws its line"):
        gym.make(MISO_SDMA_RANDOM_ID, q0=(-200.0, -150.0))
    env = gym.make(MISO_SDMA_ID, config=SMALL)
    with pytest.raises(ValueError, match=r"options\[\"config\"\].*antennas must be"):
        env.reset(options={"config": SMALL.replace(antennas=1)})


def test_each_slot_is_the_lattice_weights_setting_one_of_the_scorers():
    env = gym.make(MISO_SDMA_ID, config=SMALL, score=False)
    env.reset(seed=0)
    lattice = weight_lattice(2)
    for a_w, step in ((-1.0, (0.0, 1.0)), (1.0, (0.0, 1.0)), (0.3, (0.0, 1.0)), (5.0, (0.0, 1.0))):
        _, _, _, _, info = env.step(np.array([*step, a_w]))
        w = info["weight"]
        j = int(np.flatnonzero(lattice[:, 0] == w)[0])  # the weight is a lattice point
        assert abs(w - (min(a_w, 1.0) + 1.0) / 2.0) <= 1 / 16
        rates = np.array([info["slot_rate_0"], info["slot_rate_1"]])
        assert info["slot_value"] == pytest.approx(w * rates[0] + (1 - w) * rates[1], rel=1e-12)
        assert info["slot_value"] <= info["slot_upper"]
        q = np.array([[info["position_x"], info["position_y"]]])
        assert np.array_equal(rates, slot_points(SMALL, q)[0][0, j])  # the scorer's own setting
        if w in (0.0, 1.0):  # one user, served alone at its aligned phases with MRT
            k = 0 if w == 1.0 else 1
            alone = tdma_rates(slot_channel_at(SMALL, q[0]))
            assert rates[k] == pytest.approx(alone[k], rel=1e-12) and rates[1 - k] == 0.0


def test_the_score_is_score_plan_of_the_flight_and_bounds_the_envs_own_max_min():
    out = run(gym.make(MISO_SDMA_ID, config=SMALL), 0)
    final = out["infos"][-1]
    assert len(out["rewards"]) == SMALL.N - 1 and final["slot"] == SMALL.N
    assert np.array_equal(out["trajectory"][[0, -1]], np.array([SMALL.q0, SMALL.qF]))
    assert final["score"] == score_plan(SMALL, out["trajectory"]).rate
    assert all(info["score"] == 0.0 for info in out["infos"][:-1])
    assert final["min_rate"] <= final["score"] * (1 + PLANNER_REL)
    # the rewards telescope to N min_k R_k
    assert sum(out["rewards"]) == pytest.approx(SMALL.N * final["min_rate"], rel=PLANNER_REL)


@pytest.mark.parametrize("users", [2, 4])
def test_seeded_episodes_reproduce_bit_for_bit(users):
    kwargs = {"T": 13.0, "score": False, "users": users}
    a, b = (run(gym.make(MISO_SDMA_RANDOM_ID, **kwargs), 5) for _ in range(2))
    c = run(gym.make(MISO_SDMA_RANDOM_ID, **kwargs), 6)
    for key in ("obs", "rewards"):
        assert all(np.array_equal(x, y) for x, y in zip(a[key], b[key], strict=True))
    assert all(np.array_equal(x[k], y[k], equal_nan=True)
               for x, y in zip(a["infos"], b["infos"], strict=True) for k in x)  # fmt: skip
    assert np.array_equal(a["trajectory"], b["trajectory"]) and np.array_equal(a["weights"], b["weights"])
    assert not np.array_equal(a["trajectory"], c["trajectory"])


#: (id, keywords) of short flights of 2, 3 and 4 users.
BATCHED = [
    (MISO_SDMA_ID, {"config": SMALL}),
    (MISO_SDMA_K3_ID, {"config": SMALL.replace(ground_nodes=SDMA_CONFIGS[3].ground_nodes)}),
    (MISO_SDMA_K4_ID, {"config": SMALL.replace(ground_nodes=SDMA_CONFIGS[4].ground_nodes)}),
]


@pytest.mark.parametrize(("env_id", "kwargs"), BATCHED, ids=["K2", "K3", "K4"])
def test_the_batched_rows_are_the_single_env_seeded_seed_plus_i(env_id, kwargs):
    """Row i of ``gym.make_vec`` is the single env reset with seed + i and given row i's actions,
    bit for bit, across an autoreset."""
    kwargs = {**kwargs, "score": False}
    b, seed, steps = 2, 11, 6  # 4 steps an episode: every row ends one and starts another
    vec = gym.make_vec(env_id, num_envs=b, vectorization_mode="vector_entry_point", **kwargs)
    size = vec.single_action_space.shape[0]
    actions = np.random.default_rng(0).uniform(-1, 1, (steps, b, size)).astype(np.float32)
    obs, info = vec.reset(seed=seed)
    batch = [(obs, None, None, info)]
    for t in range(steps):
        obs, reward, terminated, _, info = vec.step(actions[t])
        batch.append((obs, reward, terminated, info))
    for i in range(b):
        env = gym.make(env_id, **kwargs)
        obs, info = env.reset(seed=seed + i)
        rows, ended = [(obs, None, None, info)], False
        for t in range(steps):
            if ended:  # (next-step autoreset)
                obs, info = env.reset()
                rows.append((obs, 0.0, False, info))
                ended = False
                continue
            obs, reward, ended, _, info = env.step(actions[t, i])
            rows.append((obs, reward, ended, info))
        for (b_obs, b_rew, b_term, b_info), (s_obs, s_rew, s_term, s_info) in zip(batch, rows, strict=True):
            assert np.array_equal(b_obs[i], s_obs)
            if b_rew is not None:
                assert b_rew[i] == s_rew and bool(b_term[i]) == s_term
            assert all(np.array_equal(b_info[k][i], v, equal_nan=True) for k, v in s_info.items())
