"""The multi-node parsers of agents on the energy layout (``objective="energy_efficiency"``: 4 energy
features after the node blocks): the layout read by name (agents.node_orders.NodeLayout), the
node-set network (its actor, statistics, numpy export, a short PPO run), the node-order average,
the imitation fit and run, the expert's node mask and the multi-node comparison's K_max."""

from __future__ import annotations

import itertools
from types import SimpleNamespace

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import gymnasium as gym  # noqa: E402
import torch as th  # noqa: E402

import ios_uav_env  # noqa: E402, F401
from agents.node_orders import MASK, MOVE, NodeLayout, NodeOrderAverage, exact_layout  # noqa: E402
from ios_uav_env.envs.multi import BASE_FEATURES  # noqa: E402
from ios_uav_env.envs.observation_layout import ENERGY_NAMES  # noqa: E402

FIXED_ID = "ios_uav_env/IOSUAV-MultiNode-v0"
RANDOM_ID = "ios_uav_env/IOSUAV-MultiNode-Random-v0"
ENERGY = {"objective": "energy_efficiency"}
BASE, EXTRA = len(BASE_FEATURES), len(ENERGY_NAMES)


def energy_env(env_id: str = FIXED_ID, **kwargs):
    return gym.make(env_id, **ENERGY, **kwargs)


def random_obs(layout: NodeLayout, k: int, rows: int = 1, seed: int = 0) -> np.ndarray:
    """Random observations of ``layout`` with ``k`` real nodes (padding zero, as the env pads) and
    energy features of 1 or more: a parser that took them for a mask would count them as nodes."""
    rng = np.random.default_rng(seed)
    obs = rng.normal(size=(rows, layout.size))
    nodes = obs[:, layout.base : layout.nodes_end].reshape(rows, layout.k_max, layout.width)
    nodes[:, :, MASK] = 1.0
    nodes[:, k:] = 0.0
    obs[:, layout.nodes_end :] = 1.0 + rng.random((rows, layout.extra))
    return obs


# --- the layout by name ----------------------------------------------------------------------------
@pytest.mark.parametrize("env_id", [FIXED_ID, RANDOM_ID])
@pytest.mark.parametrize("kwargs", [{}, {"peak_hint": True}, ENERGY, {**ENERGY, "peak_hint": True}])
def test_the_layout_is_read_from_the_names_and_agrees_with_the_sizes(env_id, kwargs):
    env = gym.make(env_id, **kwargs)
    names = env.unwrapped.observation_names
    layout = NodeLayout.from_names(names)
    energy = kwargs.get("objective") == "energy_efficiency"
    width = 9 if kwargs.get("peak_hint") else 6
    assert (layout.base, layout.k_max, layout.width) == (BASE, env.unwrapped.max_nodes, width)
    assert layout.extra == (EXTRA if energy else 0) and layout.size == env.observation_space.shape[0]
    assert layout.scenario_names == BASE_FEATURES + (ENERGY_NAMES if energy else ())
    assert layout.node_features == env.unwrapped.node_features
    # the sizes alone give the same layout (the env's exact-knowledge names, which it publishes)
    assert NodeLayout.from_sizes(env.observation_space.shape[0], env.action_space.shape[0]) == layout
    assert exact_layout(layout.k_max, width == 9, energy) == layout


def test_a_layout_that_is_no_multi_node_one_is_refused_by_name():
    single = gym.make("ios_uav_env/IOSUAV-v0").unwrapped.observation_names
    with pytest.raises(ValueError, match="no node block.*use a multi-node id"):
        NodeLayout.from_names(single, "the test")
    names = list(energy_env().unwrapped.observation_names)
    names[BASE + 7] = "dx_node_2"  # slot 1's dx_node: the blocks are not alike
    with pytest.raises(ValueError, match="not k_max blocks"):
        NodeLayout.from_names(names)
    # 40 features and 3 node slots: no layout of the env (12 + 4 x 7 would be a misreading)
    with pytest.raises(ValueError, match=r"observation size 40 and action size 5.*34 \(12 \+ 3 x 6 \+ 4\)"):
        NodeLayout.from_sizes(40, 5)


# --- the node-set network --------------------------------------------------------------------------
def test_node_layout_refuses_the_energy_layout_and_node_set_layout_reads_it():
    from agents.node_set import node_layout, node_set_layout

    env = energy_env(RANDOM_ID)  # 12 + 4 x 6 + 4 = 40 = 12 + 4 x 7: the sizes alone misread it
    size, actions = env.observation_space.shape[0], env.action_space.shape[0]
    with pytest.raises(ValueError, match="4 scenario features after the node blocks.*min_power_move"):
        node_layout(size, actions)
    layout = node_set_layout(size, actions)
    assert (layout.k_max, layout.width, layout.extra) == (4, 6, EXTRA)
    assert node_set_layout(size, actions, env.unwrapped.observation_names) == NodeLayout.from_names(
        env.unwrapped.observation_names
    )
    rate_names = gym.make(RANDOM_ID).unwrapped.observation_names  # another env's names: refused
    with pytest.raises(ValueError, match="observation_names: 12 \\+ 4 x 6 \\+ 0"):
        node_set_layout(size, actions, rate_names)


def _energy_actor(layout: NodeLayout, arch=(16, 16), seed: int = 0):
    from agents.node_set import NodeSetActor

    th.manual_seed(seed)
    actor = NodeSetActor(layout.k_max, layout.width, arch, layout.extra).double()
    with th.no_grad():
        for p in actor.parameters():
            p.normal_(0.0, 0.6)
    return actor


def _forward(actor, obs):
    with th.no_grad():
        return actor(th.as_tensor(obs)).numpy()


@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_the_node_set_actor_takes_the_energy_features_as_scenario_features(k):
    layout = exact_layout(4, peak=True, energy=True)
    actor, obs = _energy_actor(layout), random_obs(layout, k, rows=3)
    assert actor.encode[0].in_features == BASE + EXTRA + layout.width  # each node sees them
    assert actor.move[0].in_features == BASE + EXTRA + 2 * 16  # and the move
    out = _forward(actor, obs)
    assert np.all(out[:, MOVE + k :] == 0.0)  # padding slots: the energy features are no node
    end = layout.nodes_end
    nodes = obs[:, BASE:end].reshape(3, 4, layout.width)
    for perm in itertools.permutations(range(k)):  # still equivariant, the energy features fixed
        order = list(perm) + list(range(k, 4))
        moved = _forward(
            actor, np.concatenate([obs[:, :BASE], nodes[:, order].reshape(3, -1), obs[:, end:]], 1)
        )
        np.testing.assert_allclose(moved[:, :MOVE], out[:, :MOVE], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(moved[:, MOVE : MOVE + k], out[:, MOVE + np.array(order[:k])], atol=1e-12)
    for column in range(end, layout.size):  # every energy feature moves the action
        changed = obs.copy()
        changed[:, column] += 1.0
        assert np.abs(_forward(actor, changed) - out)[:, : MOVE + k].max() > 1e-6, layout.names[column]
    with pytest.raises(ValueError, match="observations of 48 features; the actor reads 52"):
        _forward(actor, obs[:, :end])


@pytest.mark.parametrize("compiled", [True, False])
def test_the_numpy_forward_of_the_energy_layout_is_the_torch_forward(compiled, monkeypatch):
    import agents.node_set

    monkeypatch.setattr(agents.node_set, "COMPILED", compiled)
    layout = exact_layout(4, energy=True)
    numpy_forward = _energy_actor(layout, seed=3).to_numpy()
    actor = _energy_actor(layout, seed=3)
    for k in (1, 2, 3, 4):
        batch = random_obs(layout, k, rows=5, seed=k)
        np.testing.assert_allclose(numpy_forward(batch), _forward(actor, batch), rtol=1e-10, atol=1e-10)
        for row in batch[:2]:  # one observation: the compiled path (energy features > 0.5, not masks)
            single = numpy_forward(row)
            np.testing.assert_allclose(single, _forward(actor, row[None])[0], rtol=1e-10, atol=1e-10)
            assert np.all(single[MOVE + k :] == 0.0)
    with pytest.raises(ValueError, match="the actor reads 40"):
        numpy_forward(batch[0, :-1])


def test_pooled_statistics_keep_the_energy_features_per_column():
    from agents.node_set import pooled_statistics

    layout = exact_layout(4, energy=True)
    obs = np.concatenate([random_obs(layout, 2, rows=30, seed=1), random_obs(layout, 4, rows=30, seed=2)])
    mean, var = pooled_statistics(obs, layout.k_max, layout.width, layout.extra)
    end = layout.nodes_end
    assert mean.shape == var.shape == (layout.size,)
    np.testing.assert_allclose(mean[end:], obs[:, end:].mean(0))
    np.testing.assert_allclose(var[end:], obs[:, end:].var(0))
    real = obs[:, BASE:end].reshape(-1, layout.width)
    real = real[real[:, MASK] > 0.5]
    np.testing.assert_allclose(mean[BASE + 1 : BASE + layout.width], real.mean(0)[1:])
    with pytest.raises(ValueError, match="obs: shape"):
        pooled_statistics(obs, layout.k_max, layout.width)  # the energy features not declared


@pytest.mark.parametrize("by_name", [True, False])
def test_the_node_set_policy_trains_on_the_energy_env_and_exports_and_reloads(by_name, tmp_path):
    from stable_baselines3 import PPO

    from agents.node_set import NodeSetActor, NodeSetPolicy
    from agents.numpy_policy import NumpyPolicy

    env = energy_env()
    kwargs = {"net_arch": {"pi": [16, 16], "vf": [32]}}
    if by_name:
        kwargs["observation_names"] = env.unwrapped.observation_names
    model = PPO(NodeSetPolicy, env, n_steps=64, batch_size=32, n_epochs=2, policy_kwargs=kwargs,
                device="cpu", seed=0)  # fmt: skip
    actor = model.policy.mlp_extractor.policy_net
    assert isinstance(actor, NodeSetActor) and (actor.k_max, actor.width, actor.extra) == (3, 6, EXTRA)
    before = [p.detach().clone() for p in actor.parameters()]
    model.learn(256)
    assert model.num_timesteps == 256
    assert any(not th.equal(a, b) for a, b in zip(before, actor.parameters(), strict=True))  # it trained
    obs = np.stack([env.reset(seed=s)[0] for s in range(3)])
    obs[:, -EXTRA:] = 0.9  # the energy features after a move: never read as node blocks
    predicted, _ = model.predict(obs, deterministic=True)
    np.testing.assert_allclose(NumpyPolicy.from_sb3(model).act(obs), predicted, atol=1e-5)
    model.save(tmp_path / "m.zip")
    loaded = PPO.load(tmp_path / "m.zip", device="cpu")
    assert loaded.policy.observation_names == (env.unwrapped.observation_names if by_name else None)
    assert loaded.policy.mlp_extractor.policy_net.extra == EXTRA
    np.testing.assert_array_equal(loaded.predict(obs, deterministic=True)[0], predicted)


# --- the node-order average ------------------------------------------------------------------------
def test_the_node_order_average_reads_the_energy_layout_by_name_and_keeps_the_energy_features():
    env = energy_env(RANDOM_ID)
    layout = NodeLayout.from_names(env.unwrapped.observation_names)
    rng = np.random.default_rng(4)
    w1 = rng.standard_normal((layout.size, 32)) / 8
    w2 = rng.standard_normal((32, MOVE + layout.k_max))
    seen = []

    def mlp(obs):
        seen.append(obs)
        return np.tanh(np.tanh(obs @ w1) @ w2)

    average = NodeOrderAverage.for_layout(mlp, env.unwrapped.observation_names)
    assert (average.k_max, average.width, average.extra) == (4, 6, EXTRA)
    obs = random_obs(layout, 3, seed=5)[0]
    out = average(obs)
    assert len(seen) == 6 and all(
        np.array_equal(o[layout.nodes_end :], obs[layout.nodes_end :]) for o in seen
    )
    end, nodes = layout.nodes_end, obs[BASE : layout.nodes_end].reshape(4, 6)
    for perm in itertools.permutations(range(3)):  # equivariant on the energy layout too
        order = [*perm, 3]
        moved = average(np.concatenate([obs[:BASE], nodes[order].ravel(), obs[end:]]))
        np.testing.assert_allclose(moved[:MOVE], out[:MOVE], atol=1e-6)
        np.testing.assert_allclose(moved[MOVE : MOVE + 3], out[MOVE + np.array(perm)], atol=1e-6)
    # the average built from the sizes of the rate layout refuses the energy observation, naming why
    with pytest.raises(ValueError, match=r"has shape \(36,\).*NodeOrderAverage.for_layout"):
        NodeOrderAverage(mlp, 4, 6)(obs)
    with pytest.raises(ValueError, match="no node block"):
        NodeOrderAverage.for_layout(mlp, gym.make("ios_uav_env/IOSUAV-v0").unwrapped.observation_names)


# --- the imitation fit and the expert's node mask ---------------------------------------------------
def test_permute_nodes_keeps_the_energy_features_in_place():
    from agents.expert import node_mask
    from agents.fitting import permute_nodes

    layout = exact_layout(4, energy=True)
    obs = random_obs(layout, 3, rows=40, seed=6).astype(np.float32)
    labels = np.zeros((40, MOVE + 4), dtype=np.float32)
    valid = th.as_tensor(node_mask(obs, 4, 6))
    x, _, m = permute_nodes(th.as_tensor(obs), th.as_tensor(labels), valid.clone(), valid, 4, 6,
                            th.Generator().manual_seed(0), EXTRA)  # fmt: skip
    x = x.numpy()
    end = layout.nodes_end
    np.testing.assert_array_equal(x[:, end:], obs[:, end:])
    np.testing.assert_array_equal(x[:, :BASE], obs[:, :BASE])
    blocks, before = x[:, BASE:end].reshape(40, 4, 6), obs[:, BASE:end].reshape(40, 4, 6)
    for i in range(40):  # the same nodes, in some order
        assert sorted(map(tuple, blocks[i, :3])) == sorted(map(tuple, before[i, :3]))
    assert np.any(blocks[:, 0] != before[:, 0]) and m.numpy().sum() == 120
    with pytest.raises(ValueError, match=r"12 \+ 4 x 6 \+ 0 after the blocks expected"):
        permute_nodes(th.as_tensor(obs), th.as_tensor(labels), valid, valid, 4, 6, th.Generator())


def test_the_expert_node_mask_reads_the_mask_features_of_the_energy_layout():
    from agents.expert import node_mask
    from ios_uav_env.envs.observation_layout import require_features

    env = energy_env(RANDOM_ID)
    names = env.unwrapped.observation_names
    obs = np.stack([env.reset(seed=s)[0] for s in range(6)])
    obs[:, -EXTRA:] = 1.0  # a stride past the node blocks would read these as masks
    columns = list(require_features([f"mask_{k}" for k in range(4)], names))
    np.testing.assert_array_equal(node_mask(obs, 4, 6), obs[:, columns] > 0.5)
    with pytest.raises(ValueError, match="obs: shape"):
        node_mask(obs[:, :30], 4, 6)


def test_the_fit_reads_the_energy_layout_of_its_observations(monkeypatch):
    import agents.fitting
    from agents.expert import Dataset, node_mask
    from agents.fitting import fit, permute_nodes
    from agents.imitation import ImitationSettings, _new_model

    env = energy_env(RANDOM_ID).unwrapped  # 40 features: (40 - 12) / 4 = 7 would be a misreading
    obs = np.stack([env.reset(seed=s)[0] for s in range(40)]).astype(np.float32)
    labels = np.random.default_rng(0).uniform(-1, 1, (40, MOVE + 4)).astype(np.float32)
    data = Dataset(obs, labels, np.zeros(40, dtype=np.int64))
    model, venv = _new_model(ImitationSettings(out="x", net_arch=(8,), policy="node-set"), env, obs)
    assert model.policy.observation_names == env.observation_names
    assert model.policy.mlp_extractor.policy_net.extra == EXTRA
    assert venv.obs_rms.mean.shape == (40,)
    seen = []
    monkeypatch.setattr(agents.fitting, "permute_nodes", lambda *a: seen.append(a[5:]) or permute_nodes(*a))
    mask = node_mask(obs, 4, 6)
    for names in (env.observation_names, None):  # by name, and from the sizes
        seen.clear()
        losses = fit(
            model, venv, data, mask, 1, 16, 1e-3, progress=False, permute=True, observation_names=names
        )
        assert np.isfinite(losses["move"]) and seen
        assert all(s[0] == 6 and s[2] == EXTRA for s in seen)  # width 6, the 4 energy features kept
    with pytest.raises(ValueError, match="no node block"):
        fit(
            model,
            venv,
            data,
            mask,
            1,
            16,
            1e-3,
            progress=False,
            permute=True,
            observation_names=BASE_FEATURES,
        )


# --- the multi-node comparison -------------------------------------------------------------------
def _agent(env, env_kwargs):
    model = SimpleNamespace(observation_space=env.observation_space)
    return SimpleNamespace(name="energy-agent", model=model, env_kwargs=env_kwargs, env_id=FIXED_ID)


@pytest.mark.parametrize("kwargs", [ENERGY, {**ENERGY, "peak_hint": True}])
def test_the_comparison_reads_k_max_of_an_energy_model(kwargs):
    from agents.evaluate_multi import agent_max_nodes, model_layout, model_max_nodes

    for k in (3, 4):
        env = gym.make(FIXED_ID, max_nodes=k, **kwargs)
        agent = _agent(env, kwargs)
        assert model_max_nodes(agent) == agent_max_nodes(agent) == k
        assert model_layout(agent).names == env.unwrapped.observation_names
    # the energy observation with env_kwargs that do not make it: refused, naming the layout
    with pytest.raises(ValueError, match=r"energy-agent: observations of shape \(34,\) are not"):
        model_max_nodes(_agent(energy_env(), {}))
    with pytest.raises(ValueError, match=r"\+ 4 energy features \(move_x"):
        model_max_nodes(_agent(gym.make(FIXED_ID), ENERGY))


def test_the_suite_report_averages_node_orders_on_the_layout_of_its_env():
    from agents.suite.multi import suite_names
    from ios_uav_env.benchmark import load_suite

    suite = load_suite("multi-node-v1")
    names = suite_names(suite, {**ENERGY, "peak_hint": True})
    assert names[-EXTRA:] == ENERGY_NAMES
    average = NodeOrderAverage.for_layout(lambda obs: np.zeros(MOVE + 4), names)
    assert (average.width, average.extra, average.obs_size) == (9, EXTRA, len(names))


def test_an_imitation_run_refuses_the_energy_objective_before_it_runs(tmp_path):
    """The tour expert plans the max-min rate (scenarios of objective 'rate'): an imitation run on the
    energy objective is refused by its settings, naming the objective and what to do."""
    from agents.imitation import ImitationSettings

    settings = ImitationSettings(out=str(tmp_path / "run"), env_kwargs={"softmin_beta": 20, **ENERGY})
    with pytest.raises(ValueError, match="objective='energy_efficiency'.*max-min rate.*train .* with PPO"):
        settings.validate()
    assert not (tmp_path / "run").exists()
    ImitationSettings(out=str(tmp_path / "run"), env_kwargs={"objective": "rate"}).validate()
