"""An id given a scenario it does not model says so: the error names the id, what it supports and
the id that handles the request (if one does), on every registered id, at construction and for a
scenario pinned at reset."""

from __future__ import annotations

import gymnasium as gym
import pytest

import ios_uav_env

#: The flight ids (the surface control ids' UAV flies a given line and takes none of their settings;
#: their own checks: ``test_star_control.py``, ``test_miso_control.py``).
CONTROL_IDS = {*ios_uav_env.STAR_CONTROL_IDS, *ios_uav_env.MISO_CONTROL_IDS}
IDS = sorted(i for i in gym.registry if i.startswith("ios_uav_env/") and i not in CONTROL_IDS)
MULTI_IDS = {*ios_uav_env.MULTINODE_IDS, *ios_uav_env.MULTINODE_MOBILE_IDS}
#: (the NOMA and SDMA ids run two users, the SDMA K3 and K4 ids three and four: their refusals are in
#: ``test_star_noma.py``, ``test_miso_sdma_env.py``, ``test_miso_sdma_users.py``)
TWO_USER_IDS = {*ios_uav_env.STAR_NOMA_IDS, *ios_uav_env.MISO_SDMA_IDS}
SINGLE_IDS = [i for i in IDS if i not in MULTI_IDS and i not in TWO_USER_IDS]
NODES = ((-100.0, -20.0), (150.0, -60.0))


def _several_nodes_message(env_id: str) -> str:
    """What the error of ``env_id`` given two nodes must say after naming the id."""
    if env_id in ios_uav_env.ENERGY_IDS:  # the energy objective: the multi-node ids, given it
        return (
            "several nodes: MultiNodeEnv, ios_uav_env/IOSUAV-MultiNode-v0 or "
            'ios_uav_env/IOSUAV-MultiNode-Random-v0 with objective="energy_efficiency"'
        )
    if env_id in ios_uav_env.MOBILE_IDS:
        return f"several nodes: MultiNodeEnv, {ios_uav_env.MULTINODE_MOBILE_ID}"
    return "several nodes: MultiNodeEnv, ios_uav_env/IOSUAV-MultiNode-v0"


@pytest.mark.parametrize("env_id", SINGLE_IDS)
def test_a_single_node_id_given_several_nodes_says_it_is_single_node(env_id):
    with pytest.raises(ValueError) as err:
        gym.make(env_id, ground_nodes=NODES)
    message = str(err.value)
    assert f"{env_id} is a single-node env (one ground node, K = 1" in message, message
    assert _several_nodes_message(env_id) in message and "ranges" not in message
    # a scenario pinned at reset: the same, naming the option
    env = gym.make(env_id)
    pinned = env.unwrapped.config.replace(ground_nodes=NODES)
    with pytest.raises(ValueError, match=r'options\["config"\] has K = 2 ground_nodes, but ' + env_id):
        env.reset(options={"config": pinned})


@pytest.mark.parametrize("env_id", sorted(MULTI_IDS))
def test_a_multi_node_id_keeps_the_objective_it_was_made_with(env_id):
    """Either objective at construction; a scenario pinned at reset with the other one is refused,
    naming the option, the id and the objective the env has (its observation and reward)."""
    for own, other in (("rate", "energy_efficiency"), ("energy_efficiency", "rate")):
        env = gym.make(env_id, objective=own)
        assert env.unwrapped.energy_objective == (own == "energy_efficiency")
        env.reset(seed=0)
        pinned = env.unwrapped.config.replace(objective=other)
        with pytest.raises(ValueError) as err:
            env.reset(options={"config": pinned})
        message = str(err.value)
        assert message.startswith(f'options["config"] has objective={other!r}, but this {env_id}'), message
        assert f"was made with objective {own!r}" in message
