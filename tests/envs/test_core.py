"""The one env class and the one vector class (``ios_uav_env.envs.core``): every single- and
multi-node id is ``UAVEnv`` / ``UAVVectorEnv`` with its preset, the view chooses the stepper, the
presets make the same envs, and a copy (a batched env's row) has a stepper of its own."""

from __future__ import annotations

import copy
import pickle

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env
from ios_uav_env import ScenarioConfig
from ios_uav_env.envs.core.env import UAVEnv
from ios_uav_env.envs.core.stepper import VIEWS, Stepper
from ios_uav_env.envs.core.vector import UAVVectorEnv
from ios_uav_env.envs.miso_sdma import MisoSdmaStepper
from ios_uav_env.envs.multi import MultiNodeEnv
from ios_uav_env.envs.multi_node import MultiNodeStepper
from ios_uav_env.envs.multi_vector import MultiNodeVectorEnv
from ios_uav_env.envs.random_env import RandomIOSUAVEnv
from ios_uav_env.envs.registration import ENTRY_POINT, VECTOR_ENTRY_POINT, presets
from ios_uav_env.envs.single import IOSUAVEnv
from ios_uav_env.envs.single_drawn import DrawnSingleNodeStepper
from ios_uav_env.envs.single_node import SingleNodeStepper
from ios_uav_env.envs.single_vector import IOSUAVVectorEnv, RandomIOSUAVVectorEnv
from ios_uav_env.envs.star_noma import StarNomaStepper

ie = ios_uav_env
IDS = {
    *ie.ENV_IDS,
    *ie.RANDOM_IDS,
    *ie.ENERGY_IDS,
    *ie.MOBILE_IDS,
    *ie.MULTINODE_IDS,
    *ie.MULTINODE_MOBILE_IDS,
    *ie.STAR_NOMA_IDS,
    *ie.MISO_IDS,
    *ie.MISO_SDMA_IDS,
}
DRAWN = {*ie.RANDOM_IDS, ie.ENERGY_RANDOM_ID, *ie.MOBILE_IDS}
NODE_BLOCKS = {*ie.MULTINODE_IDS, *ie.MULTINODE_MOBILE_IDS}


def test_every_single_and_multi_node_id_is_the_one_class_with_its_preset():
    assert set(presets()) == IDS
    for env_id in sorted(IDS):
        spec = gym.spec(env_id)
        assert spec.entry_point == ENTRY_POINT and spec.vector_entry_point == VECTOR_ENTRY_POINT, env_id
        env = gym.make(env_id).unwrapped
        view = "node_blocks" if env_id in NODE_BLOCKS else "star_noma" if env_id in ie.STAR_NOMA_IDS else "v0"
        view = "miso_sdma" if env_id in ie.MISO_SDMA_IDS else view
        assert type(env) is UAVEnv and (env.view, env.action) == (view, VIEWS[view]), env_id
        assert env.draws == (env_id in DRAWN) and isinstance(env.stepper, Stepper), env_id
        steppers = {
            "node_blocks": MultiNodeStepper,
            "star_noma": StarNomaStepper,
            "miso_sdma": MisoSdmaStepper,
        }
        expected = steppers.get(view, SingleNodeStepper)
        expected = DrawnSingleNodeStepper if env_id in DRAWN else expected
        assert type(env.stepper) is expected and env.stepper_class(**spec.kwargs) is expected, env_id
    assert gym.spec("ios_uav_env/IOSUAV-v0").kwargs == {"surface": "ios"}  # the v0 view is the default


@pytest.mark.parametrize(
    ("env_id", "preset", "kwargs"),
    [
        ("ios_uav_env/RISUAV-v0", IOSUAVEnv, {"T": 40.0}),
        ("ios_uav_env/IOSUAV-Random-v0", RandomIOSUAVEnv, {}),
        ("ios_uav_env/IOSUAV-MultiNode-v0", MultiNodeEnv, {"T": 40.0}),
    ],
)
def test_a_preset_makes_its_ids_env_step_for_step(env_id, preset, kwargs):
    made = gym.make(env_id, **kwargs).unwrapped
    own = preset(**{**gym.spec(env_id).kwargs, **kwargs}) if preset is IOSUAVEnv else preset(**kwargs)
    assert (
        isinstance(own, UAVEnv) and own.view == made.view and own.observation_names == made.observation_names
    )
    rng = np.random.default_rng(3)
    obs, info = made.reset(seed=5)
    again, info_again = own.reset(seed=5)
    np.testing.assert_array_equal(obs, again)
    for _ in range(10):
        action = rng.uniform(-1, 1, made.action_space.shape)
        step, step_again = made.step(action), own.step(action)
        np.testing.assert_array_equal(step[0], step_again[0])
        assert step[1:4] == step_again[1:4]


def test_the_vector_presets_are_the_one_vector_class():
    for vec, view in (
        (IOSUAVVectorEnv(2), "v0"),
        (RandomIOSUAVVectorEnv(2), "v0"),
        (MultiNodeVectorEnv(2), "node_blocks"),
    ):
        assert isinstance(vec, UAVVectorEnv) and all(env.view == view for env in vec.envs)
        assert len({id(env.stepper) for env in vec.envs}) == 2  # each row its own stepper
    assert RandomIOSUAVVectorEnv(2).envs[0].draws and MultiNodeVectorEnv(2).max_nodes == 3


def test_view_action_and_draws_are_checked_naming_them():
    with pytest.raises(ValueError, match="view must be one of"):
        UAVEnv(view="pixels")
    with pytest.raises(ValueError, match="action must be 'move_scores'"):
        UAVEnv(view="node_blocks", action="move")
    with pytest.raises(ValueError, match="draws is the v0 view's"):
        UAVEnv(view="node_blocks", draws=True)
    with pytest.raises(ValueError, match="draws must be True or False"):
        UAVEnv(draws="yes")
    with pytest.raises(ValueError, match="single-node env"):  # the v0 view: one node, naming the others
        UAVEnv(ScenarioConfig(ground_nodes=((-50.0, 0.0), (50.0, 0.0))))
    with pytest.raises(TypeError, match=r"UAVEnv.__init__\(\) got an unexpected keyword argument 'nope'"):
        UAVEnv(nope=1)


def test_a_copy_or_a_pickle_has_a_stepper_of_its_own_bound_to_it():
    env = UAVEnv(T=40.0)
    env.reset(seed=0)
    twin = copy.copy(env)
    assert twin.stepper is not env.stepper and twin.stepper.env is twin and env.stepper.env is env
    twin.reset(seed=1)  # seeds the copy's generator, not the original's
    assert twin.np_random is not env.np_random and twin.np_random is twin.stepper.np_random
    loaded = pickle.loads(pickle.dumps(env))
    assert loaded.stepper.env is loaded and loaded.config == env.config
    np.testing.assert_array_equal(loaded.trajectory, env.trajectory)


@pytest.mark.parametrize("env_id", ["ios_uav_env/IOSUAV-v0", "ios_uav_env/IOSUAV-MultiNode-v0"])
def test_the_base_env_has_no_env_attribute_so_a_walk_down_the_wrappers_ends(env_id):
    """Tools walk ``.env`` down to the base env (TorchRL's pixel check, Gymnasium's wrappers): the
    stepper's back-reference ``env`` must not be forwarded, or the walk never ends."""
    env = gym.make(env_id)
    assert not hasattr(env.unwrapped, "env")
    layer, depth = env, 0
    while hasattr(layer, "env"):
        layer, depth = layer.env, depth + 1
        assert depth < 20
    assert layer is env.unwrapped and env.unwrapped.stepper.env is env.unwrapped
