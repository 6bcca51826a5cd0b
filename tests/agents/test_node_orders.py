"""The node-order average of a multi-node policy (agents.node_orders): equivariant by construction,
the identity on a policy that already is, and its errors."""

from __future__ import annotations

import numpy as np
import pytest

from agents.node_orders import MASK, MOVE, NodeOrderAverage
from ios_uav_env.envs.multi import BASE_FEATURES

K_MAX, WIDTH = 4, 9
BASE = len(BASE_FEATURES)


def observation(k: int, seed: int = 0) -> np.ndarray:
    """A random observation of ``k`` real nodes in the first slots (mask 1) and padding after."""
    rng = np.random.default_rng(seed)
    nodes = rng.standard_normal((K_MAX, WIDTH))
    nodes[:, MASK] = 0.0
    nodes[:k, MASK] = 1.0
    nodes[k:, MASK + 1 :] = 0.0
    return np.concatenate([rng.standard_normal(BASE), nodes.ravel()])


def mlp(seed: int = 1):
    """A random tanh MLP over the whole observation: not equivariant in the nodes."""
    rng = np.random.default_rng(seed)
    w1 = rng.standard_normal((BASE + K_MAX * WIDTH, 32)) / 8
    w2 = rng.standard_normal((32, MOVE + K_MAX))
    return lambda obs: np.tanh(np.tanh(obs @ w1) @ w2)


def renumbered(obs: np.ndarray, order: np.ndarray) -> np.ndarray:
    nodes = obs[BASE:].reshape(K_MAX, WIDTH)
    return np.concatenate([obs[:BASE], nodes[order].ravel()])


@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_renumbering_the_nodes_permutes_the_scores_and_keeps_the_move(k):
    policy = mlp()
    average = NodeOrderAverage(policy, K_MAX, WIDTH)
    obs = observation(k)
    ref = average(obs)
    assert ref.shape == (MOVE + K_MAX,) and ref.dtype == np.float32
    for order in average.orders(k)[1:]:
        new = average(renumbered(obs, order))
        np.testing.assert_allclose(new[:MOVE], ref[:MOVE], rtol=0, atol=1e-6)
        np.testing.assert_allclose(new[MOVE:], ref[MOVE + order], rtol=0, atol=1e-6)  # slot j: node order[j]
        if k > 1:  # (the wrapped policy itself is not equivariant: the average is what makes it so)
            assert not np.allclose(policy(renumbered(obs, order))[:MOVE], policy(obs)[:MOVE], atol=1e-3)


def test_an_equivariant_policy_is_returned_unchanged():
    """Its scores score each node's own block and its move sums over the nodes: every order gives
    the same action, once put back (a wrong un-permutation of the scores would scramble them)."""
    rng = np.random.default_rng(2)
    v, u = rng.standard_normal(WIDTH), rng.standard_normal((WIDTH, MOVE))

    def policy(obs):
        nodes = obs[BASE:].reshape(K_MAX, WIDTH)
        return np.concatenate([np.tanh(nodes.sum(0) @ u), np.tanh(nodes @ v)])

    average = NodeOrderAverage(policy, K_MAX, WIDTH)
    for k in (2, 3, 4):
        obs = observation(k, seed=k)
        np.testing.assert_allclose(average(obs), policy(obs), rtol=0, atol=1e-6)


def test_the_orders_are_every_permutation_of_the_real_nodes_only():
    average = NodeOrderAverage(mlp(), K_MAX, WIDTH)
    orders = average.orders(3)
    assert len(orders) == 6 and len({tuple(o) for o in orders}) == 6
    assert all(o[3] == 3 and sorted(o[:3]) == [0, 1, 2] for o in orders)
    calls = []
    counting = NodeOrderAverage(lambda obs: calls.append(obs) or np.zeros(MOVE + K_MAX), K_MAX, WIDTH)
    counting(observation(4))
    assert len(calls) == 24  # 4! orders of 4 nodes
    calls.clear()
    counting(observation(2))
    assert len(calls) == 2  # 2! orders; the padding slots stay where they are
    assert all(c[BASE:].reshape(K_MAX, WIDTH)[:, MASK].tolist() == [1.0, 1.0, 0.0, 0.0] for c in calls)


def test_bad_input_is_refused_with_the_field_named():
    with pytest.raises(ValueError, match="k_max"):
        NodeOrderAverage(mlp(), 0, WIDTH)
    with pytest.raises(ValueError, match="width"):
        NodeOrderAverage(mlp(), K_MAX, 0)
    average = NodeOrderAverage(mlp(), K_MAX, WIDTH)
    with pytest.raises(ValueError, match=r"obs: shape \(5,\)"):
        average(np.zeros(5))
    short = NodeOrderAverage(lambda obs: np.zeros(3), K_MAX, WIDTH)
    with pytest.raises(ValueError, match="act: an action of shape"):
        short(observation(2))
