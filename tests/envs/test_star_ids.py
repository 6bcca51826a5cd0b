"""The STAR ids (``ios_uav_env/STARUAV-v0``, ``ios_uav_env/STARUAV-Random-v0``): each is the env of
its family on the STAR surface (TDMA), scored by ``score_plan``; its STAR fields as keywords, b-bit
phases (``star_bits``) among them: the scorer's rate, seeded reproduction, the batched rows, the
checkers."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import ios_uav_env
from ios_uav_env import RANDOM_ENV_ID, STAR_ID, STAR_RANDOM_ID, ScenarioConfig, ScenarioRanges, score_plan
from ios_uav_env.envs.single import INSTANCE_NAMES, IOSUAVEnv
from ios_uav_env.model import channel
from tests.tolerances import RATE_REL

IOS_ID = "ios_uav_env/IOSUAV-v0"
STAR = ScenarioConfig(surface="star", T=40.0)  # a short mission of the paper's scenario, STAR surface
#: Short missions over small surfaces: the randomised id's b-bit episodes in the tests.
SHORT_RANGES = ScenarioRanges(T=(40.0, 50.0), ios_rows=(20, 22))


def episode(env: gym.Env, seed: int = 3) -> dict:
    """One episode of seeded uniform actions: every output and the flight."""
    rng = np.random.default_rng(seed)
    obs, info = env.reset(seed=seed)
    out = {"obs": [obs], "rewards": [], "infos": [info]}
    done = False
    while not done:
        obs, reward, terminated, truncated, info = env.step(rng.uniform(-1.0, 1.0, 2).astype(np.float32))
        out["obs"].append(obs)
        out["rewards"].append(reward)
        out["infos"].append(info)
        done = terminated or truncated
    out["trajectory"] = env.unwrapped.trajectory
    out["config"] = env.unwrapped.config
    return out


def same(a: dict, b: dict) -> bool:
    """Whether two episodes are equal bit for bit (observations, rewards, every info value, flight)."""
    if len(a["obs"]) != len(b["obs"]):
        return False
    pairs = [*zip(a["obs"], b["obs"], strict=True), *zip(a["rewards"], b["rewards"], strict=True)]
    pairs += [(x[k], y[k]) for x, y in zip(a["infos"], b["infos"], strict=True) for k in x]
    pairs.append((a["trajectory"], b["trajectory"]))
    return all(np.array_equal(np.asarray(x), np.asarray(y)) for x, y in pairs)


def test_the_ids_are_registered_with_their_surface():
    assert ios_uav_env.ENV_IDS[STAR_ID] == {"surface": "star"}
    assert ios_uav_env.RANDOM_IDS == {RANDOM_ENV_ID: {}, STAR_RANDOM_ID: {"surface": "star"}}
    assert gym.make(STAR_ID).unwrapped.config == ScenarioConfig(surface="star")
    assert gym.make(STAR_RANDOM_ID).unwrapped.ranges.surfaces == ("star",)


def test_the_star_id_is_the_env_on_the_star_config():
    """Its seeded episode is IOSUAVEnv's on the STAR scenario, made any way, and not the IOS one's."""
    own = episode(gym.make(STAR_ID, T=40.0))
    assert own["config"] == STAR
    assert same(own, episode(IOSUAVEnv(STAR)))
    assert same(own, episode(gym.make(IOS_ID, config=STAR, surface="star")))
    assert not same(own, episode(gym.make(IOS_ID, T=40.0)))  # (the surface changes the episode)


def test_the_star_ids_rate_is_score_plans():
    out = episode(gym.make(STAR_ID, T=40.0))
    score = score_plan(STAR, out["trajectory"])
    final = out["infos"][-1]
    assert bool(final["feasible"]) == score.feasible
    assert float(final["average_rate"]) == pytest.approx(score.rate, rel=1e-12)
    ios = score_plan(STAR.replace(surface="ios"), out["trajectory"]).rate
    assert abs(ios - score.rate) > 1e-3  # the IOS's rate on the same flight differs


def test_the_star_fields_as_keywords():
    """Access: TDMA runs, NOMA is refused naming its scorer; b-bit phases run (their own tests
    below), with NOMA refused naming TDMA. The protocol and phase model do not enter a TDMA rate,
    with continuous or b-bit phases: as keywords they are refused as doing nothing, and in a config
    passed whole they are the scenario's, with the same episode."""
    assert gym.make(STAR_ID, star_access="tdma").unwrapped.config == ScenarioConfig(surface="star")
    assert gym.make(STAR_ID, star_bits=2).unwrapped.config == ScenarioConfig(surface="star", star_bits=2)
    for env_id in (STAR_ID, STAR_RANDOM_ID):
        with pytest.raises(ValueError, match=rf"{env_id}.*'noma', the field star_access.*star_regions"):
            gym.make(env_id, star_access="noma")
        with pytest.raises(ValueError, match=r"star_bits=2 with star_access='noma'.*star_access='tdma'"):
            gym.make(env_id, star_bits=2, star_access="noma")
        for field, value in (("star_protocol", "ms"), ("star_phases", "shared")):
            with pytest.raises(ValueError, match=rf"{field} is the STAR surface's .* in {env_id} .*nothing"):
                gym.make(env_id, **{field: value})
    for bits in (None, 2):
        switched = STAR.replace(star_protocol="ms", star_phases="coupled", star_bits=bits)
        env = gym.make(STAR_ID, config=switched)
        assert env.unwrapped.config == switched
        assert same(episode(env), episode(gym.make(STAR_ID, T=40.0, star_bits=bits)))


# --- b-bit phases: the keyword star_bits ---------------------------------------------------------


def test_b_bit_phases_fly_on_the_scorers_rate():
    """The env's rate at every slot is the model's b-bit slot rate (``channel.slot_rates``, the
    per-slot optimum of ``star_slot``: tests/model/test_star_bits.py), its ``average_rate`` and its
    reward sum are ``score_plan``'s, and b bits score below continuous phases on the same flight."""
    out = episode(gym.make(STAR_ID, T=40.0, star_bits=2))
    config, flight = out["config"], out["trajectory"]
    assert config == STAR.replace(star_bits=2)
    rates = [float(info["rate"]) for info in out["infos"]]
    np.testing.assert_allclose(rates, channel.slot_rates(config, flight), rtol=RATE_REL)
    score = score_plan(config, flight)
    assert score.feasible and bool(out["infos"][-1]["feasible"])
    assert float(out["infos"][-1]["average_rate"]) == pytest.approx(score.rate, rel=RATE_REL)
    # the guard keeps every penalty at 0: the rewards are the rates of slots 2..N, slot 1's in reset's info
    assert (rates[0] + sum(out["rewards"])) / config.N == pytest.approx(score.rate, rel=RATE_REL)
    assert score.rate < score_plan(STAR, flight).rate


@pytest.mark.parametrize("env_id", [STAR_ID, STAR_RANDOM_ID])
def test_b_bit_episodes_reproduce_and_the_batch_rows_are_the_singles(env_id):
    """Two envs of the same seed give the same episode bit for bit, and so does row i of the
    batched form (seeded seed + i) against the single env, across an autoreset; the randomised id
    draws every scenario with the keyword's bits."""
    kwargs = {"star_bits": 2, **({"T": 40.0} if env_id == STAR_ID else {"ranges": SHORT_RANGES})}
    first = episode(gym.make(env_id, **kwargs), seed=5)
    assert same(first, episode(gym.make(env_id, **kwargs), seed=5))
    assert first["config"].star_bits == 2 and first["config"].surface == "star"
    assert not same(first, episode(gym.make(env_id, **{**kwargs, "star_bits": 3}), seed=5))
    vec = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point", **kwargs)
    singles = [gym.make(env_id, **kwargs) for _ in range(3)]
    obs, _ = vec.reset(seed=5)
    pending = [False] * 3
    for i, env in enumerate(singles):
        o, _ = env.reset(seed=5 + i)
        assert np.array_equal(o, obs[i])
    rng, ends = np.random.default_rng(5), 0
    while ends < 4:
        actions = rng.uniform(-1.0, 1.0, (3, 2)).astype(np.float32)
        obs, reward, terminated, _, info = vec.step(actions)
        for i, env in enumerate(singles):
            if pending[i]:  # (the batch's NEXT_STEP autoreset: this step resets the row)
                (o, i_info), r, t = env.reset(), 0.0, False
            else:
                o, r, t, _, i_info = env.step(actions[i])
            pending[i], ends = bool(t), ends + bool(t)
            assert np.array_equal(o, obs[i]) and r == reward[i] and t == terminated[i]
            assert all(np.array_equal(np.asarray(v), np.asarray(info[k][i])) for k, v in i_info.items())
    assert [env.config.star_bits for env in vec.unwrapped.envs] == [2, 2, 2]
    vec.close()


@pytest.mark.parametrize("env_id", [STAR_ID, STAR_RANDOM_ID])
def test_b_bit_ids_pass_the_checkers(env_id):
    """Gymnasium's checker and SB3's, without a warning, on the b-bit form of each STAR id."""
    kwargs = {"star_bits": 2} if env_id == STAR_ID else {"star_bits": 2, "ranges": SHORT_RANGES}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(env_id, **kwargs).unwrapped, skip_render_check=True)
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sb3_checker.check_env(gym.make(env_id, **kwargs).unwrapped, warn=True)


def test_b_bit_phases_refuse_faded_rates_naming_the_expected_channel():
    with pytest.raises(ValueError, match=r"b-bit phases \(the field star_bits\) and fading 'rician'.*"
                       r"channel='expected'"):  # fmt: skip
        gym.make(STAR_ID, star_bits=2, channel="rician")


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_random_star_id_draws_the_randomised_ids_scenarios_on_the_star_surface(seed):
    """The randomised id's family narrowed to one surface draws the same scenarios for every
    surface (a draw among one surface takes no number from the stream, so the comparison is the
    family narrowed to the IOS)."""
    star, ios = gym.make(STAR_RANDOM_ID), gym.make(RANDOM_ENV_ID, surface="ios")
    obs, _ = star.reset(seed=seed)
    ios.reset(seed=seed)
    assert star.unwrapped.config == ios.unwrapped.config.replace(surface="star")
    assert star.unwrapped.ranges == ios.unwrapped.ranges.with_surface("star")
    assert star.unwrapped.ranges.with_surface("ios") == ios.unwrapped.ranges
    features = dict(zip(star.unwrapped.observation_names, obs, strict=True))
    flags = [features[name] for name in INSTANCE_NAMES[1:4]]  # is-IOS, is-RIS, t / (1 + t)
    assert flags == [0.0, 0.0, 0.5]


def test_the_random_star_ids_ranges_and_pinned_config():
    short = ScenarioRanges(T=(40.0, 50.0))  # (the default surfaces: the id's surface is taken)
    env = gym.make(STAR_RANDOM_ID, ranges=short)
    assert env.unwrapped.ranges == short.with_surface("star")
    env.reset(seed=0)
    assert env.unwrapped.config.surface == "star" and env.unwrapped.config.T <= 50.0
    with pytest.raises(ValueError, match=rf"{STAR_RANDOM_ID}: ranges.surfaces=\('ris',\).*{RANDOM_ENV_ID}"):
        gym.make(STAR_RANDOM_ID, ranges=ScenarioRanges(surfaces=("ris",)))
    pinned = gym.make(STAR_RANDOM_ID, config=ScenarioConfig(T=100.0))
    pinned.reset(seed=0)
    assert pinned.unwrapped.config == ScenarioConfig(T=100.0, surface="star")
    with pytest.raises(ValueError, match=rf"config.surface='ris'.*keyword surface='star'.*{RANDOM_ENV_ID}"):
        gym.make(STAR_RANDOM_ID, config=ScenarioConfig(surface="ris"))


def test_the_surface_keyword_narrows_any_randomised_family():
    env = gym.make(RANDOM_ENV_ID, surface="ris")
    assert env.unwrapped.ranges.surfaces == ("ris",)
    assert {env.reset(seed=s)[1] is not None and env.unwrapped.config.surface for s in range(6)} == {"ris"}
    with pytest.raises(ValueError, match=r"surface must be one of \('ios', 'ris', 'none', 'star'\)"):
        gym.make(RANDOM_ENV_ID, surface="mirror")


def test_the_batched_random_star_rows_are_star():
    vec = gym.make_vec(STAR_RANDOM_ID, num_envs=3, vectorization_mode="vector_entry_point")
    vec.reset(seed=0)
    assert [row.config.surface for row in vec.unwrapped.envs] == ["star"] * 3
    vec.close()
