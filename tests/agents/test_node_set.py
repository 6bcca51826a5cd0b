"""agents.node_set: the multi-node actor that sees the nodes as a set (equivariant by construction),
its pooled observation statistics, its numpy export and its SB3 policy."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import torch as th  # noqa: E402

from agents.node_set import (  # noqa: E402
    MASK,
    NodeSetActor,
    NodeSetPolicy,
    node_layout,
    pooled_statistics,
)
from ios_uav_env.envs.multi import BASE_FEATURES  # noqa: E402

RANDOM_ID = "ios_uav_env/IOSUAV-MultiNode-Random-v0"
KW = {"softmin_beta": 20, "peak_hint": True}
K_MAX, WIDTH = 4, 9
BASE = len(BASE_FEATURES)


def _actor(seed: int = 0) -> NodeSetActor:
    """An actor with weights large enough that every part of it moves the output."""
    th.manual_seed(seed)
    actor = NodeSetActor(K_MAX, WIDTH, (16, 16)).double()
    with th.no_grad():
        for p in actor.parameters():
            p.normal_(0.0, 0.6)
    return actor


def _obs(k: int, rows: int = 1, seed: int = 0) -> np.ndarray:
    """Random observations of ``k`` real nodes; padding slots are zero, as the env pads."""
    rng = np.random.default_rng(seed)
    obs = rng.normal(size=(rows, BASE + K_MAX * WIDTH))
    nodes = obs[:, BASE:].reshape(rows, K_MAX, WIDTH)
    nodes[:, :, MASK] = 1.0
    nodes[:, k:] = 0.0
    return obs


def _forward(actor: NodeSetActor, obs: np.ndarray) -> np.ndarray:
    with th.no_grad():
        return actor(th.as_tensor(obs)).numpy()


@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_renumbering_the_nodes_permutes_the_scores_and_keeps_the_move(k):
    actor, obs = _actor(), _obs(k, rows=3)
    out = _forward(actor, obs)
    assert np.ptp(out[:, 2 : 2 + k]) > 0.05 and np.abs(out[:, :2]).max() > 0.05  # not a trivial output
    nodes = obs[:, BASE:].reshape(3, K_MAX, WIDTH)
    for perm in itertools.permutations(range(k)):
        order = list(perm) + list(range(k, K_MAX))
        moved = _forward(actor, np.concatenate([obs[:, :BASE], nodes[:, order].reshape(3, -1)], 1))
        np.testing.assert_allclose(moved[:, :2], out[:, :2], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(
            moved[:, 2 : 2 + k], out[:, 2 + np.array(order[:k])], rtol=1e-12, atol=1e-12
        )


def test_padding_slots_change_nothing_the_env_reads():
    actor, obs = _actor(), _obs(2, rows=2)
    out = _forward(actor, obs)
    noisy = obs.copy()
    pad = noisy[:, BASE:].reshape(2, K_MAX, WIDTH)[:, 2:]
    pad[...] = np.random.default_rng(5).normal(size=pad.shape)
    pad[..., MASK] = 0.0  # still padding: the context and the attention must skip them
    np.testing.assert_allclose(_forward(actor, noisy)[:, :4], out[:, :4], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("arch, compiled", [((16, 16), True), ((16, 16), False), ((16, 8), True)])
def test_the_numpy_forward_is_the_torch_forward(arch, compiled, monkeypatch):
    # one observation: compiled (numba, when installed) on its real nodes, or the batch's numpy
    # path; (16, 8) cannot be stacked for the compiled path and takes the batch's
    import agents.node_set

    monkeypatch.setattr(agents.node_set, "COMPILED", compiled)
    calls = []
    kernel = agents.node_set._forward_one
    monkeypatch.setattr(agents.node_set, "_forward_one", lambda *a: calls.append(1) or kernel(*a))
    th.manual_seed(3)
    actor = NodeSetActor(K_MAX, WIDTH, arch).double()
    with th.no_grad():
        for p in actor.parameters():
            p.normal_(0.0, 0.6)
    numpy_forward = actor.to_numpy()
    for k in (1, 2, 3, 4):
        batch = _obs(k, rows=5, seed=k)
        np.testing.assert_allclose(numpy_forward(batch), _forward(actor, batch), rtol=1e-10, atol=1e-10)
        single = numpy_forward(batch[0])  # one observation: the real nodes only
        np.testing.assert_allclose(single, _forward(actor, batch[:1])[0], rtol=1e-10, atol=1e-10)
        assert np.all(single[2 + k :] == 0.0)  # a padding slot's score
    gap = _obs(4, rows=1, seed=9)
    gap[0, BASE + WIDTH : BASE + 2 * WIDTH] = 0.0  # slot 1 empty, slots 2 and 3 real: the general path
    np.testing.assert_allclose(numpy_forward(gap[0]), _forward(actor, gap)[0], rtol=1e-10, atol=1e-10)
    expected = 4 if compiled and arch == (16, 16) and agents.node_set.HAVE_NUMBA else 0
    assert len(calls) == expected  # one per single observation with its nodes first, when compiled
    strided = np.repeat(batch[0], 2)[::2]  # a strided view: copied before the compiled pass
    np.testing.assert_allclose(numpy_forward(strided), numpy_forward(batch[0]), rtol=0, atol=0)


def test_pooled_statistics_treat_every_slot_alike_and_skip_padding():
    obs = _obs(2, rows=50, seed=1)
    obs[25:] = _obs(4, rows=25, seed=2)[:, :]  # half the rows with 4 nodes: slots 2 and 3 half padding
    mean, var = pooled_statistics(obs, K_MAX, WIDTH)
    real = obs[:, BASE:].reshape(-1, WIDTH)
    real = real[real[:, MASK] > 0.5]
    for slot in range(K_MAX):
        block = slice(BASE + slot * WIDTH, BASE + (slot + 1) * WIDTH)
        np.testing.assert_allclose(mean[block][1:], real.mean(0)[1:])
        np.testing.assert_allclose(var[block][1:], real.var(0)[1:])
        assert mean[block][MASK] == 0.0 and var[block][MASK] == 1.0  # the mask stays 0 or 1
    np.testing.assert_allclose(mean[:BASE], obs[:, :BASE].mean(0))
    with pytest.raises(ValueError, match="obs: shape"):
        pooled_statistics(obs[:, :-1], K_MAX, WIDTH)


def test_bad_layouts_name_the_sizes():
    assert node_layout(BASE + K_MAX * WIDTH, 2 + K_MAX) == (K_MAX, WIDTH)
    with pytest.raises(ValueError, match="observation size 47 and action size 6"):
        node_layout(BASE + K_MAX * WIDTH - 1, 2 + K_MAX)
    with pytest.raises(ValueError, match="observation size"):
        node_layout(BASE + K_MAX * WIDTH, 2)
    with pytest.raises(ValueError, match="net_arch"):
        NodeSetActor(K_MAX, WIDTH, ())


def test_the_sb3_policy_predicts_exports_and_reloads_alike(tmp_path):
    import gymnasium as gym
    from stable_baselines3 import PPO

    from agents.numpy_policy import NumpyPolicy

    env = gym.make(RANDOM_ID, **KW)
    model = PPO(
        NodeSetPolicy, env, policy_kwargs={"net_arch": {"pi": [16, 16], "vf": [32]}}, device="cpu", seed=0
    )
    actor = model.policy.mlp_extractor.policy_net
    assert isinstance(actor, NodeSetActor) and isinstance(model.policy.action_net, th.nn.Identity)
    optimised = {id(p) for g in model.policy.optimizer.param_groups for p in g["params"]}
    assert optimised == {id(p) for p in model.policy.parameters()}  # the actor's, and no stale action_net
    with th.no_grad():
        for p in actor.parameters():
            p.normal_(0.0, 0.3)
    obs = np.stack([env.reset(seed=s)[0] for s in range(4)])
    predicted, _ = model.predict(obs, deterministic=True)
    exported = NumpyPolicy.from_sb3(model)
    np.testing.assert_allclose(exported.act(obs), predicted, atol=1e-5)  # float32 torch, float64 numpy
    model.save(tmp_path / "m.zip")
    loaded = PPO.load(tmp_path / "m.zip", device="cpu")
    assert isinstance(loaded.policy, NodeSetPolicy)
    np.testing.assert_array_equal(loaded.predict(obs, deterministic=True)[0], predicted)
