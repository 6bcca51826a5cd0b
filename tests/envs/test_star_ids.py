"""The STAR ids (``ios_uav_env/STARUAV-v0``, ``ios_uav_env/STARUAV-Random-v0``): each is the env of
its family on the STAR surface (TDMA), scored by ``score_plan``; its STAR fields as keywords."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env
from ios_uav_env import RANDOM_ENV_ID, STAR_ID, STAR_RANDOM_ID, ScenarioConfig, ScenarioRanges, score_plan
from ios_uav_env.envs.single import INSTANCE_NAMES, IOSUAVEnv

IOS_ID = "ios_uav_env/IOSUAV-v0"
STAR = ScenarioConfig(surface="star", T=40.0)  # a short mission of the paper's scenario, STAR surface


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
    """Access: TDMA runs, NOMA is refused naming its scorer; b-bit phases naming the per-slot
    optimum. The protocol and phase model do not enter a TDMA rate: as keywords they are refused
    as doing nothing, and in a config passed whole they are the scenario's, with the same episode."""
    assert gym.make(STAR_ID, star_access="tdma").unwrapped.config == ScenarioConfig(surface="star")
    for env_id in (STAR_ID, STAR_RANDOM_ID):
        with pytest.raises(ValueError, match=rf"{env_id}.*'noma', the field star_access.*star_regions"):
            gym.make(env_id, star_access="noma")
        with pytest.raises(ValueError, match=r"star_bits=2.*star_slot\.slot_optimum"):
            gym.make(env_id, star_bits=2)
        for field, value in (("star_protocol", "ms"), ("star_phases", "shared")):
            with pytest.raises(ValueError, match=rf"{field} is the STAR surface's .* in {env_id} .*nothing"):
                gym.make(env_id, **{field: value})
    switched = STAR.replace(star_protocol="ms", star_phases="coupled")
    env = gym.make(STAR_ID, config=switched)
    assert env.unwrapped.config == switched
    assert same(episode(env), episode(gym.make(STAR_ID, T=40.0)))


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
