"""The NOMA STAR flight ids (``ios_uav_env/STARUAV-NOMA-v0``, ``-Random-v0``; ``envs.star_noma``):
the worlds they run and the ones still refused, the slot the env sets (a weighted-sum optimum of
the agent's weight, below its bound), the reward's telescoping to N min_k R_k, the final score
equal to ``score_plan`` of the flight and never below the env's own max-min, seeded reproduction
and the batched form's rows equal to the single env seeded seed + i, bit for bit."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from ios_uav_env import STAR_ID, STAR_NOMA_ID, STAR_NOMA_RANDOM_ID, score_plan
from ios_uav_env.components import UnsupportedWorld, World
from ios_uav_env.envs.policies import full_speed_move
from ios_uav_env.envs.rollout import run_episode
from ios_uav_env.envs.star_noma import NOMA_CONFIG
from ios_uav_env.envs.worlds import make_world
from ios_uav_env.model.star_maps import frontier_maps
from tests.tolerances import PLANNER_REL

#: The NOMA scenario's surface and radio on a short flight past a 4 x 4 surface (fast to score).
SMALL = NOMA_CONFIG.replace(ios_shape=(4, 4), T=8.0, q0=(-150.0, -75.0), qF=(-150.0, 75.0))
MULTI_ID = "ios_uav_env/IOSUAV-MultiNode-v0"


def run(env: gym.Env, seed: int, actions_seed: int | None = None) -> dict:
    """One episode of seeded uniform actions: every output and the flight."""
    rng = np.random.default_rng(seed if actions_seed is None else actions_seed)
    obs, info = env.reset(seed=seed)
    out = {"obs": [obs], "rewards": [], "infos": [info]}
    done = False
    while not done:
        action = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
        obs, reward, done, truncated, info = env.step(action)
        assert not truncated
        out["obs"].append(obs)
        out["rewards"].append(reward)
        out["infos"].append(info)
    out["trajectory"] = env.unwrapped.trajectory
    out["weights"] = env.unwrapped.weights
    return out


def test_the_ids_run_the_noma_scenario_and_the_random_id_draws_its_line():
    env = gym.make(STAR_NOMA_ID)
    assert env.unwrapped.config == NOMA_CONFIG and env.unwrapped.view == "star_noma"
    assert env.action_space.shape == (3,) and env.observation_space.shape == (16,)
    random = gym.make(STAR_NOMA_RANDOM_ID)
    lines = set()
    for seed in range(3):
        random.reset(seed=seed)
        cfg = random.unwrapped.config
        assert cfg == NOMA_CONFIG.replace(q0=(cfg.q0[0], -150.0), qF=(cfg.q0[0], 150.0))
        assert -250.0 <= cfg.q0[0] <= -100.0
        lines.add(cfg.q0[0])
    assert len(lines) == 3


def test_the_world_rule_lifts_only_what_the_env_runs():
    """World: NOMA with two static, exactly known nodes, expected gains and the rate objective
    passes; NOMA with one or three nodes, moving nodes, fading or a budget is refused, naming the
    components. Envs: the NOMA id runs, the STAR id (one node) and the multi-node id (TDMA steps)
    refuse NOMA, the multi-node one naming the NOMA id."""
    star = {"kind": "star", "access": "noma"}
    assert World(surface=star, nodes=2).check().nodes == 2
    refused = [
        World(surface=star, nodes=1),
        World(surface=star, nodes=3),
        World(surface=star, nodes=2, motion="gauss_markov"),
        World(surface=star, nodes=2, link={"kind": "single_antenna", "fading": "rician"}),
        World(surface=star, nodes=2, objective={"kind": "rate", "budget_j": 1e4}),
        World(surface=star, nodes=2, objective="energy_efficiency"),
    ]
    for world in refused:
        with pytest.raises(UnsupportedWorld, match=r"surface star \(noma\).*STARUAV-NOMA-v0") as err:
            world.check()
        assert all(f"{family} {kind}" in str(err.value) for family, kind in world.names().items())
    with pytest.raises(ValueError, match=rf"{STAR_ID}.*'noma', the field star_access.*star_regions"):
        gym.make(STAR_ID, star_access="noma")
    with pytest.raises(ValueError, match=rf"{MULTI_ID}.*surface star \(noma\).*one node per slot.*NOMA-v0"):
        gym.make(MULTI_ID, config=NOMA_CONFIG)
    gym.make(MULTI_ID, config=NOMA_CONFIG.replace(star_access="tdma"))  # (TDMA runs there)


def test_the_noma_id_refuses_what_it_does_not_run_naming_the_field():
    cases = [
        ({"star_access": "tdma"}, r"surface='star' and star_access='noma'"),
        ({"surface": "ios"}, r"surface='star' and star_access='noma'"),
        ({"ground_nodes": ((-5.0, 2.0), (-8.0, 1.0))}, r"ground_nodes must be one user on each side"),
        ({"ground_nodes": ((-5.0, 2.0), (5.0, 1.0), (6.0, 0.0))}, r"surface star \(noma\).*K = 3"),
        ({"channel": "rician"}, r"channel is an option this env does not have"),
        ({"peak_hint": True}, r"peak_hint is an option"),
        ({"frontier_points": 1}, r"frontier_points must be an integer >= 2"),
        ({"score": 1}, r"score must be True or False"),
    ]
    for kwargs, message in cases:
        with pytest.raises(ValueError, match=message):
            gym.make(STAR_NOMA_ID, **kwargs)
    with pytest.raises(ValueError, match=r"STARUAV-NOMA-Random-v0 draws its line"):
        gym.make(STAR_NOMA_RANDOM_ID, q0=(-200.0, -150.0))
    env = gym.make(STAR_NOMA_ID, config=SMALL)
    with pytest.raises(ValueError, match=r"options\[\"config\"\].*star_access='noma'"):
        env.reset(options={"config": SMALL.replace(star_access="tdma")})
    env.reset(seed=0)
    for bad in (np.zeros(2), np.array([0.0, np.nan, 0.0])):
        with pytest.raises(ValueError, match="action must"):
            env.step(bad)


def test_each_slot_is_the_weighted_sum_optimum_of_the_agents_weight():
    """Slot rates: a setting's (w . rates = slot_value <= slot_upper); the weight read as
    (a + 1) / 2; at the extremes the whole surface and all the power go to one user; the rates are
    frontier_maps' at the slot's position."""
    env = gym.make(STAR_NOMA_ID, config=SMALL)
    env.reset(seed=0)
    for a_w, step in ((-1.0, (0.0, 0.8)), (1.0, (0.1, 0.8)), (0.2, (-0.5, 0.6)), (5.0, (0.0, 0.8))):
        _, _, _, _, info = env.step(np.array([*step, a_w]))
        w = (min(a_w, 1.0) + 1.0) / 2.0
        rates = np.array([info["slot_rate_0"], info["slot_rate_1"]])
        assert info["weight"] == w
        assert info["slot_value"] == pytest.approx(w * rates[0] + (1 - w) * rates[1], rel=1e-12)
        assert info["slot_value"] <= info["slot_upper"]
        q = np.array([[info["position_x"], info["position_y"]]])
        maps = frontier_maps(SMALL, q, np.asarray(SMALL.nodes))
        assert np.array_equal(rates, maps.weighted_sum(np.array([w, 1 - w]))[2][:, 0])
        alone = np.log2(1 + maps.full_snr[:, 0])
        if w in (0.0, 1.0):  # one user served alone, with everything
            k = 0 if w == 1.0 else 1
            assert rates[k] == pytest.approx(alone[k], rel=1e-12) and rates[1 - k] == 0.0


@pytest.mark.parametrize("seed", [0, 1])
def test_the_score_is_score_plan_of_the_flight_and_bounds_the_envs_own_max_min(seed):
    env = gym.make(STAR_NOMA_ID, config=SMALL)
    out = run(env, seed)
    final = out["infos"][-1]
    assert len(out["rewards"]) == SMALL.N - 1 and final["slot"] == SMALL.N
    assert np.array_equal(out["trajectory"][[0, -1]], np.array([SMALL.q0, SMALL.qF]))
    assert score_plan(SMALL, out["trajectory"]).report.feasible
    assert final["score"] == score_plan(SMALL, out["trajectory"]).rate
    assert all(info["score"] == 0.0 for info in out["infos"][:-1])
    assert final["min_rate"] <= final["score"] * (1 + PLANNER_REL)
    # the rewards telescope to N min_k R_k (a sum of differences of running minima)
    assert sum(out["rewards"]) == pytest.approx(SMALL.N * final["min_rate"], rel=PLANNER_REL)
    assert final["min_rate"] == min(final["rate_0"], final["rate_1"])
    unscored = run(gym.make(STAR_NOMA_ID, config=SMALL, score=False), seed)
    assert np.isnan(unscored["infos"][-1]["score"])


def test_seeded_episodes_reproduce_bit_for_bit():
    a, b = (run(gym.make(STAR_NOMA_RANDOM_ID, ios_shape=(4, 4), score=False), 5) for _ in range(2))
    c = run(gym.make(STAR_NOMA_RANDOM_ID, ios_shape=(4, 4), score=False), 6)
    for key in ("obs", "rewards"):
        assert all(np.array_equal(x, y) for x, y in zip(a[key], b[key], strict=True))
    assert all(x[k] is not None and np.array_equal(x[k], y[k], equal_nan=True)
               for x, y in zip(a["infos"], b["infos"], strict=True) for k in x)  # fmt: skip
    assert np.array_equal(a["trajectory"], b["trajectory"]) and np.array_equal(a["weights"], b["weights"])
    assert not np.array_equal(a["trajectory"], c["trajectory"])


@pytest.mark.parametrize(
    ("env_id", "mode"), [(STAR_NOMA_ID, "next_step"), (STAR_NOMA_RANDOM_ID, "same_step")]
)
def test_the_batched_rows_are_the_single_env_seeded_seed_plus_i(env_id, mode):
    """Row i of ``gym.make_vec`` is the single env reset with seed + i and given row i's actions,
    bit for bit (observations, rewards, terminations, every info value), across an autoreset."""
    kwargs = {"ios_shape": (4, 4), "T": 14.0}
    b, seed, steps = 3, 11, 16  # 13 steps an episode: every row ends one and starts another
    vec = gym.make_vec(env_id, num_envs=b, vectorization_mode="vector_entry_point", autoreset_mode=mode,
                       **kwargs)  # fmt: skip
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (steps, b, 3)).astype(np.float32)
    obs, info = vec.reset(seed=seed)
    batch = [(obs, None, None, info)]
    for t in range(steps):
        obs, reward, terminated, _, info = vec.step(actions[t])
        batch.append((obs, reward, terminated, info))
    for i in range(b):
        env = gym.make(env_id, **kwargs)
        obs, info = env.reset(seed=seed + i)
        rows = [(obs, None, None, info)]
        ended = False
        for t in range(steps):
            if ended and mode == "next_step":
                obs, info = env.reset()
                rows.append((obs, 0.0, False, info))
                ended = False
                continue
            obs, reward, ended, _, info = env.step(actions[t, i])
            if ended and mode == "same_step":
                final = info
                obs, info = env.reset()
                assert all(np.array_equal(batch[t + 1][3]["final_info"][k][i], v, equal_nan=True)
                           for k, v in final.items())  # fmt: skip
            rows.append((obs, reward, ended, info))
        for (b_obs, b_rew, b_term, b_info), (s_obs, s_rew, s_term, s_info) in zip(batch, rows, strict=True):
            assert np.array_equal(b_obs[i], s_obs)
            if b_rew is not None:
                assert b_rew[i] == s_rew and bool(b_term[i]) == s_term
            assert all(np.array_equal(b_info[k][i], v, equal_nan=True) for k, v in s_info.items())


def test_run_episode_scores_a_policy_with_score_plan():
    """The rollout every agent is evaluated by (``rollout.run_episode``) scores a NOMA flight as the
    env's final info does: ``score_plan`` of the trajectory, no TDMA shares."""
    env = gym.make(STAR_NOMA_ID, config=SMALL)
    episode = run_episode(env, lambda obs: np.array([0.3, 1.0, obs[10] > obs[14]], dtype=np.float32), seed=0)
    assert env.unwrapped.shares is None and episode.feasible and episode.steps == SMALL.N - 1
    assert episode.average_rate == score_plan(SMALL, env.unwrapped.trajectory).rate
    assert episode.average_rate == env.unwrapped.rows.flight_score(0)


def test_fly_steps_the_rows_at_weight_one_half():
    """``fly`` (hidden full-speed moves) on the NOMA batch: the rows flown are the single env given
    the same moves with a_w = 0 (w = 1/2), bit for bit; the other rows do not move."""
    vec = gym.make_vec(STAR_NOMA_ID, num_envs=2, vectorization_mode="vector_entry_point", config=SMALL)
    vec.reset(seed=0)
    target = np.array([-120.0, -40.0])
    obs = vec.unwrapped.fly([1], [target], [2])
    env = gym.make(STAR_NOMA_ID, config=SMALL)
    single, _ = env.reset(seed=1)
    for _ in range(2):
        move = full_speed_move((target - env.unwrapped.trajectory[-1])[None], np.array([[SMALL.D]]))[0]
        single, *_ = env.step(np.array([*move, 0.0]))
    assert np.array_equal(vec.unwrapped.trajectories[1], env.unwrapped.trajectory)
    assert np.array_equal(obs[1], single) and len(vec.unwrapped.trajectories[0]) == 1


def test_make_world_runs_a_noma_world_in_the_noma_id():
    world = World(surface={"kind": "star", "access": "noma"}, nodes=2)
    env = make_world(world)
    assert env.spec.id == STAR_NOMA_ID and env.unwrapped.config == NOMA_CONFIG
    batch = make_world(world, SMALL, num_envs=2)
    assert batch.envs[0].view == "star_noma" and batch.configs[0] == SMALL
    with pytest.raises(UnsupportedWorld, match=r"surface star \(noma\)"):
        make_world(World(surface={"kind": "star", "access": "noma"}, nodes=3))
