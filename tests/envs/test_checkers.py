"""Every registered id through Gymnasium's and SB3's env checkers, without a warning, and its
batched form with the same spaces: one test over the ids (the ids' own behaviour is in the test
module of their env; any combination of components: ``test_worlds.py``)."""

from __future__ import annotations

import warnings

import gymnasium as gym
import pytest
from gymnasium.utils.env_checker import check_env

import ios_uav_env
from ios_uav_env.envs.options import CHANNELS

#: Every id this package registers (on Gymnasium < 1.0, the oldest release the package supports,
#: the single-node ids of the oldest releases' suite, the Makefile's OLDEST_TESTS; no batched forms:
#: 0.29's make_vec has no vector_entry_point mode).
OLD_GYMNASIUM = int(gym.__version__.split(".")[0]) < 1
IDS = sorted(
    env_id
    for env_id in gym.registry
    if env_id.startswith("ios_uav_env/")
    and (not OLD_GYMNASIUM or env_id in {*ios_uav_env.ENV_IDS, *ios_uav_env.RANDOM_IDS})
)
#: The ids on which the Rician channel is checked too (the others' channel tests are their own).
RICIAN_IDS = {*ios_uav_env.ENV_IDS, *ios_uav_env.RANDOM_IDS}
#: The ids whose render check runs here (the energy and moving-node ids render as these do).
RENDERED = {*ios_uav_env.ENV_IDS, *ios_uav_env.RANDOM_IDS, *ios_uav_env.MULTINODE_IDS}
CASES = [(env_id, "expected") for env_id in IDS] + [(env_id, "rician") for env_id in sorted(RICIAN_IDS)]


@pytest.mark.skipif(OLD_GYMNASIUM, reason="Gymnasium < 1.0: the single-node ids only")
def test_the_ids_are_all_here():
    ie = ios_uav_env
    expected = {*ie.ENV_IDS, *ie.RANDOM_IDS, *ie.MULTINODE_IDS, *ie.ENERGY_IDS, *ie.MOBILE_IDS,
                *ie.MULTINODE_MOBILE_IDS, *ie.STAR_CONTROL_IDS, *ie.MISO_CONTROL_IDS,
                *ie.STAR_NOMA_IDS, *ie.MISO_IDS, *ie.MISO_SDMA_IDS}  # fmt: skip
    assert set(IDS) == expected and set(CHANNELS) == {"expected", "rician"}
    assert {ie.STAR_ID, ie.STAR_RANDOM_ID} <= expected


@pytest.mark.parametrize(("env_id", "channel"), CASES, ids=[f"{i}-{c}" for i, c in CASES])
def test_gymnasiums_checker_without_warnings(env_id, channel):
    env = gym.make(env_id, **({"channel": channel} if channel != "expected" else {}))
    assert env.spec.max_episode_steps is None  # the env ends every episode itself
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=env_id not in RENDERED)


@pytest.mark.parametrize("env_id", IDS)
def test_sb3s_checker_without_warnings(env_id):
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sb3_checker.check_env(gym.make(env_id).unwrapped, warn=True)


@pytest.mark.skipif(OLD_GYMNASIUM, reason="Gymnasium < 1.0: no vector_entry_point")
def test_every_id_has_a_batched_form():
    unbatched = {i for i in IDS if getattr(gym.spec(i), "vector_entry_point", None) is None}
    assert not unbatched


@pytest.mark.parametrize("env_id", IDS)
def test_the_batched_form_has_the_envs_spaces(env_id):
    if OLD_GYMNASIUM:  # pragma: no cover - Gymnasium 0.29's make_vec has no vector_entry_point mode
        pytest.skip("Gymnasium < 1.0: no vector_entry_point mode")
    env = gym.make(env_id)
    vec = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
    assert vec.single_observation_space == env.observation_space
    assert vec.single_action_space == env.action_space
    vec.close()
