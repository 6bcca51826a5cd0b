"""agents.expert (the tour expert and its labelled episodes) and agents.imitation (the imitation
loss, the fit and a resumable run)."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("cvxpy")

import torch as th  # noqa: E402

from agents.expert import Dataset, hindsight_shares, node_mask, rollouts, tour_plans  # noqa: E402
from agents.fitting import fit, imitation_loss, obs_normalizer, permute_nodes  # noqa: E402
from agents.imitation import ImitationSettings, main, run, share_rows  # noqa: E402
from ios_uav_env import maxmin_rate  # noqa: E402
from ios_uav_env.envs.multi import BASE_FEATURES, NODE_FEATURES, NODE_PEAK_FEATURES, share_scores  # noqa: E402
from ios_uav_env.model.schedule import maxmin_schedule, node_rates  # noqa: E402

KW = {"softmin_beta": 20, "peak_hint": True}
SEEDS = (1_000_003, 1_000_001)  # a 2-node and a 3-node scenario of the random family


@pytest.fixture(scope="module")
def plan_cache(tmp_path_factory):
    return tmp_path_factory.mktemp("plans")


@pytest.fixture(scope="module")
def plans(plan_cache):
    out = [p for seed in SEEDS for p in tour_plans(1, plan_cache, first_seed=seed, jobs=1, progress=False)]
    assert [p.config.K for p in out] == [2, 3]
    return out


def test_the_expert_replays_its_plan_and_scores_like_it(plans):
    data = rollouts(plans, KW)
    for i, plan in enumerate(plans):
        assert plan.rate == pytest.approx(maxmin_rate(plan.config, plan.trajectory))
        # slot 1 is shared equally by the env, the plan's own slot 1 may differ: within a slot's worth
        assert data.ratio[i] == pytest.approx(1.0, abs=1.5 / plan.config.N)
    assert len(data.obs) == len(data.labels) == sum(p.config.N - 1 for p in plans)
    assert data.obs.shape[1] == 12 + 9 * 4 and data.labels.shape[1] == 2 + 4
    mask = node_mask(data.obs, 4, 9)
    assert mask[data.episode == 0].sum(1).tolist() == [2] * (plans[0].config.N - 1)
    assert np.all(np.abs(data.labels) <= 1.0 + 1e-6)
    assert np.all(data.labels[data.episode == 0, 4:] == 0.0)  # K = 2: the padding scores are 0


def test_the_expert_steers_back_to_its_plan(plans):
    plan = plans[0]
    n = 40
    off = plan.trajectory[n] + np.array([60.0, -45.0])
    action = plan.action(n, off, 4, 5.0)
    after = off + plan.config.D * action[:2]
    assert np.linalg.norm(after - plan.trajectory[n + 1]) < np.linalg.norm(off - plan.trajectory[n + 1])
    assert np.hypot(*action[:2]) == pytest.approx(1.0)  # far off: full speed
    on = plan.action(n, plan.trajectory[n], 4, 5.0)
    np.testing.assert_allclose(plan.trajectory[n] + plan.config.D * on[:2], plan.trajectory[n + 1], atol=1e-4)
    assert np.all(on[2 + plan.config.K :] == 0.0)  # padding


def test_noisy_episodes_leave_the_plan_and_are_labelled_by_the_expert(plans):
    clean, noisy = rollouts(plans, KW), rollouts(plans, KW, noise=0.5, seed=1)
    assert not np.allclose(clean.obs[:, :2], noisy.obs[:, :2])
    assert np.all(noisy.ratio < clean.ratio + 1e-9)
    # every label is the expert's action from the state it labels: replay one episode
    sel = noisy.episode == 1
    position = noisy.obs[sel, :2] * 400.0
    expected = np.array([plans[1].action(n, q, 4, 5.0) for n, q in enumerate(position)])
    np.testing.assert_allclose(noisy.labels[sel], expected, atol=1e-4)
    with pytest.raises(ValueError, match="noise must be"):
        rollouts(plans, KW, noise=-1.0)


def test_hindsight_shares_make_up_for_what_was_served():
    r = np.ones((2, 11))  # the same rate everywhere: only the balance served so far matters
    executed = np.zeros((2, 11))
    executed[:, 0] = 0.5
    executed[0, 1:6] = 1.0  # node 0 served in slots 1..5, node 1 starved
    labels = hindsight_shares(r, executed, 1)
    np.testing.assert_array_equal(labels[:, 0], [0.5, 0.5])  # slot 0 is the env's
    np.testing.assert_allclose(labels[:, 6:], np.tile([[0.0], [1.0]], 5), atol=1e-12)  # node 1 catches up
    one = hindsight_shares(r, executed, 20)  # a single solve at slot 1: the best schedule from there
    assert np.mean(one * r, axis=1).min() == pytest.approx(maxmin_schedule(r, executed[:, :1]).value)
    np.testing.assert_array_equal(hindsight_shares(r, executed, 3)[:, 1:4], one[:, 1:4])
    with pytest.raises(ValueError, match="block: must be an integer >= 1"):
        hindsight_shares(r, executed, 0)


def test_hindsight_rollouts_relabel_each_state_with_its_episodes_continuation(plans):
    plain = rollouts(plans, KW, noise=0.5, seed=3)
    data = rollouts(plans, KW, noise=0.5, seed=3, hindsight_block=4, jobs=1)
    np.testing.assert_array_equal(data.obs, plain.obs)  # the same episodes, the moves' labels unchanged
    np.testing.assert_array_equal(data.labels[:, :2], plain.labels[:, :2])
    assert not np.allclose(data.labels[:, 2:], plain.labels[:, 2:])
    import gymnasium as gym

    from agents.expert import RANDOM_ID

    for i, plan in enumerate(plans):  # replay episode i's executed actions to get its shares
        env = gym.make(RANDOM_ID, **KW).unwrapped
        env.reset(options={"config": plan.config})
        rng, sel = np.random.default_rng(3), plain.episode == i
        for step in range(plan.config.N - 1):  # the noise draws of the lockstep batch
            noise = rng.normal(0.0, 0.5, (sum(step < p.config.N - 1 for p in plans), 2))
            act = plain.labels[sel][step].copy()
            act[:2] += noise[[j for j, p in enumerate(plans) if step < p.config.N - 1].index(i)]
            env.step(np.clip(act, -1.0, 1.0))
        expected = hindsight_shares(node_rates(plan.config, env.trajectory), env.shares, 4)
        k = plan.config.K
        np.testing.assert_allclose(
            data.labels[sel, 2 : 2 + k], share_scores(expected[:, 1:], 5.0).T, atol=1e-6
        )


def test_permute_nodes_reorders_each_rows_real_nodes_and_their_labels_alike():
    k_max, width, rows = 4, 9, 60
    ks = np.tile([2, 3, 4], rows // 3)
    obs = np.zeros((rows, 12 + k_max * width), dtype=np.float32)
    obs[:, :12] = np.arange(12)
    labels = np.zeros((rows, 2 + k_max), dtype=np.float32)
    labels[:, :2] = [0.25, -0.5]
    for i, k in enumerate(ks):
        for j in range(k):
            obs[i, 12 + j * width : 12 + (j + 1) * width] = [1.0] + [10 * j + f for f in range(1, width)]
            labels[i, 2 + j] = 10 * j  # node j's score names node j
    valid = th.as_tensor(node_mask(obs, k_max, width))
    x, y, m = permute_nodes(th.as_tensor(obs), th.as_tensor(labels), valid.clone(), valid, k_max, width,
                            th.Generator().manual_seed(0))  # fmt: skip
    x, y, m = x.numpy(), y.numpy(), m.numpy()
    np.testing.assert_array_equal(x[:, :12], obs[:, :12])
    np.testing.assert_array_equal(y[:, :2], labels[:, :2])
    blocks = x[:, 12:].reshape(rows, k_max, width)
    for i, k in enumerate(ks):
        ids = blocks[i, :k, 1] // 10  # which node each slot now holds
        assert sorted(ids.tolist()) == list(range(k))  # the same nodes, in some order
        np.testing.assert_array_equal(y[i, 2 : 2 + k], 10 * ids)  # each with its own label
        assert np.all(blocks[i, k:] == 0) and np.all(y[i, 2 + k :] == 0) and m[i].sum() == k
    assert np.any(blocks[:, 0, 1] != 0)  # not the identity


def test_fit_permutes_the_nodes_only_when_asked(plans, monkeypatch):
    import gymnasium as gym

    import agents.fitting
    from agents.expert import RANDOM_ID
    from agents.imitation import _new_model

    data = rollouts(plans[:1], KW)
    model, venv = _new_model(
        ImitationSettings(out="x", net_arch=(16,)), gym.make(RANDOM_ID, **KW).unwrapped, data.obs
    )
    calls = []
    monkeypatch.setattr(agents.fitting, "permute_nodes", lambda *a: calls.append(1) or permute_nodes(*a))
    mask = node_mask(data.obs, 4, 9)
    fit(model, venv, data, mask, 1, 64, 1e-3, progress=False)
    assert not calls
    fit(model, venv, data, mask, 1, 64, 1e-3, progress=False, permute=True)
    assert len(calls) == -(-len(data.obs) // 64)


def test_imitation_loss_is_zero_at_the_labels_and_ignores_padding():
    labels = th.tensor([[0.5, -0.5, 1.0, -0.2, 0.0, 0.0], [0.0, 0.0, -1.0, 1.0, 0.3, 0.0]])
    mask = th.tensor([[1, 1, 0, 0], [1, 1, 1, 0]], dtype=th.bool)
    move, share = imitation_loss(labels.clone(), labels, mask)
    assert move.item() == 0.0 and share.item() == 0.0
    padded = labels.clone()
    padded[0, 4:] = 1.0  # padding entries: the env ignores them, so must the loss
    padded[1, 5] = 1.0
    assert imitation_loss(padded, labels, mask)[1].item() == 0.0
    wrong = labels.clone()
    wrong[0, 2:4] = th.tensor([-0.2, 1.0])  # the other node served: 2 x 1.2^2 / 6 / 2 states
    wrong[1, :2] = 0.3  # 4 x 2 x 0.3^2 / 6 / 2 states
    move, share = imitation_loss(wrong, labels, mask)
    assert move.item() == pytest.approx(4 * 2 * 0.09 / 6 / 2) and share.item() == pytest.approx(
        2 * 1.44 / 6 / 2
    )


def test_a_run_fits_the_labels_resumes_and_loads(plans, plan_cache, tmp_path):
    from agents.loading import load_agent

    out = tmp_path / "run"
    kw = dict(out=str(out), scenarios=1, first_seed=SEEDS[0], epochs=30, net_arch=(32, 32), batch_size=64,
              learning_rate=3e-3, plans=str(plan_cache), progress=False, jobs=1)  # fmt: skip
    summary = run(ImitationSettings(rounds=1, **kw))
    first = summary["rounds"][0]
    assert first["played"] == "expert" and first["ratio_mean"] == pytest.approx(1.0, abs=0.02)
    agent = load_agent(out)
    data = Dataset.load(out / "data" / "round_0.npz")
    clean = data.episode[: len(data.episode) // 2] == 0
    error = np.abs(agent.act(data.obs[: len(clean)])[:, :2] - data.labels[: len(clean), :2]).mean()
    untrained = np.abs(data.labels[: len(clean), :2]).mean()
    assert error < 0.5 * untrained  # it learnt the moves
    stamp = (out / "data" / "round_0.npz").stat().st_mtime_ns
    summary = run(ImitationSettings(rounds=2, **kw))  # resumes: round 0 is read back, round 1 is new
    assert [r["round"] for r in summary["rounds"]] == [0, 1] and summary["rounds"][1]["played"] == "policy"
    assert (out / "data" / "round_0.npz").stat().st_mtime_ns == stamp
    config = json.loads((out / "config.json").read_text())
    assert config["trained_by"] == "agents.imitation" and config["env_id"].endswith("MultiNode-Random-v0")
    with pytest.raises(ValueError, match=r"other settings \(epochs: 30 -> 5, noise: 0.3 -> 0.1\)"):
        run(ImitationSettings(rounds=3, **{**kw, "epochs": 5}, noise=0.1))  # would mix two recipes' data
    assert not (out / "data" / "round_2.npz").exists()
    # hindsight labels may start at a round not played yet, and not earlier
    summary = run(ImitationSettings(rounds=3, hindsight_from=2, hindsight_block=3, **kw))
    assert [r["round"] for r in summary["rounds"]] == [0, 1, 2]
    with pytest.raises(ValueError, match=r"other settings \(hindsight_from: 2 -> 1\)"):
        run(ImitationSettings(rounds=4, hindsight_from=1, hindsight_block=3, **kw))
    # the polish: the last round's model, fitted again with the nodes in random order
    polished = run(ImitationSettings(rounds=3, hindsight_from=2, hindsight_block=3, polish_epochs=2, **kw))
    assert polished["polish"]["after_round"] == 2 and polished["polish"]["epochs"] == 2
    final, last = _round_policy(out), _round_policy(out / "rounds" / "2")
    obs = Dataset.load(out / "data" / "round_2.npz").obs[:20]
    assert not np.allclose(final(obs), last(obs))
    assert "polish" not in run(ImitationSettings(rounds=3, hindsight_from=2, hindsight_block=3, **kw))
    np.testing.assert_allclose(_round_policy(out)(obs), last(obs))  # without it, the last round's model
    played = Dataset.load(out / "data" / "round_2.npz")
    replay = rollouts(plans[:1], KW, policy=_round_policy(out / "rounds" / "1"))
    np.testing.assert_allclose(played.obs, replay.obs, atol=1e-5)  # the round-1 policy's episode ...
    assert not np.allclose(played.labels[:, 2:4], replay.labels[:, 2:4])  # ... with hindsight shares


def test_permute_reaches_every_rounds_fit_and_is_part_of_the_recipe(plan_cache, tmp_path, monkeypatch):
    import agents.imitation

    seen = []
    real = agents.imitation.fit

    def recording(*args, **kwargs):
        seen.append(kwargs.get("permute", False))
        return real(*args, **kwargs)

    monkeypatch.setattr(agents.imitation, "fit", recording)
    out = tmp_path / "run"
    kw = dict(out=str(out), scenarios=1, first_seed=SEEDS[0], epochs=1, net_arch=(8,), batch_size=64,
              plans=str(plan_cache), progress=False, jobs=1)  # fmt: skip
    run(ImitationSettings(rounds=2, permute=True, **kw))
    assert seen == [True, True]
    settings = json.loads((out / "settings.json").read_text())
    assert settings["permute"] is True
    with pytest.raises(ValueError, match=r"other settings \(permute: True -> False\)"):
        run(ImitationSettings(rounds=3, **kw))  # the rounds so far were fitted otherwise
    del settings["permute"]  # a run recorded before the field: fitted without the permutation
    (out / "settings.json").write_text(json.dumps(settings))
    with pytest.raises(ValueError, match=r"other settings \(permute: False -> True\)"):
        run(ImitationSettings(rounds=3, permute=True, **kw))
    seen.clear()
    run(ImitationSettings(rounds=3, **kw))
    assert seen == [False]  # round 2 only: rounds 0 and 1 are read back


def test_a_node_set_run_trains_the_equivariant_actor_on_pooled_statistics(plan_cache, tmp_path):
    from agents.loading import load_agent, load_numpy_agent
    from agents.node_set import NodeSetPolicy

    out = tmp_path / "run"
    kw = dict(out=str(out), scenarios=1, first_seed=SEEDS[0], epochs=2, net_arch=(8,), batch_size=64,
              plans=str(plan_cache), progress=False, jobs=1)  # fmt: skip
    run(ImitationSettings(rounds=1, policy="node-set", **kw))
    agent = load_agent(out)
    assert isinstance(agent.model.policy, NodeSetPolicy)
    config = json.loads((out / "config.json").read_text())
    assert config["hyperparams"]["policy"] == "agents.node_set.NodeSetPolicy"
    rms, base = agent.vecnormalize.obs_rms, len(BASE_FEATURES)
    for stat in (rms.mean, rms.var):  # one statistic for all slots; the mask left 0 or 1
        blocks = stat[base:].reshape(4, len(NODE_FEATURES) + len(NODE_PEAK_FEATURES))
        np.testing.assert_array_equal(blocks, np.broadcast_to(blocks[0], blocks.shape))
    assert (rms.mean[base], rms.var[base]) == (0.0, 1.0)
    obs = Dataset.load(out / "data" / "round_0.npz").obs[:10]
    numpy_agent = load_numpy_agent(out)
    np.testing.assert_allclose(numpy_agent(obs), agent.act(obs), atol=1e-5)
    np.testing.assert_allclose(numpy_agent(obs[3]), agent.act(obs[3:4])[0], atol=1e-5)  # one at a time
    with pytest.raises(ValueError, match=r"other settings \(policy: 'node-set' -> 'mlp'\)"):
        run(ImitationSettings(rounds=2, **kw))
    settings = json.loads((out / "settings.json").read_text())
    del settings["policy"]  # a run recorded before the field: an MLP's
    (out / "settings.json").write_text(json.dumps(settings))
    with pytest.raises(ValueError, match=r"other settings \(policy: 'mlp' -> 'node-set'\)"):
        run(ImitationSettings(rounds=2, policy="node-set", **kw))


def test_the_cli_picks_the_networks_own_default_widths(tmp_path):
    from agents.imitation import NODE_SET_ARCH, _checked_settings, build_parser

    parser = build_parser()
    for policy, arch in (("node-set", NODE_SET_ARCH), ("mlp", ImitationSettings.net_arch)):
        args = parser.parse_args(["--out", str(tmp_path / policy), "--policy", policy])
        assert _checked_settings(parser, args).net_arch == arch
    args = parser.parse_args(["--out", str(tmp_path / "w"), "--policy", "node-set", "--net-arch", "32"])
    assert _checked_settings(parser, args).net_arch == (32,)


def _round_policy(folder):
    """The numpy actor of a round's model, as ``run`` plays it."""
    import gymnasium as gym
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from agents.expert import RANDOM_ID
    from agents.numpy_policy import NumpyPolicy

    venv = VecNormalize.load(
        str(folder / "vecnormalize.pkl"), DummyVecEnv([lambda: gym.make(RANDOM_ID, **KW)])
    )
    return NumpyPolicy.from_sb3(PPO.load(folder / "model.zip", device="cpu"), venv).act


def test_share_rows_keep_the_labels_of_best_schedules_only(plans):
    rows = [p.config.N - 1 for p in plans]
    part = Dataset(np.zeros((sum(rows), 1)), np.zeros((sum(rows), 1)), np.zeros(sum(rows)))
    parts = [Dataset.concat([part, part]), part, part]  # round 0 (clean, noisy), rounds 1 and 2
    plain = ImitationSettings(out="x")
    assert share_rows(plain, 2, parts, plans).all()  # no hindsight: every label, as before
    keep = share_rows(ImitationSettings(out="x", hindsight_from=2), 2, parts, plans)
    n = sum(rows)
    expected = np.concatenate([np.ones(n), np.zeros(n), np.zeros(n), np.ones(n)]).astype(bool)
    np.testing.assert_array_equal(keep, expected)
    assert share_rows(ImitationSettings(out="x", hindsight_from=2), 1, parts[:2], plans).all()


@pytest.mark.parametrize(
    "field, value",
    [
        ("scenarios", 0),
        ("rounds", 1.5),
        ("noise", -0.1),
        ("learning_rate", 2.0),
        ("net_arch", ()),
        ("env_kwargs", {"max_nodes": 3}),
        ("permute", 1),
        ("round_fraction", 0.0),
        ("round_fraction", 1.5),
        ("policy", "cnn"),
    ],  # fmt: skip
)
def test_bad_settings_name_the_field(field, value, tmp_path):
    with pytest.raises(ValueError, match=field):
        ImitationSettings(out=str(tmp_path), **{field: value}).validate()


def test_the_cli_rejects_bad_arguments(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--out", str(tmp_path), "--noise", "-1"])
    assert exc.value.code == 2 and "noise" in capsys.readouterr().err


def test_fit_lowers_the_loss_on_a_tiny_dataset(plans):
    import gymnasium as gym

    from agents.expert import RANDOM_ID
    from agents.imitation import _new_model

    data = rollouts(plans[:1], KW)
    env = gym.make(RANDOM_ID, **KW).unwrapped
    model, venv = _new_model(ImitationSettings(out="x", net_arch=(32,)), env, data.obs)
    mask = node_mask(data.obs, 4, 9)
    before = fit(model, venv, data, mask, 1, 64, 1e-9, progress=False)
    after = fit(model, venv, data, mask, 20, 64, 3e-3, progress=False)
    assert after["move"] < 0.5 * before["move"] and after["share"] < before["share"]


def test_the_fits_normalisation_is_the_vecnormalize_one_bit_for_bit(plans):
    """The fit normalises its batches in torch; the policy is run on ``VecNormalize``'s numpy
    normalisation, so the two must agree exactly, clipping included."""
    import gymnasium as gym

    from agents.expert import RANDOM_ID
    from agents.imitation import _new_model

    data = rollouts(plans[:1], KW)
    env = gym.make(RANDOM_ID, **KW).unwrapped
    _, venv = _new_model(ImitationSettings(out="x", net_arch=(8,)), env, data.obs)
    obs = np.concatenate([data.obs, data.obs * 1e4]).astype(np.float32)  # the second half clips
    want = venv.normalize_obs(obs).astype(np.float32)
    assert np.any(np.abs(want) == venv.clip_obs)
    np.testing.assert_array_equal(obs_normalizer(venv)(th.as_tensor(obs)).numpy(), want)
    venv.norm_obs = False
    np.testing.assert_array_equal(obs_normalizer(venv)(th.as_tensor(obs)).numpy(), obs)


def test_round_fraction_keeps_a_seeded_share_of_each_dagger_rounds_states(plan_cache, tmp_path):
    """Round 0 (the expert's passes) stays whole; a DAgger round keeps about ``round_fraction``
    of its states, the same ones in a rerun, with the per-episode ratios whole."""
    kw = dict(scenarios=1, first_seed=SEEDS[0], epochs=1, net_arch=(8,), batch_size=256,
              plans=str(plan_cache), progress=False, jobs=1, rounds=2)  # fmt: skip
    runs = {}
    for name, fraction in (("all", 1.0), ("half", 0.5), ("again", 0.5)):
        run(ImitationSettings(out=str(tmp_path / name), round_fraction=fraction, **kw))
        runs[name] = [Dataset.load(tmp_path / name / "data" / f"round_{r}.npz") for r in (0, 1)]
    whole, half, again = runs["all"][1], runs["half"][1], runs["again"][1]
    assert len(runs["half"][0].obs) == len(runs["all"][0].obs)
    assert 0.3 * len(whole.obs) < len(half.obs) < 0.7 * len(whole.obs)
    np.testing.assert_array_equal(half.obs, again.obs)
    assert np.isin(half.obs, whole.obs).all() and len(half.ratio) == len(whole.ratio)
    rng = np.random.default_rng(0)
    assert len(whole.sample(1.0, rng).obs) == len(whole.obs)
    with pytest.raises(ValueError, match="fraction"):
        whole.sample(0.0, rng)
