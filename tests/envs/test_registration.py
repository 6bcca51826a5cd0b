"""The registered ids (ios_uav_env/envs/registration.py): gym.make forms, overrides, no time limit."""

from __future__ import annotations

import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env
from ios_uav_env import ScenarioConfig
from ios_uav_env.envs.core.env import UAVEnv

IOS_ID = "ios_uav_env/IOSUAV-v0"
STAR_RANDOM_ID = "ios_uav_env/STARUAV-Random-v0"


def run_to_end(env: gym.Env) -> tuple[int, bool, bool, dict]:
    env.reset(seed=0)
    steps, terminated, truncated = 0, False, False
    while not (terminated or truncated):
        _, _, terminated, truncated, info = env.step(env.action_space.sample())
        steps += 1
    return steps, terminated, truncated, info


def test_make_with_module_prefix_in_a_fresh_interpreter():
    code = (
        "import sys, gymnasium as gym\n"
        "assert 'ios_uav_env' not in sys.modules\n"
        "env = gym.make('ios_uav_env:ios_uav_env/IOSUAV-v0')\n"
        "obs, info = env.reset(seed=0)\n"
        "print(type(env.unwrapped).__name__, env.unwrapped.config.surface, obs.shape)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["UAVEnv", "ios", "(11,)"]


@pytest.mark.parametrize("env_id", sorted(ios_uav_env.ENV_IDS))
def test_each_id_has_its_surface_and_the_paper_horizon(env_id):
    env = gym.make(env_id)
    assert isinstance(env.unwrapped, UAVEnv) and env.unwrapped.view == "v0" and not env.unwrapped.draws
    assert env.unwrapped.config == ScenarioConfig(surface=ios_uav_env.ENV_IDS[env_id]["surface"])
    assert env.spec.max_episode_steps is None  # the env ends the episode itself, at slot N
    steps, terminated, truncated, info = run_to_end(env)
    assert steps == ScenarioConfig().N - 1 and terminated and info["feasible"]


def test_register_envs_again_is_harmless():
    before = {env_id: gym.spec(env_id) for env_id in ios_uav_env.ENV_IDS}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ios_uav_env.register_envs()
        ios_uav_env.register_envs()
    assert all(gym.spec(env_id) is spec for env_id, spec in before.items())
    assert gym.make(IOS_ID).unwrapped.config == ScenarioConfig()


def test_config_and_keyword_overrides_through_make():
    env = gym.make("ios_uav_env/RISUAV-v0", config=ScenarioConfig(T=100.0))
    assert env.unwrapped.config == ScenarioConfig(T=100.0, surface="ris")  # the id sets the surface
    assert run_to_end(env)[:2] == (99, True)
    env = gym.make(IOS_ID, T=60.0, v_max=20.0, channel="rician")
    assert env.unwrapped.config == ScenarioConfig(T=60.0, v_max=20.0) and env.unwrapped.channel == "rician"
    steps, terminated, _, info = run_to_end(env)
    assert (steps, terminated) == (59, True) and info["mean_faded_rate"] != info["average_rate"]
    # a longer limit than needed is harmless: the env ends the episode itself
    env = gym.make(IOS_ID, config=ScenarioConfig(T=60.0), max_episode_steps=500)
    assert run_to_end(env)[:3] == (59, True, False)


def test_bad_override_names_the_field():
    with pytest.raises(TypeError, match="v_maxx"):
        gym.make(IOS_ID, v_maxx=30.0)
    with pytest.raises(ValueError, match="channel"):
        gym.make(IOS_ID, channel="awgn")


@pytest.mark.parametrize("T", [300.0, 60.0])
def test_any_horizon_runs_to_slot_n_without_max_episode_steps(T):
    env = gym.make(IOS_ID, T=T)
    assert run_to_end(env)[:3] == (int(T) - 1, True, False)


def test_a_shorter_time_limit_truncates_as_asked():
    env = gym.make(IOS_ID, T=60.0, max_episode_steps=20)
    steps, terminated, truncated, info = run_to_end(env)
    assert (steps, terminated, truncated) == (20, False, True) and info["slot"] == 21


def test_unknown_keyword_raises_pythons_type_error():
    # TorchRL's GymEnv passes frameskip=1 and retries without it on exactly this wording
    with pytest.raises(TypeError, match=r"got an unexpected keyword argument 'frameskip'"):
        gym.make(IOS_ID, frameskip=1)
    with pytest.raises(TypeError, match=r"got an unexpected keyword argument 'frameskip'"):
        gym.make("ios_uav_env/IOSUAV-Random-v0", frameskip=1)
    with pytest.raises(TypeError, match=r"replace\(\) got an unexpected keyword argument 'nope'"):
        ScenarioConfig().replace(nope=1)


def test_spec_round_trip_remakes_the_same_stack():
    env = gym.make(IOS_ID, T=60.0, channel="rician")
    again = gym.make(env.spec)
    assert str(again) == str(env) and again.unwrapped.config == env.unwrapped.config


def test_sb3_make_vec_env():
    env_util = pytest.importorskip("stable_baselines3.common.env_util")
    vec = env_util.make_vec_env(IOS_ID, n_envs=2, seed=0)
    obs = vec.reset()
    assert obs.shape == (2, 11)
    for _ in range(3):
        obs, rewards, dones, infos = vec.step(np.zeros((2, 2), dtype=np.float32))
    assert rewards.shape == (2,) and not dones.any() and infos[0]["slot"] == 4
    vec.close()


@pytest.mark.parametrize(
    ("env_id", "config", "field", "alternative"),
    [
        (IOS_ID, ScenarioConfig(surface="ris"), "surface", "ios_uav_env/RISUAV-v0"),
        ("ios_uav_env/UAV-v0", ScenarioConfig(surface="ris"), "surface", "ios_uav_env/RISUAV-v0"),
        ("ios_uav_env/IOSUAV-Energy-v0", ScenarioConfig(objective="rate", surface="ris"), "surface", None),
        (IOS_ID, ScenarioConfig(surface="star"), "surface", "ios_uav_env/STARUAV-v0"),
        (IOS_ID, ScenarioConfig(surface="star", star_protocol="ms"), "surface", "ios_uav_env/STARUAV-v0"),
        ("ios_uav_env/STARUAV-v0", ScenarioConfig(surface="ris"), "surface", "ios_uav_env/RISUAV-v0"),
        (STAR_RANDOM_ID, ScenarioConfig(surface="ris"), "surface", "ios_uav_env/IOSUAV-Random-v0"),
    ],
)
def test_a_config_field_the_id_would_replace_is_refused(env_id, config, field, alternative):
    # the id's keyword wins over the config passed whole: a config that chose another value
    # would run another scenario in silence, so the env refuses and names both values
    with pytest.raises(ValueError, match=rf"config\.{field}=.*keyword {field}=") as err:
        gym.make(env_id, config=config)
    if alternative is not None:
        assert alternative in str(err.value)
    # the same value passed once, as the keyword, is taken
    made = gym.make(env_id, config=config, **{field: getattr(config, field)}).unwrapped.config
    assert made == config.replace(objective=gym.spec(env_id).kwargs.get("objective", config.objective))


def test_a_multi_node_config_the_id_would_replace_is_refused():
    from ios_uav_env.model.mobility import GaussMarkov

    walk = GaussMarkov(speed=3.0)
    base = ScenarioConfig(ground_nodes=((10.0, 20.0), (30.0, -20.0)), motion=walk)
    from ios_uav_env.envs.multi import MultiNodeEnv

    with pytest.raises(ValueError, match=r"config\.motion=.*keyword motion="):
        MultiNodeEnv(config=base, motion={"kind": "gauss_markov"}, knowledge="reports")
    # the id's keyword on a config that did not choose is taken
    env = MultiNodeEnv(config=base.replace(motion=None), motion={"kind": "gauss_markov"}, knowledge="reports")
    assert env.unwrapped._base.motion == GaussMarkov()
