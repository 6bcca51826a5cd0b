"""The PPO update of a small MLP policy as one compiled function (numba), without torch's per-op cost.

On a CPU, a gradient step of SB3's ``MlpPolicy`` on the small networks of the recipes costs torch
mostly the fixed cost of each of its ~100 ops (forward, autograd, clipping, Adam), not
arithmetic (``results/log.md``). :func:`ppo_update` does a whole PPO update (every
epoch and minibatch) in one call on a flat float32 parameter vector: the forward pass, the
hand-derived backward pass below, the gradient clipping and Adam, with the matrix products on
BLAS. :class:`KernelUpdate` copies the policy's parameters and Adam state into the flat vectors
before the call and back after it, so the torch policy stays the model (rollouts, checkpoints,
export) and a run can switch between the two updates at any point.

The loss is :meth:`agents.fast.ppo.FastPPO.update`'s (SB3's PPO): for a minibatch of n samples
with ratio rho = exp(log pi(a|s) - log pi_old(a|s)), normalised advantages A, values v and
returns R,

    L = -1/n sum_i min(A_i rho_i, A_i clip(rho_i, 1 - eps, 1 + eps))
        + c_v / n sum_i (R_i - v_i)^2 - c_e sum_j (log sigma_j + 1/2 log(2 pi e)).

Its gradient, per sample i (the clipped term has none outside the clip range, and the two
terms agree inside it):

    dL/d log pi_i = -A_i rho_i / n   if A_i rho_i <= A_i clip(rho_i) (always so inside the range),
                    0                otherwise;
    dL/d mu_ij    = dL/d log pi_i (a_ij - mu_ij) / sigma_j^2;
    dL/d log sigma_j = sum_i dL/d log pi_i ((a_ij - mu_ij)^2 / sigma_j^2 - 1) - c_e;
    dL/d v_i      = -2 c_v (R_i - v_i) / n;

and back through each layer y = tanh(x W^T + b): dz = dy (1 - y^2), dW = dz^T x, db = sum dz,
dx = dz W. The gradient is clipped to a global norm as ``torch.nn.utils.clip_grad_norm_`` does
(scaled by min(1, max_norm / (norm + 1e-6))) and Adam steps as ``torch.optim.Adam`` does.
"""

from __future__ import annotations

import math
from contextlib import nullcontext
from typing import Any

import numpy as np

from ios_uav_env.jit import jit, parallel_safe, prange

#: Columns of a layer row of a net's layout: the offsets of its weight and bias in the flat
#: vector, its input and output widths.
W_OFF, B_OFF, N_IN, N_OUT = 0, 1, 2, 3


#: Eigen's float tanh (``generic_fast_tanh_float``, the one PyTorch's CPU kernels use): a 13/6
#: rational approximation on [-c, c], within 3e-7 of tanh; numba's ``np.tanh`` calls the scalar
#: libm function, which does not vectorise.
_TANH_CLAMP = np.float32(7.90531110763549805)
_A1, _A3, _A5 = (
    np.float32(4.89352455891786e-03),
    np.float32(6.37261928875436e-04),
    np.float32(1.48572235717979e-05),
)
_A7, _A9 = np.float32(5.12229709037114e-08), np.float32(-8.60467152213735e-11)
_A11, _A13 = np.float32(2.00018790482477e-13), np.float32(-2.76076847742355e-16)
_B0, _B2 = np.float32(4.89352518554385e-03), np.float32(2.26843463243900e-03)
_B4, _B6 = np.float32(1.18534705686654e-04), np.float32(1.19825839466702e-06)


@jit(inline=True)
def _tanh(x: float) -> float:
    v = min(max(x, -_TANH_CLAMP), _TANH_CLAMP)
    v2 = v * v
    p = ((((((_A13 * v2 + _A11) * v2 + _A9) * v2 + _A7) * v2 + _A5) * v2 + _A3) * v2 + _A1) * v
    q = ((_B6 * v2 + _B4) * v2 + _B2) * v2 + _B0
    return p / q


@jit
def _forward(theta: np.ndarray, layers: np.ndarray, x: np.ndarray) -> list[np.ndarray]:
    """The activations of a net (``layers``: a (L, 4) layout; tanh after every layer but the
    last) on ``x``: the input, then each layer's output."""
    acts = [x]
    h = x
    n_layers = layers.shape[0]
    for k in range(n_layers):
        w_off, b_off, n_in, n_out = layers[k, 0], layers[k, 1], layers[k, 2], layers[k, 3]
        w = theta[w_off : w_off + n_out * n_in].reshape((n_out, n_in))
        b = theta[b_off : b_off + n_out]
        h = np.dot(h, w.T)
        if k < n_layers - 1:
            for i in range(h.shape[0]):
                for j in range(n_out):
                    h[i, j] = _tanh(h[i, j] + b[j])
        else:
            for i in range(h.shape[0]):
                for j in range(n_out):
                    h[i, j] += b[j]
        acts.append(h)
    return acts


@jit
def _backward(
    theta: np.ndarray, grad: np.ndarray, layers: np.ndarray, acts: list[np.ndarray], d_out: np.ndarray
) -> None:
    """Write the gradient of the net's parameters into ``grad`` given dL/d(output) ``d_out``."""
    d = d_out
    n_layers = layers.shape[0]
    for k in range(n_layers - 1, -1, -1):
        w_off, b_off, n_in, n_out = layers[k, 0], layers[k, 1], layers[k, 2], layers[k, 3]
        if k < n_layers - 1:
            y = acts[k + 1]
            d = d.copy()
            for i in range(d.shape[0]):
                for j in range(n_out):
                    d[i, j] *= np.float32(1.0) - y[i, j] * y[i, j]
        grad[w_off : w_off + n_out * n_in] = np.dot(d.T, acts[k]).ravel()
        grad[b_off : b_off + n_out] = d.sum(axis=0)
        if k > 0:
            d = np.dot(d, theta[w_off : w_off + n_out * n_in].reshape((n_out, n_in)))


@jit
def _actor_gradient(
    theta: np.ndarray, grad: np.ndarray, pi_layers: np.ndarray, log_std_off: int, obs: np.ndarray,
    actions: np.ndarray, old_logp: np.ndarray, advantages: np.ndarray, settings: np.ndarray,
    stats: np.ndarray,
) -> None:  # fmt: skip
    """The policy loss's gradient (the actor's parameters and the log std) and stats 0, 2, 3."""
    clip, ent_coef, normalize = settings[1], settings[3], settings[6] > 0.5
    m, act_dim = actions.shape
    acts = _forward(theta, pi_layers, obs)
    log_std = theta[log_std_off : log_std_off + act_dim].astype(np.float64)
    inv_var = np.exp(-2.0 * log_std)
    diff = (actions - acts[-1]).astype(np.float64)
    scaled = diff * diff * inv_var
    logp = -0.5 * scaled.sum(axis=1) - (log_std.sum() + act_dim * 0.5 * math.log(2.0 * math.pi))
    log_ratio = logp - old_logp
    ratio = np.exp(log_ratio)
    adv = advantages.astype(np.float64)
    if normalize and m > 1:
        centred = adv - adv.mean()
        adv = centred / (np.sqrt((centred * centred).sum() / (m - 1)) + 1e-8)
    clipped = np.minimum(np.maximum(ratio, 1.0 - clip), 1.0 + clip)
    surrogate, clipped_surrogate = adv * ratio, adv * clipped
    # the unclipped term is the minimum (inside the clip range the two are equal)
    live = surrogate <= clipped_surrogate
    d_logp = np.where(live, -surrogate / m, 0.0).reshape((m, 1))
    _backward(theta, grad, pi_layers, acts, ((d_logp * diff) * inv_var).astype(theta.dtype))
    g_log_std = (d_logp * (scaled - 1.0)).sum(axis=0) - ent_coef
    grad[log_std_off : log_std_off + act_dim] = g_log_std.astype(theta.dtype)
    stats[0] = -np.mean(np.minimum(surrogate, clipped_surrogate))
    stats[2] = np.mean(ratio - 1.0 - log_ratio)
    stats[3] = np.mean(np.abs(ratio - 1.0) > clip)


@jit
def _critic_gradient(
    theta: np.ndarray, grad: np.ndarray, vf_layers: np.ndarray, obs: np.ndarray, returns: np.ndarray,
    settings: np.ndarray, stats: np.ndarray,
) -> None:  # fmt: skip
    """The value loss's gradient (the critic's parameters) and stat 1."""
    m = obs.shape[0]
    acts = _forward(theta, vf_layers, obs)
    err = returns - acts[-1][:, 0].astype(np.float64)
    d_value = ((-2.0 * settings[2] / m) * err).astype(theta.dtype).reshape((m, 1))
    _backward(theta, grad, vf_layers, acts, d_value)
    stats[1] = np.mean(err * err)


@jit(parallel=True)
def _gradient_parallel(
    theta: np.ndarray, grad: np.ndarray, pi_layers: np.ndarray, vf_layers: np.ndarray, log_std_off: int,
    obs: np.ndarray, actions: np.ndarray, old_logp: np.ndarray, advantages: np.ndarray, returns: np.ndarray,
    settings: np.ndarray, stats: np.ndarray,
) -> None:  # fmt: skip
    for branch in prange(2):  # the actor and the critic share nothing: one thread each
        if branch == 0:
            _actor_gradient(theta, grad, pi_layers, log_std_off, obs, actions, old_logp, advantages, settings,
                            stats)  # fmt: skip
        else:
            _critic_gradient(theta, grad, vf_layers, obs, returns, settings, stats)


@jit
def minibatch_gradient(
    theta: np.ndarray,
    grad: np.ndarray,
    pi_layers: np.ndarray,
    vf_layers: np.ndarray,
    log_std_off: int,
    obs: np.ndarray,
    actions: np.ndarray,
    old_logp: np.ndarray,
    advantages: np.ndarray,
    returns: np.ndarray,
    settings: np.ndarray,
    parallel: bool = False,
) -> np.ndarray:
    """The PPO loss's gradient on one minibatch, written into ``grad`` (every entry: the log
    std's too, whether trained or not); returns (policy loss, value loss, approx KL, clip
    fraction). ``settings``: as :func:`ppo_update`'s; ``parallel``: the actor's and the critic's
    parts on two of numba's threads."""
    stats = np.empty(4)
    if parallel:
        _gradient_parallel(theta, grad, pi_layers, vf_layers, log_std_off, obs, actions, old_logp, advantages,
                           returns, settings, stats)  # fmt: skip
    else:
        _actor_gradient(
            theta, grad, pi_layers, log_std_off, obs, actions, old_logp, advantages, settings, stats
        )
        _critic_gradient(theta, grad, vf_layers, obs, returns, settings, stats)
    return stats


@jit
def adam_step(
    theta: np.ndarray, grad: np.ndarray, exp_avg: np.ndarray, exp_avg_sq: np.ndarray, step: int,
    n_train: int, settings: np.ndarray,
) -> None:  # fmt: skip
    """Clip the gradient of the first ``n_train`` parameters to ``settings``' max norm
    (``clip_grad_norm_``) and take Adam's step ``step`` (1 for the first) on them."""
    lr, max_norm, beta1, beta2, eps = settings[0], settings[4], settings[7], settings[8], settings[9]
    norm = 0.0
    for j in range(n_train):
        norm += float(grad[j]) * float(grad[j])
    scale = min(1.0, max_norm / (math.sqrt(norm) + 1e-6))
    step_size = lr / (1.0 - beta1**step)
    root_bias2 = math.sqrt(1.0 - beta2**step)
    for j in range(n_train):
        g = grad[j] * scale
        exp_avg[j] += (g - exp_avg[j]) * (1.0 - beta1)
        exp_avg_sq[j] = exp_avg_sq[j] * beta2 + (1.0 - beta2) * g * g
        theta[j] -= step_size * exp_avg[j] / (math.sqrt(exp_avg_sq[j]) / root_bias2 + eps)


@jit
def ppo_update(
    theta: np.ndarray,
    exp_avg: np.ndarray,
    exp_avg_sq: np.ndarray,
    step: int,
    n_train: int,
    pi_layers: np.ndarray,
    vf_layers: np.ndarray,
    log_std_off: int,
    obs: np.ndarray,
    actions: np.ndarray,
    old_logp: np.ndarray,
    advantages: np.ndarray,
    returns: np.ndarray,
    orders: np.ndarray,
    batch_size: int,
    settings: np.ndarray,
    parallel: bool = False,
) -> tuple[int, int, np.ndarray]:
    """Every epoch of a PPO update, in place on ``theta`` and Adam's ``exp_avg``, ``exp_avg_sq``.

    ``theta``: the flat parameters (float32), the trained ones first (``n_train``: the log std is
    last and trained only if ``n_train`` covers it); ``step``: Adam's step count so far;
    ``pi_layers``, ``vf_layers``: the actor's and critic's layouts, heads included;
    ``orders``: (epochs, n) the sample order of each epoch; ``settings``: (lr, clip range,
    vf_coef, ent_coef, max_grad_norm, target_kl or inf, normalise advantages (0/1), beta1,
    beta2, Adam eps). Returns (Adam's step count, the minibatches stepped, the sums of
    (policy loss, value loss, approx KL, clip fraction) over them); like SB3, an update stops
    before the step of the first minibatch whose KL exceeds 1.5 target_kl."""
    grad = np.zeros_like(theta)
    totals = np.zeros(4)
    count = 0
    n = orders.shape[1]
    for epoch in range(orders.shape[0]):
        for start in range(0, n, batch_size):
            idx = orders[epoch, start : start + batch_size]
            stats = minibatch_gradient(
                theta, grad, pi_layers, vf_layers, log_std_off, obs[idx], actions[idx], old_logp[idx],
                advantages[idx], returns[idx], settings, parallel,
            )  # fmt: skip
            if stats[2] > 1.5 * settings[5]:
                return step, count, totals
            step += 1
            adam_step(theta, grad, exp_avg, exp_avg_sq, step, n_train, settings)
            totals += stats
            count += 1
    return step, count, totals


@jit
def policy_step(
    theta: np.ndarray, pi_layers: np.ndarray, vf_layers: np.ndarray, log_std_off: int, obs: np.ndarray,
    noise: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """A rollout slot's (actions, log-probabilities, values) for the rows' observations ``obs``:
    actions = mean + sigma * ``noise`` (standard normal draws, one per row and action entry),
    their log-probability as :func:`minibatch_gradient` computes it (so that an update's first
    ratios are 1 to float rounding)."""
    act_dim = noise.shape[1]
    mean = _forward(theta, pi_layers, obs)[-1]
    value = _forward(theta, vf_layers, obs)[-1][:, 0].copy()
    log_std = theta[log_std_off : log_std_off + act_dim]
    actions = mean + np.exp(log_std) * noise
    log_std64 = log_std.astype(np.float64)
    diff = (actions - mean).astype(np.float64)
    logp = -0.5 * (diff * diff * np.exp(-2.0 * log_std64)).sum(axis=1) - (
        log_std64.sum() + act_dim * 0.5 * math.log(2.0 * math.pi)
    )
    return actions, logp.astype(np.float32), value


def _blas_controller() -> Any:
    """threadpoolctl's controller of the BLAS libraries loaded (numba's matrix products call
    scipy's), or None without threadpoolctl. The kernel runs its products on one thread: an
    OpenBLAS pool left spinning between them takes the core the env and torch need."""
    try:
        import scipy.linalg.cython_blas  # noqa: F401  (the BLAS numba calls: loaded before the scan)
        from threadpoolctl import ThreadpoolController
    except ImportError:
        return None
    return ThreadpoolController()


def _linear_stack(modules: Any) -> list[Any] | None:
    """The Linear layers of a ``Sequential`` of (Linear, Tanh) pairs, or None if it is anything else."""
    import torch

    layers = list(modules)
    if len(layers) % 2:
        return None
    linears = layers[0::2]
    if not all(type(m) is torch.nn.Linear for m in linears):
        return None
    if not all(type(m) is torch.nn.Tanh for m in layers[1::2]):
        return None
    return linears


class KernelUpdate:
    """:func:`ppo_update` on an SB3 ``ActorCriticPolicy`` and its Adam optimizer.

    :meth:`of` returns None for a policy the kernel does not cover (anything but separate
    (Linear, Tanh) actor and critic stacks with linear heads, a state-independent Gaussian, a
    flattening features extractor and plain Adam); the caller then updates with torch."""

    def __init__(self, policy: Any, optimizer: Any, pi: list[Any], vf: list[Any]) -> None:
        self.policy, self.optimizer = policy, optimizer
        self._train_log_std = bool(policy.log_std.requires_grad)
        self.params: list[Any] = []  # (parameter, offset) in the flat vector's order
        rows: dict[str, list[list[int]]] = {"pi": [], "vf": []}
        offset = 0
        for name, stack in (("pi", pi), ("vf", vf)):
            for linear in stack:
                w, b = linear.weight, linear.bias
                rows[name].append([offset, offset + w.numel(), w.shape[1], w.shape[0]])
                self.params += [(w, offset), (b, offset + w.numel())]
                offset += w.numel() + b.numel()
        self.log_std_off = offset
        self.params.append((policy.log_std, offset))
        self.size = offset + policy.log_std.numel()
        self.n_train = self.size if self._train_log_std else offset
        self.pi_layers = np.asarray(rows["pi"], dtype=np.int64)
        self.vf_layers = np.asarray(rows["vf"], dtype=np.int64)
        self._blas = _blas_controller()
        #: the actor's and the critic's gradients on two of numba's threads (where they may run)
        self.parallel = True

    @classmethod
    def of(cls, policy: Any, optimizer: Any) -> KernelUpdate | None:
        """The kernel's update of ``policy`` (an SB3 ``ActorCriticPolicy``), or None if it does not apply."""
        import torch
        from stable_baselines3.common.distributions import DiagGaussianDistribution
        from stable_baselines3.common.torch_layers import FlattenExtractor

        if type(optimizer) is not torch.optim.Adam or len(optimizer.param_groups) != 1:
            return None
        group = optimizer.param_groups[0]
        if group["weight_decay"] or group["amsgrad"] or group["maximize"]:
            return None
        if not isinstance(getattr(policy, "action_dist", None), DiagGaussianDistribution):
            return None
        if type(policy.features_extractor) is not FlattenExtractor or getattr(policy, "use_sde", False):
            return None
        extractor = policy.mlp_extractor
        if len(getattr(extractor, "shared_net", ())) != 0:
            return None
        pi, vf = _linear_stack(extractor.policy_net), _linear_stack(extractor.value_net)
        if pi is None or vf is None:
            return None
        if type(policy.action_net) is not torch.nn.Linear or type(policy.value_net) is not torch.nn.Linear:
            return None
        every = {id(p) for p in policy.parameters()}
        covered = pi + [policy.action_net] + vf + [policy.value_net]
        mine = {id(p) for m in covered for p in m.parameters()} | {id(policy.log_std)}
        if every != mine or any(p.dtype != torch.float32 for p in policy.parameters()):
            return None
        return cls(policy, optimizer, pi + [policy.action_net], vf + [policy.value_net])

    def parameters(self) -> np.ndarray:
        """The policy's parameters now, as the flat vector the kernels read."""
        theta = np.empty(self.size, dtype=np.float32)
        for p, off in self.params:
            theta[off : off + p.numel()] = p.detach().numpy().ravel()
        return theta

    def one_blas_thread(self) -> Any:
        """A context in which the BLAS libraries run on one thread (see :func:`_blas_controller`)."""
        return self._blas.limit(limits=1, user_api="blas") if self._blas is not None else nullcontext()

    def act(self, theta: np.ndarray, obs: np.ndarray, noise: np.ndarray) -> tuple[np.ndarray, ...]:
        """:func:`policy_step` of the parameters ``theta`` (:meth:`parameters`) on float32 arrays
        (call it under :meth:`one_blas_thread`)."""
        return policy_step(theta, self.pi_layers, self.vf_layers, self.log_std_off, obs, noise)  # type: ignore[no-any-return]

    def _gather(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        theta = np.empty(self.size, dtype=np.float32)
        exp_avg, exp_avg_sq = np.zeros_like(theta), np.zeros_like(theta)
        step = 0
        for p, off in self.params:
            theta[off : off + p.numel()] = p.detach().numpy().ravel()
            state = self.optimizer.state.get(p)
            if state:
                exp_avg[off : off + p.numel()] = state["exp_avg"].numpy().ravel()
                exp_avg_sq[off : off + p.numel()] = state["exp_avg_sq"].numpy().ravel()
                step = int(state["step"])
        return theta, exp_avg, exp_avg_sq, step

    def _scatter(self, theta: np.ndarray, exp_avg: np.ndarray, exp_avg_sq: np.ndarray, step: int) -> None:
        import torch

        fused = bool(self.optimizer.param_groups[0].get("fused"))
        with torch.no_grad():
            for p, off in self.params:
                size = p.numel()
                p.copy_(torch.from_numpy(theta[off : off + size].reshape(p.shape)))
                if not p.requires_grad:
                    continue
                state = self.optimizer.state[p]
                if not state:  # what torch.optim.Adam creates on its first step
                    state["step"] = torch.zeros((), dtype=torch.float32) if fused else torch.tensor(0.0)
                    state["exp_avg"] = torch.zeros_like(p, memory_format=torch.preserve_format)
                    state["exp_avg_sq"] = torch.zeros_like(p, memory_format=torch.preserve_format)
                state["step"].fill_(float(step))
                state["exp_avg"].copy_(torch.from_numpy(exp_avg[off : off + size].reshape(p.shape)))
                state["exp_avg_sq"].copy_(torch.from_numpy(exp_avg_sq[off : off + size].reshape(p.shape)))

    def __call__(
        self,
        obs: np.ndarray,
        actions: np.ndarray,
        old_logp: np.ndarray,
        advantages: np.ndarray,
        returns: np.ndarray,
        orders: np.ndarray,
        batch_size: int,
        *,
        clip: float,
        vf_coef: float,
        ent_coef: float,
        max_grad_norm: float,
        target_kl: float | None,
        normalize_advantage: bool,
    ) -> tuple[int, np.ndarray]:
        """One PPO update on the rollout's float32 arrays; (minibatches stepped, the sums of
        (policy loss, value loss, approx KL, clip fraction) over them). The policy's parameters
        and Adam state are read before and written after."""
        group = self.optimizer.param_groups[0]
        beta1, beta2 = group["betas"]
        kl = math.inf if target_kl is None else target_kl
        settings = np.array(
            [group["lr"], clip, vf_coef, ent_coef, max_grad_norm, kl, float(normalize_advantage), beta1,
             beta2, group["eps"]],
        )  # fmt: skip
        theta, exp_avg, exp_avg_sq, step = self._gather()
        with self.one_blas_thread():
            step, count, stats = ppo_update(
                theta, exp_avg, exp_avg_sq, step, self.n_train, self.pi_layers, self.vf_layers,
                self.log_std_off, obs, actions, old_logp, advantages, returns, orders.astype(np.int64),
                int(batch_size), settings, self.parallel and parallel_safe(),
            )  # fmt: skip
        self._scatter(theta, exp_avg, exp_avg_sq, step)
        return count, stats
