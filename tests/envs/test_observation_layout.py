"""Every env publishes its observation layout (``observation_names``), and every shipped policy
reads the features it needs by name: on every registered id, with and without the peak hint, a
policy either runs on the right features or is refused before the episode, with a message that
names the missing features and the env argument that provides them."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from ios_uav_env import (
    ENERGY_ID,
    ENERGY_RANDOM_ID,
    MISO_CONTROL_IDS,
    MOBILE_ID,
    STAR_CONTROL_IDS,
    ScenarioConfig,
)
from ios_uav_env.benchmark.fleet_policies import NearestWorstNode
from ios_uav_env.benchmark.miso_policies import DirectMRT
from ios_uav_env.benchmark.multi_policies import StraightEqualShares
from ios_uav_env.benchmark.star_policies import ChannelPhases
from ios_uav_env.envs.observation import SINGLE_LAYOUTS, feature_source, require_features
from ios_uav_env.envs.policies import FeatureReader, HoverAt, Loiter
from ios_uav_env.envs.random_env import RandomIOSUAVEnv
from ios_uav_env.envs.rollout import bind_policy, run_episode, run_episodes
from ios_uav_env.envs.single import IOSUAVEnv

#: The flight ids (the surface control ids' UAV flies a given line and takes none of their settings;
#: their own checks: ``test_star_control.py``, ``test_miso_control.py``).
CONTROL_IDS = {*STAR_CONTROL_IDS, *MISO_CONTROL_IDS}
IDS = sorted(i for i in gym.registry if i.startswith("ios_uav_env/") and i not in CONTROL_IDS)
#: Every shipped policy (``ios_uav_env.envs.policies``, ``ios_uav_env.benchmark.multi_policies``,
#: ``ios_uav_env.benchmark.fleet_policies``).
POLICIES = {
    "hover-peak": lambda: HoverAt("peak"),
    "hover-ground": lambda: HoverAt("ground"),
    "loiter": Loiter,
    "straight": StraightEqualShares,
    "nearest": NearestWorstNode,
}
SHORT = {"T": 40.0}  # the fixed ids' episodes, shortened (the randomised ids draw theirs)


def _make(env_id: str, hint: bool, vector: bool = False):
    """The id's env (with ``peak_hint=True`` if ``hint``), or None where the id refuses the hint."""
    fixed = "Random" not in env_id and "Mobile" not in env_id
    kwargs = ({"peak_hint": True} if hint else {}) | (SHORT if fixed else {})
    try:
        if vector:
            return gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", **kwargs)
        return gym.make(env_id, **kwargs)
    except ValueError as err:
        assert "peak_hint" in str(err)  # the mobile ids' nodes have no static peak
        return None


def test_every_shipped_policy_is_a_feature_reader():
    """Every class of the package that maps an observation to an action (a ``__call__`` of its own)
    reads the observation by name: the flight policies are the ones checked here; the surface
    controls' ``ChannelPhases`` (STAR) and ``DirectMRT`` (MISO) bind to a suite scenario's task (its
    observation names and action width): the first is refused without the channel phases
    (``tests/benchmark/test_star_suite.py``), the second unbound (``tests/benchmark/test_miso_suite.py``)."""
    import importlib
    import pkgutil

    import ios_uav_env

    shipped = set()
    for module_info in pkgutil.walk_packages(ios_uav_env.__path__, "ios_uav_env."):
        if module_info.name.endswith("__main__"):
            continue
        module = importlib.import_module(module_info.name)
        shipped |= {
            obj for obj in vars(module).values()
            if isinstance(obj, type) and obj.__module__ == module.__name__ and "__call__" in vars(obj)
        }  # fmt: skip
    from ios_uav_env.benchmark.policy_errors import NamedPolicy

    # (the scorer's wrapper of an action function, which evaluate makes of the policy once bound)
    shipped -= {NamedPolicy}
    surface_controls = {ChannelPhases, DirectMRT}
    assert shipped - surface_controls == {HoverAt, Loiter, StraightEqualShares, NearestWorstNode}
    assert surface_controls <= shipped
    shipped -= surface_controls
    assert all(issubclass(cls, FeatureReader) for cls in shipped)
    assert {type(make()) for make in POLICIES.values()} == shipped


@pytest.mark.parametrize("hint", [False, True])
@pytest.mark.parametrize("env_id", IDS)
def test_every_env_publishes_its_layout(env_id, hint):
    env = _make(env_id, hint)
    if env is None:
        return
    names = env.unwrapped.observation_names
    obs, _ = env.reset(seed=0)
    assert isinstance(names, tuple) and all(isinstance(n, str) for n in names)
    assert len(names) == len(set(names)) == obs.shape[0] == env.observation_space.shape[0]
    assert all(feature_source(n) != feature_source("no_such_feature") for n in names)  # each is known
    vec = _make(env_id, hint, vector=True)
    assert vec.unwrapped.observation_names == names


def _expected_columns(policy, names: tuple[str, ...]) -> tuple[int, ...]:
    return tuple(names.index(n) for n in policy.observation_features)


@pytest.mark.parametrize("hint", [False, True])
@pytest.mark.parametrize("policy_name", sorted(POLICIES))
@pytest.mark.parametrize("env_id", IDS)
def test_a_policy_runs_on_its_features_or_is_refused_before_the_episode(env_id, policy_name, hint):
    env = _make(env_id, hint)
    if env is None:
        return
    policy = POLICIES[policy_name]()
    names = env.unwrapped.observation_names
    missing = [n for n in policy.observation_features if n not in names]
    if missing:
        with pytest.raises(ValueError) as err:
            run_episode(env, policy, seed=0)
        message = str(err.value)
        assert all(n in message for n in missing) and repr(policy) in message
        assert all(feature_source(n) in message for n in missing)
        assert len(env.unwrapped.trajectory) == 0  # refused before the reset
        return
    bound = bind_policy(policy, names)
    assert bound._columns(np.zeros(len(names))) == _expected_columns(policy, names)
    episode = run_episode(env, policy, seed=0)
    assert episode.feasible and episode.steps == env.unwrapped.config.N - 1


@pytest.mark.parametrize("policy_name", sorted(POLICIES))
def test_a_bound_policy_reads_by_name_wherever_the_layout_puts_a_feature(policy_name):
    """On a shuffled layout (and the observation shuffled alike) the bound policy acts as the
    unbound one does on its own layout: it reads names, not positions."""
    policy = POLICIES[policy_name]()
    multi = "ios_uav_env/IOSUAV-MultiNode-v0"
    env_id = {"loiter": ENERGY_RANDOM_ID, "straight": multi, "nearest": multi}.get(
        policy_name, "ios_uav_env/IOSUAV-Random-v0"
    )
    env = gym.make(env_id, **({"peak_hint": True} if env_id != multi else {}))
    obs, _ = env.reset(seed=1)
    names = env.unwrapped.observation_names
    order = np.random.default_rng(0).permutation(len(names))
    shuffled = policy.bind(tuple(names[i] for i in order))
    np.testing.assert_array_equal(shuffled(obs[order]), policy.bind(names)(obs))
    if env_id != multi:
        np.testing.assert_array_equal(policy.bind(names)(obs), policy(obs))  # unbound: the same layout
    with pytest.raises(ValueError, match=f"bound to a layout of {len(names)} features, got 5"):
        policy.bind(names)(np.zeros(5))


@pytest.mark.parametrize("width", sorted(SINGLE_LAYOUTS))
@pytest.mark.parametrize("policy_name", ["hover-peak", "hover-ground", "loiter"])
def test_an_unbound_policy_takes_the_single_node_layout_of_the_length(policy_name, width):
    policy = POLICIES[policy_name]()
    names = SINGLE_LAYOUTS[width]
    obs = np.random.default_rng(width).uniform(-0.5, 0.5, (3, width))
    if all(n in names for n in policy.observation_features):
        np.testing.assert_array_equal(policy(obs), policy.bind(names)(obs))
    else:
        with pytest.raises(ValueError, match="peak_hint=True|energy_efficiency"):
            policy(obs)
    with pytest.raises(ValueError, match="none of the single-node layouts"):
        policy(np.zeros(12))


def test_the_probes_examples_are_refused_with_the_kwarg_that_fixes_them():
    with pytest.raises(ValueError, match=r"dx_peak.*peak_hint=True"):
        run_episode(gym.make(ENERGY_RANDOM_ID), Loiter(), seed=0)
    with pytest.raises(ValueError, match=r"dx_peak.*peak_hint=True"):
        Loiter()(gym.make(ENERGY_RANDOM_ID).reset(seed=0)[0])  # unbound: the layout of its length
    with pytest.raises(ValueError, match=r"dx_peak.*peak_hint=True"):
        run_episode(gym.make(ENERGY_ID), HoverAt("peak"), seed=0)
    with pytest.raises(ValueError, match=r"dx_peak.*peak_hint=True"):
        HoverAt("peak")(gym.make(ENERGY_ID).reset(seed=0)[0])
    # the node's position is hidden with knowledge="rates": nothing to fly to
    hidden = gym.make(MOBILE_ID, knowledge="rates")
    assert "dx_ground_hidden" in hidden.unwrapped.observation_names
    with pytest.raises(ValueError, match=r"dx_ground.*knowledge='exact' or 'reports'"):
        run_episode(hidden, HoverAt("ground"), seed=0)


def test_the_batched_rollout_and_the_benchmark_check_before_any_episode():
    vec = gym.make_vec(ENERGY_RANDOM_ID, num_envs=2, vectorization_mode="vector_entry_point")
    with pytest.raises(ValueError, match=r"dx_peak.*peak_hint=True"):
        run_episodes(vec, Loiter(), seed=0)
    assert not vec.unwrapped._started
    from ios_uav_env.benchmark import evaluate

    with pytest.raises(ValueError, match=r"min_power_move.*energy_efficiency"):
        evaluate(Loiter(), "single-node-v1", n=1)  # (its peak hint given, the energy features missing)
    with pytest.raises(ValueError, match=r"mask_0.*multi-node id"):
        evaluate(StraightEqualShares(), "single-node-v1", n=1)


def test_require_features_names_what_is_missing_and_where_it_comes_from():
    names = IOSUAVEnv(ScenarioConfig(T=40.0)).observation_names
    assert require_features(("slack", "dx_final"), names) == (9, 2)
    with pytest.raises(ValueError, match=r"the BC expert reads .*'dx_peak'.*peak_hint=True"):
        require_features(("dx_final", "dx_peak"), names, who="the BC expert")
    with pytest.raises(ValueError, match=r"elements.*instance_features=True"):
        require_features(("elements",), names)
    with pytest.raises(ValueError, match="publishes no observation_names"):
        require_features(("x",), None)
    random_names = RandomIOSUAVEnv().observation_names
    assert random_names[11:] == ("elements", "is_ios", "is_ris", "transmit", "horizon", "seconds_left")


def test_a_wrapper_that_changes_the_observation_is_not_taken_for_the_env():
    stacked = gym.wrappers.FrameStackObservation(gym.make("ios_uav_env/IOSUAV-v0"), 2)
    env = gym.wrappers.FlattenObservation(stacked)
    with pytest.raises(ValueError, match="a wrapper changed the observation"):
        run_episode(env, HoverAt("ground"), seed=0)
