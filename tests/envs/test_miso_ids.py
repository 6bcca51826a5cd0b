"""The multi-antenna id (``ios_uav_env/MISOUAV-v0``): the agent flies as in ``IOSUAV-v0`` and the env
sets the beam and the surface's phases at their closed-form joint optimum; its episode is scored by
``score_plan``, one antenna is ``IOSUAV-v0`` bit for bit, and more antennas give more rate."""

from __future__ import annotations

import itertools

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env
from ios_uav_env import MISO_ID, ScenarioConfig, score_plan
from ios_uav_env.components import UnsupportedWorld
from ios_uav_env.model.channel import slot_rates
from tests.envs.test_star_ids import episode, same  # (one seeded episode, and bit-for-bit equality)

IOS_ID = "ios_uav_env/IOSUAV-v0"
SHORT = ScenarioConfig(T=40.0, antennas=4)  # a short mission of the paper's scenario, four antennas


def test_the_id_is_the_papers_scenario_with_four_antennas():
    assert ios_uav_env.MISO_IDS == {MISO_ID: {"antennas": 4}}
    env = gym.make(MISO_ID)
    assert env.unwrapped.config == ScenarioConfig(antennas=4)
    assert env.unwrapped.view == "v0" and env.action_space.shape == (2,)
    assert gym.make(MISO_ID, antennas=8).unwrapped.config.antennas == 8


def test_the_episode_score_is_score_plans():
    """The env's running eq. (9) (the compiled kernel) is ``score_plan``'s on the flown trajectory
    (the model's numpy rate): the same closed form, to rounding."""
    out = episode(gym.make(MISO_ID, T=40.0))
    assert out["config"] == SHORT
    score = score_plan(SHORT, out["trajectory"])
    final = out["infos"][-1]
    assert bool(final["feasible"]) == score.feasible
    assert float(final["average_rate"]) == pytest.approx(score.rate, rel=1e-12)
    rates = [float(info["rate"]) for info in out["infos"]]
    np.testing.assert_allclose(rates, slot_rates(SHORT, out["trajectory"]), rtol=1e-12)


def test_one_antenna_is_the_papers_id_bit_for_bit():
    own = episode(gym.make(MISO_ID, T=40.0, antennas=1))
    assert own["config"] == ScenarioConfig(T=40.0)
    assert same(own, episode(gym.make(IOS_ID, T=40.0)))
    assert not same(own, episode(gym.make(MISO_ID, T=40.0)))  # (the antennas change the episode)


def test_more_antennas_give_more_rate_on_the_same_flight():
    """Doubling N_t never lowers a slot's rate: G(2 N_t) >= 2 N_t (S^2 + a_D^2) >= N_t zeta^2 >= G(N_t)
    (``channel.aligned_gain``); on this flight the mean rate rises strictly."""
    runs = [episode(gym.make(MISO_ID, T=40.0, antennas=n)) for n in (1, 2, 4, 8)]
    flights = [run["trajectory"] for run in runs]
    assert all(np.array_equal(flights[0], f) for f in flights)  # the same actions fly the same path
    rates = [np.array([float(i["rate"]) for i in run["infos"]]) for run in runs]
    for lower, higher in itertools.pairwise(rates):
        assert np.all(higher >= lower) and higher.mean() > lower.mean() + 0.1


def test_a_seed_reproduces_the_episode_bit_for_bit():
    assert same(episode(gym.make(MISO_ID, T=40.0), seed=5), episode(gym.make(MISO_ID, T=40.0), seed=5))


#: A batch equals its rows to rounding, as every v0 id's does (``tests/envs/test_worlds.py``): the
#: batch's compiled step (parallel over rows) is built apart from the single env's, with fastmath, so
#: the node sums may be reassociated differently (~1e-15 relative here), which can flip the last bit
#: of a float32 observation.
BATCH_REL, BATCH_OBS = 1e-12, 1e-6


def test_the_batched_rows_are_the_single_envs_seeded_seed_plus_i():
    vec = gym.make_vec(MISO_ID, num_envs=3, vectorization_mode="vector_entry_point", T=40.0)
    singles = [gym.make(MISO_ID, T=40.0) for _ in range(3)]
    obs, _ = vec.reset(seed=11)
    assert np.array_equal(obs, np.stack([s.reset(seed=11 + i)[0] for i, s in enumerate(singles)]))
    rng = np.random.default_rng(0)
    for _ in range(SHORT.N - 1):
        actions = rng.uniform(-1.0, 1.0, (3, 2)).astype(np.float32)
        obs, reward, terminated, _, info = vec.step(actions)
        for i, s in enumerate(singles):
            o, r, t, _, single_info = s.step(actions[i])
            np.testing.assert_allclose(obs[i], o, rtol=BATCH_OBS, atol=BATCH_OBS)
            assert reward[i] == pytest.approx(r, rel=BATCH_REL) and bool(terminated[i]) == t
            assert info["average_rate"][i] == pytest.approx(single_info["average_rate"], rel=BATCH_REL)
    assert terminated.all()
    vec.close()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"channel": "rician"}, r"MISOUAV-v0.*link multi_antenna with fading 'rician' or measured rates"),
        ({"knowledge": "reports"}, r"link multi_antenna with fading 'rician' or measured rates"),
        ({"ground_nodes": ((-100.0, -20.0), (60.0, 30.0))}, r"K = 2 ground_nodes.*single-node env"),
    ],
)
def test_what_the_closed_form_does_not_model_is_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        gym.make(MISO_ID, **kwargs)


def test_several_nodes_with_antennas_are_refused_by_name_in_the_multi_node_env():
    nodes = ((-100.0, -20.0), (60.0, 30.0))
    with pytest.raises(UnsupportedWorld, match=r"multi_antenna with several nodes.*MISOUAV-SDMA-v0"):
        gym.make("ios_uav_env/IOSUAV-MultiNode-v0", config=ScenarioConfig(ground_nodes=nodes, antennas=4))


@pytest.mark.parametrize("value", [0, 65, 2.5, True])
def test_bad_antennas_are_refused_naming_the_field_and_range(value):
    with pytest.raises(ValueError, match=r"antennas must be an integer in \[1, 64\]"):
        gym.make(MISO_ID, antennas=value)


def test_the_randomised_family_takes_the_antennas_and_its_score_is_score_plans():
    env = gym.make("ios_uav_env/IOSUAV-Random-v0", antennas=4)
    out = episode(env, seed=2)
    assert out["config"].antennas == 4
    final = out["infos"][-1]
    assert float(final["average_rate"]) == pytest.approx(
        score_plan(out["config"], out["trajectory"]).rate, rel=1e-12
    )
