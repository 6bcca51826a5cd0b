"""The compiled PPO update (agents.fast.kernel) against torch's autograd and Adam.

The kernel computes in float32 with its own order of sums (BLAS products, a rational tanh
within 3e-7 of torch's): its gradients agree with torch's to a few 1e-7 relative on this
machine, and the tolerances below (1e-5 relative on a gradient, 1e-5 absolute on parameters
after an update) hold on any x86-64 or ARM CPU while a wrong term (a missing clip, a factor,
a frozen parameter that moves) is off by far more."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

pytest.importorskip("numba")

from agents.fast import FastPPO, FastRecipe  # noqa: E402
from agents.fast.kernel import SETTINGS, minibatch_gradient, update_settings  # noqa: E402
from agents.fast.kernel_policy import KernelUpdate  # noqa: E402
from agents.hyperparams import check_entry, resolve  # noqa: E402
from tests.agents.test_fast import ENV, MULTI, entry  # noqa: E402

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def recipe(**overrides) -> FastRecipe:
    """test_fast's tiny recipe with 3 epochs of 64-sample minibatches and nets of depth 1-2."""
    base = {"n_timesteps": 4096, "batch_size": 64, "n_epochs": 3, "max_grad_norm": 0.5,
            "policy_kwargs": "dict(net_arch=dict(pi=[32, 16], vf=[24]), log_std_init=-1.0)"}  # fmt: skip
    return FastRecipe.from_hyperparams(resolve(check_entry("ppo", entry(**{**base, **overrides}))))


def sb3_policy(env_id: str = ENV, net_arch=None, activation=None, seed: int = 0):
    import gymnasium as gym
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    kwargs = {"net_arch": net_arch or {"pi": [32, 32], "vf": [16]}, "log_std_init": -0.5}
    if activation is not None:
        kwargs["activation_fn"] = activation
    env = DummyVecEnv([lambda: gym.make(env_id)])
    return PPO("MlpPolicy", env, policy_kwargs=kwargs, device="cpu", seed=seed).policy


def torch_loss(policy, obs, actions, old_logp, adv, returns, clip, vf_coef, ent_coef, stats=None):
    """FastPPO's torch loss (the reference), written out here once more; ``stats``: a dict that
    receives the approx KL and the clip fraction."""
    x = torch.from_numpy(obs)
    ex = policy.mlp_extractor
    mean = policy.action_net(ex.forward_actor(x))
    value = policy.value_net(ex.forward_critic(x)).squeeze(-1)
    log_std = policy.log_std
    z = (torch.from_numpy(actions) - mean) * torch.exp(-log_std)
    logp = (-0.5 * z * z - log_std - 0.5 * math.log(2 * math.pi)).sum(-1)
    log_ratio = logp - torch.from_numpy(old_logp)
    ratio = torch.exp(log_ratio)
    a = torch.from_numpy(adv)
    if a.numel() > 1:  # as SB3: one sample has no spread to normalise by
        a = (a - a.mean()) / (a.std() + 1e-8)
    if stats is not None:
        r, lr = ratio.detach(), log_ratio.detach()
        stats["approx_kl"] = float(torch.mean(r - 1.0 - lr))
        stats["clip_fraction"] = float(torch.mean((torch.abs(r - 1.0) > clip).float()))
    policy_loss = -torch.min(a * ratio, a * torch.clamp(ratio, 1 - clip, 1 + clip)).mean()
    value_loss = torch.mean((torch.from_numpy(returns) - value) ** 2)
    entropy = (log_std + 0.5 * math.log(2 * math.pi * math.e)).sum()
    return policy_loss + vf_coef * value_loss - ent_coef * entropy, policy_loss, value_loss


def minibatch(policy, m: int = 256, seed: int = 0):
    """Observations, actions sampled from the policy, old log-probabilities shifted so that about
    half the ratios leave the clip range, advantages and returns."""
    rng = np.random.default_rng(seed)
    obs_dim = policy.observation_space.shape[0]
    obs = rng.standard_normal((m, obs_dim)).astype(np.float32)
    with torch.no_grad():
        dist = policy.get_distribution(torch.from_numpy(obs))
        actions = dist.sample()
        old_logp = dist.log_prob(actions).numpy() + rng.normal(0.0, 0.3, m).astype(np.float32)
    adv = rng.standard_normal(m).astype(np.float32)
    returns = rng.standard_normal(m).astype(np.float32)
    return obs, actions.numpy(), old_logp, adv, returns


@pytest.mark.parametrize("parallel", [False, True])
@pytest.mark.parametrize(
    ("env_id", "net_arch"), [(ENV, {"pi": [32, 32], "vf": [16]}), (MULTI, {"pi": [16], "vf": [8, 8, 8]})]
)
def test_the_kernels_gradient_is_torchs(env_id, net_arch, parallel):
    policy = sb3_policy(env_id, net_arch)
    kernel = KernelUpdate.of(policy, policy.optimizer)
    assert kernel is not None
    obs, actions, old_logp, adv, returns = minibatch(policy)
    clip, vf_coef, ent_coef = 0.2, 0.5, 0.01
    expected: dict[str, float] = {}
    loss, policy_loss, value_loss = torch_loss(
        policy, obs, actions, old_logp, adv, returns, clip, vf_coef, ent_coef, expected
    )
    policy.zero_grad()
    loss.backward()
    theta = kernel._gather()[0]
    grad = np.zeros_like(theta)
    settings = update_settings(lr=1e-3, clip=clip, vf_coef=vf_coef, ent_coef=ent_coef, max_grad_norm=0.5,
                               target_kl=None, normalize=True, beta1=0.9, beta2=0.999, eps=1e-8)  # fmt: skip
    stats = minibatch_gradient(theta, grad, kernel.pi_layers, kernel.vf_layers, kernel.log_std_off, obs,
                               actions, old_logp, adv, returns, settings, parallel)  # fmt: skip
    assert 0.2 < stats[3] < 0.8  # both branches of the clipped surrogate are exercised
    np.testing.assert_allclose(
        stats[:2], [float(policy_loss.detach()), float(value_loss.detach())], rtol=1e-5
    )
    np.testing.assert_allclose(stats[2], expected["approx_kl"], rtol=1e-4)
    assert stats[3] == expected["clip_fraction"]  # counts of the same ratios (none near the edge)
    for p, offset in kernel.params:
        mine = grad[offset : offset + p.numel()].reshape(p.shape)
        scale = float(p.grad.abs().max())
        np.testing.assert_allclose(mine, p.grad.numpy(), rtol=0, atol=1e-5 * scale + 1e-12)


#: The update settings of the minibatch tests below.
MINIBATCH = {"lr": 1e-3, "clip": 0.2, "vf_coef": 0.5, "ent_coef": 0.01, "max_grad_norm": 0.5,
             "target_kl": None, "normalize": True, "beta1": 0.9, "beta2": 0.999, "eps": 1e-8}  # fmt: skip


def test_a_one_sample_minibatch_keeps_its_advantage():
    """A minibatch of one sample (a rollout one longer than a multiple of batch_size) is not
    normalised, as in SB3: its spread is undefined (0 / 0), and the gradient would be NaN."""
    policy = sb3_policy(ENV)
    kernel = KernelUpdate.of(policy, policy.optimizer)
    obs, actions, old_logp, adv, returns = minibatch(policy, m=1)
    with torch.no_grad():  # ratio 1: inside the clip range, the advantage's scale reaches the gradient
        old_logp = policy.get_distribution(torch.from_numpy(obs)).log_prob(torch.from_numpy(actions)).numpy()
    loss = torch_loss(policy, obs, actions, old_logp, adv, returns, 0.2, 0.5, 0.01)[0]
    policy.zero_grad()
    loss.backward()
    theta = kernel._gather()[0]
    grad = np.zeros_like(theta)
    minibatch_gradient(theta, grad, kernel.pi_layers, kernel.vf_layers, kernel.log_std_off, obs, actions,
                       old_logp, adv, returns, update_settings(**MINIBATCH))  # fmt: skip
    assert np.all(np.isfinite(grad))
    for p, offset in kernel.params:
        mine = grad[offset : offset + p.numel()].reshape(p.shape)
        scale = float(p.grad.abs().max())
        np.testing.assert_allclose(mine, p.grad.numpy(), rtol=0, atol=1e-5 * scale + 1e-12)


@pytest.mark.parametrize("parallel", [False, True])
def test_an_updates_first_ratios_are_one(parallel):
    """The rollout step's log-probabilities are the update's own (one formula): fed back into
    the gradient with the same parameters, every ratio is 1 to float32 rounding."""
    policy = sb3_policy(MULTI, {"pi": [32, 32], "vf": [16]})
    kernel = KernelUpdate.of(policy, policy.optimizer)
    kernel.parallel = parallel
    obs, _, _, adv, returns = minibatch(policy, m=64)
    noise = np.random.default_rng(3).standard_normal((64, 5)).astype(np.float32)
    theta = kernel.parameters()
    actions, logp, _ = kernel.act(theta, obs, noise)
    stats = minibatch_gradient(theta, np.zeros_like(theta), kernel.pi_layers, kernel.vf_layers,
                               kernel.log_std_off, obs, actions, logp, adv, returns,
                               update_settings(**MINIBATCH))  # fmt: skip
    assert 0.0 <= stats[2] < 1e-10
    assert stats[3] == 0.0


def updated(update: str, r: FastRecipe, seed: int = 0) -> FastPPO:
    algo = FastPPO(ENV, r, total=4 * r.rollout_size, env_kwargs={"T": 40}, seed=seed, update=update)
    torch.manual_seed(seed)
    algo.collect()
    algo.stats = algo.update()
    algo.close()
    return algo


@pytest.mark.parametrize(
    "overrides",
    [
        {},  # the log std trained, the gradient clipped at 0.5
        {"max_grad_norm": 0.01},  # every step clipped hard
        {"callback": [{"agents.callbacks.LogStdSchedule": {"start": -1.0, "end": -3.0}}]},  # log std frozen
        {"target_kl": 1e-4},  # an early stop part-way
        {"normalize_advantage": False},  # the advantages as GAE gave them
    ],
)
def test_an_update_by_the_kernel_is_torchs_update(overrides):
    """The same rollout and minibatch order: the parameters, Adam's state and the statistics
    after one update agree (the kernel writes them back into the SB3 policy and its optimizer)."""
    r = recipe(**overrides)
    ref, new = updated("torch", r), updated("kernel", r)
    assert ref.kernel is None and new.kernel is not None
    for (name, p), q in zip(ref.policy.named_parameters(), new.policy.parameters(), strict=True):
        np.testing.assert_allclose(q.detach().numpy(), p.detach().numpy(), rtol=0, atol=2e-5, err_msg=name)
        if p.requires_grad:
            s, t = ref.optimizer.state[p], new.optimizer.state[q]
            assert float(t["step"]) == float(s["step"]) > 0
            np.testing.assert_allclose(t["exp_avg"].numpy(), s["exp_avg"].numpy(), atol=1e-6, err_msg=name)
            np.testing.assert_allclose(
                t["exp_avg_sq"].numpy(), s["exp_avg_sq"].numpy(), rtol=1e-3, atol=1e-10
            )
    for key in ("policy_loss", "value_loss", "approx_kl", "clip_fraction"):
        assert new.stats[key] == pytest.approx(ref.stats[key], rel=1e-4, abs=1e-6), key
    if "callback" in overrides:  # a scheduled log std is set, never stepped
        np.testing.assert_array_equal(new.policy.log_std.detach().numpy(), -1.0)
    else:
        assert not np.allclose(new.policy.log_std.detach().numpy(), -1.0)
    steps = float(next(iter(new.optimizer.state.values()))["step"])
    if "target_kl" in overrides:
        assert 0 < steps < r.n_epochs * r.rollout_size // r.batch_size  # stopped part-way, as torch did
    else:
        assert steps == r.n_epochs * r.rollout_size // r.batch_size


def test_the_kernel_goes_on_from_torchs_adam_state():
    """An update by torch, then one by the kernel, equals two by torch: the kernel reads the
    optimizer's state (step count, moments) before it runs."""
    r = recipe()

    def two(second: str) -> FastPPO:
        algo = FastPPO(ENV, r, total=4 * r.rollout_size, env_kwargs={"T": 40}, seed=1, update="torch")
        torch.manual_seed(1)
        algo.collect()
        algo.update()
        algo.kernel = KernelUpdate.of(algo.policy, algo.optimizer) if second == "kernel" else None
        algo.collect()
        algo.update()
        algo.close()
        return algo

    ref, mixed = two("torch"), two("kernel")
    for p, q in zip(ref.policy.parameters(), mixed.policy.parameters(), strict=True):
        np.testing.assert_allclose(q.detach().numpy(), p.detach().numpy(), atol=5e-5)


def test_the_kernel_covers_tanh_mlps_only_and_says_so():
    import torch.nn as nn

    assert KernelUpdate.of(*(lambda p: (p, p.optimizer))(sb3_policy())) is not None
    relu = sb3_policy(activation=nn.ReLU)
    assert KernelUpdate.of(relu, relu.optimizer) is None
    plain = sb3_policy()
    sgd = torch.optim.SGD(plain.parameters(), lr=1e-3)
    assert KernelUpdate.of(plain, sgd) is None
    shared = sb3_policy(net_arch=[16, 16])  # (a list: SB3 builds separate pi and vf stacks of it)
    assert KernelUpdate.of(shared, shared.optimizer) is not None
    r = recipe(policy_kwargs="dict(net_arch=dict(pi=[16], vf=[16]), activation_fn=nn.ReLU)")
    with pytest.raises(ValueError, match="tanh MLPs"):
        FastPPO(ENV, r, total=r.rollout_size, env_kwargs={"T": 40}, update="kernel")
    algo = FastPPO(ENV, r, total=r.rollout_size, env_kwargs={"T": 40})  # auto: torch for this one
    assert algo.kernel is None
    algo.close()
    with pytest.raises(ValueError, match="update must be one of auto, kernel, torch"):
        FastPPO(ENV, recipe(), total=64, env_kwargs={"T": 40}, update="numba")


def test_update_settings_are_named_in_full():
    names = dict(lr=1e-3, clip=0.2, vf_coef=0.5, ent_coef=0.0, max_grad_norm=0.5, target_kl=None,
                 normalize=True, beta1=0.9, beta2=0.999, eps=1e-8)  # fmt: skip
    settings = update_settings(**names)
    assert settings.shape == (len(SETTINGS),) and np.isinf(settings[SETTINGS.index("target_kl")])
    assert settings[SETTINGS.index("beta2")] == 0.999
    with pytest.raises(ValueError, match=r"missing \['eps'\], unknown \[\]"):
        update_settings(**{k: v for k, v in names.items() if k != "eps"})
    with pytest.raises(ValueError, match=r"unknown \['gamma'\]"):
        update_settings(**names, gamma=0.99)


@pytest.mark.parametrize("parallel", [False, True])
def test_the_compiled_rollout_step_is_torchs_forward(parallel):
    """policy_step, its actor and critic passes on one thread or two: the actions mean + sigma *
    noise, their log-probabilities and the values of SB3's policy, to float rounding; a rollout
    of FastPPO with it equals one with torch's."""
    policy = sb3_policy(MULTI, {"pi": [32, 32], "vf": [16]})
    kernel = KernelUpdate.of(policy, policy.optimizer)
    kernel.parallel = parallel
    obs = minibatch(policy, m=64)[0]
    noise = np.random.default_rng(1).standard_normal((64, 5)).astype(np.float32)
    actions, logp, values = kernel.act(kernel.parameters(), obs, noise)
    x = torch.from_numpy(obs)
    with torch.no_grad():
        dist = policy.get_distribution(x)
        mean = dist.distribution.mean
        expected = mean + torch.exp(policy.log_std) * torch.from_numpy(noise)
        np.testing.assert_allclose(actions, expected.numpy(), rtol=0, atol=1e-5)
        np.testing.assert_allclose(
            logp, dist.log_prob(torch.from_numpy(actions)).numpy(), rtol=1e-5, atol=1e-4
        )
        np.testing.assert_allclose(values, policy.predict_values(x).squeeze(-1).numpy(), rtol=0, atol=1e-5)
    assert actions.dtype == logp.dtype == values.dtype == np.float32

    r = recipe()
    rollouts = []
    for update in ("torch", "kernel"):
        algo = FastPPO(ENV, r, total=r.rollout_size, env_kwargs={"T": 40}, seed=2, update=update)
        if algo.kernel is not None:
            algo.kernel.parallel = parallel
        torch.manual_seed(2)
        algo.collect()
        rollouts.append({k: v.clone() for k, v in algo._buf.items()})
        algo.close()
    for key in rollouts[0]:
        np.testing.assert_allclose(rollouts[1][key], rollouts[0][key], rtol=1e-5, atol=1e-5, err_msg=key)
