"""The PPO update of a small MLP policy as one compiled function (numba), without torch's per-op cost.

On a CPU, a gradient step of SB3's ``MlpPolicy`` on the small networks of the recipes costs torch
mostly the fixed cost of each of its ~100 ops (forward, autograd, clipping, Adam), not
arithmetic (``results/log.md``). :func:`ppo_update` does a whole PPO update (every
epoch and minibatch) in one call on a flat float32 parameter vector: the forward pass, the
hand-derived backward pass below, the gradient clipping and Adam, with the matrix products on
BLAS; :func:`policy_step` is a rollout slot's forward pass. A net is a (L, 4) int array of its
layers (the offsets of each weight and bias in the flat vector, the input and output widths;
tanh after every layer but the last). :class:`agents.fast.kernel_policy.KernelUpdate` runs these
on an SB3 policy.

The kernels address the columns of their arrays by name, as ``ios_uav_env.envs.single_kernels``
does: a module-level int per entry of :data:`LAYER` (a ``layers`` row), :data:`SETTINGS` and
:data:`STATS`, the prefix ``LAYER_``, ``SETTING_`` or ``STAT_`` and the entry upper-cased
(``layers[k, LAYER_N_OUT]``, ``settings[SETTING_CLIP]``, ``stats[STAT_APPROX_KL]``), each
``TUPLE.index("name")``: numba compiles it as a constant.

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

import numpy as np

from ios_uav_env.jit import copy_into, jit, prange

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

#: The entries of an update's ``settings`` vector, in order (:func:`update_settings` builds it):
#: the learning rate, the clip range, c_v, c_e, the max gradient norm, target_kl (inf: none),
#: whether advantages are normalised (0/1), Adam's beta1, beta2 and eps.
SETTINGS = ("lr", "clip", "vf_coef", "ent_coef", "max_grad_norm", "target_kl", "normalize", "beta1",
            "beta2", "eps")  # fmt: skip
SETTING_LR = SETTINGS.index("lr")
SETTING_CLIP = SETTINGS.index("clip")
SETTING_VF_COEF = SETTINGS.index("vf_coef")
SETTING_ENT_COEF = SETTINGS.index("ent_coef")
SETTING_MAX_GRAD_NORM = SETTINGS.index("max_grad_norm")
SETTING_TARGET_KL = SETTINGS.index("target_kl")
SETTING_NORMALIZE = SETTINGS.index("normalize")
SETTING_BETA1 = SETTINGS.index("beta1")
SETTING_BETA2 = SETTINGS.index("beta2")
SETTING_EPS = SETTINGS.index("eps")

#: The columns of a net's (L, 4) ``layers`` array, a row per layer: the offsets of its weight and
#: bias in the flat parameter vector, its input and output widths.
LAYER = ("w_off", "b_off", "n_in", "n_out")
LAYER_W_OFF = LAYER.index("w_off")
LAYER_B_OFF = LAYER.index("b_off")
LAYER_N_IN = LAYER.index("n_in")
LAYER_N_OUT = LAYER.index("n_out")

#: An update's statistics, in the order :func:`minibatch_gradient` and :func:`ppo_update` return them.
STATS = ("policy_loss", "value_loss", "approx_kl", "clip_fraction")
STAT_POLICY_LOSS = STATS.index("policy_loss")
STAT_VALUE_LOSS = STATS.index("value_loss")
STAT_APPROX_KL = STATS.index("approx_kl")
STAT_CLIP_FRACTION = STATS.index("clip_fraction")


def update_settings(**values: float) -> np.ndarray:
    """The ``settings`` vector of :func:`ppo_update` from every name of :data:`SETTINGS`
    (``target_kl=None`` for none); a ``ValueError`` names a missing or unknown entry."""
    if "target_kl" in values and values["target_kl"] is None:
        values["target_kl"] = math.inf
    missing, unknown = set(SETTINGS) - set(values), set(values) - set(SETTINGS)
    if missing or unknown:
        raise ValueError(f"update settings: missing {sorted(missing)}, unknown {sorted(unknown)}; "
                         f"the entries are {SETTINGS}")  # fmt: skip
    return np.array([float(values[name]) for name in SETTINGS])


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
        w_off, b_off = layers[k, LAYER_W_OFF], layers[k, LAYER_B_OFF]
        n_in, n_out = layers[k, LAYER_N_IN], layers[k, LAYER_N_OUT]
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
        w_off, b_off = layers[k, LAYER_W_OFF], layers[k, LAYER_B_OFF]
        n_in, n_out = layers[k, LAYER_N_IN], layers[k, LAYER_N_OUT]
        if k < n_layers - 1:  # d is the product of the layer above (a temporary): scaled in place
            y = acts[k + 1]
            for i in range(d.shape[0]):
                for j in range(n_out):
                    d[i, j] *= np.float32(1.0) - y[i, j] * y[i, j]
        copy_into(grad[w_off : w_off + n_out * n_in], np.dot(d.T, acts[k]).ravel())
        db = grad[b_off : b_off + n_out]
        db[:] = 0.0
        for i in range(d.shape[0]):  # the bias's gradient, row by row (vectorised over j)
            for j in range(n_out):
                db[j] += d[i, j]
        if k > 0:
            d = np.dot(d, theta[w_off : w_off + n_out * n_in].reshape((n_out, n_in)))


@jit(inline=True)
def _log_prob_row(actions: np.ndarray, mean: np.ndarray, inv_var: np.ndarray, const: float, i: int) -> float:
    """The diagonal Gaussian's log-density of row ``i`` of ``actions`` about ``mean`` with
    ``inv_var`` = exp(-2 log sigma) and ``const`` = sum_j log sigma_j + act_dim/2 log(2 pi):
    sum_j -1/2 (a_ij - mu_ij)^2 / sigma_j^2 - const (float64; the difference taken in float32)."""
    s = 0.0
    for j in range(inv_var.shape[0]):
        diff = float(actions[i, j] - mean[i, j])
        s += diff * diff * inv_var[j]
    return -0.5 * s - const


@jit
def _actor_gradient(
    theta: np.ndarray, grad: np.ndarray, pi_layers: np.ndarray, log_std_off: int, obs: np.ndarray,
    actions: np.ndarray, old_logp: np.ndarray, advantages: np.ndarray, settings: np.ndarray,
    stats: np.ndarray,
) -> None:  # fmt: skip
    """The policy loss's gradient (the actor's parameters and the log std) and the stats policy
    loss, approx KL and clip fraction: one pass over the rows (no float64 temporaries), then the
    backward pass."""
    clip, ent_coef = settings[SETTING_CLIP], settings[SETTING_ENT_COEF]
    normalize = settings[SETTING_NORMALIZE] > 0.5
    m, act_dim = actions.shape
    acts = _forward(theta, pi_layers, obs)
    mean = acts[-1]
    log_std = theta[log_std_off : log_std_off + act_dim].astype(np.float64)
    inv_var = np.exp(-2.0 * log_std)
    const = log_std.sum() + act_dim * 0.5 * math.log(2.0 * math.pi)
    adv_mean, adv_std = 0.0, 1.0
    if normalize and m > 1:
        for i in range(m):
            adv_mean += float(advantages[i])
        adv_mean /= m
        square = 0.0
        for i in range(m):
            square += (float(advantages[i]) - adv_mean) ** 2
        adv_std = math.sqrt(square / (m - 1)) + 1e-8
    d_mean = np.empty((m, act_dim), dtype=theta.dtype)
    g_log_std = np.zeros(act_dim)
    objective, kl, n_clipped = 0.0, 0.0, 0
    for i in range(m):
        log_ratio = _log_prob_row(actions, mean, inv_var, const, i) - old_logp[i]
        ratio = math.exp(log_ratio)
        adv = (float(advantages[i]) - adv_mean) / adv_std
        surrogate = adv * ratio
        clipped_surrogate = adv * min(max(ratio, 1.0 - clip), 1.0 + clip)
        objective += min(surrogate, clipped_surrogate)
        kl += ratio - 1.0 - log_ratio
        n_clipped += abs(ratio - 1.0) > clip
        # the unclipped term is the minimum (inside the clip range the two are equal)
        d_logp = -surrogate / m if surrogate <= clipped_surrogate else 0.0
        for j in range(act_dim):
            diff = float(actions[i, j] - mean[i, j])
            d_mean[i, j] = d_logp * diff * inv_var[j]
            g_log_std[j] += d_logp * (diff * diff * inv_var[j] - 1.0)
    _backward(theta, grad, pi_layers, acts, d_mean)
    for j in range(act_dim):
        grad[log_std_off + j] = g_log_std[j] - ent_coef
    stats[STAT_POLICY_LOSS] = -objective / m
    stats[STAT_APPROX_KL] = kl / m
    stats[STAT_CLIP_FRACTION] = n_clipped / m


@jit
def _critic_gradient(
    theta: np.ndarray, grad: np.ndarray, vf_layers: np.ndarray, obs: np.ndarray, returns: np.ndarray,
    settings: np.ndarray, stats: np.ndarray,
) -> None:  # fmt: skip
    """The value loss's gradient (the critic's parameters) and the stat value loss."""
    m = obs.shape[0]
    acts = _forward(theta, vf_layers, obs)
    value = acts[-1]
    d_value = np.empty((m, 1), dtype=theta.dtype)
    scale = -2.0 * settings[SETTING_VF_COEF] / m
    square = 0.0
    for i in range(m):
        err = returns[i] - float(value[i, 0])
        square += err * err
        d_value[i, 0] = scale * err
    _backward(theta, grad, vf_layers, acts, d_value)
    stats[STAT_VALUE_LOSS] = square / m


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
    std's too, whether trained or not); returns the :data:`STATS` (policy loss, value loss,
    approx KL, clip fraction). ``settings``: as :func:`ppo_update`'s; ``parallel``: the actor's
    and the critic's parts on two of numba's threads."""
    stats = np.empty(len(STATS))
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
    lr, max_norm = settings[SETTING_LR], settings[SETTING_MAX_GRAD_NORM]
    beta1, beta2, eps = settings[SETTING_BETA1], settings[SETTING_BETA2], settings[SETTING_EPS]
    norm = 0.0
    for j in range(n_train):
        norm += float(grad[j]) * float(grad[j])
    # the step in float32, as torch's Adam takes it on float32 parameters
    f32 = np.float32
    scale = f32(min(1.0, max_norm / (math.sqrt(norm) + 1e-6)))
    step_size = f32(lr / (1.0 - beta1**step))
    root_bias2 = f32(math.sqrt(1.0 - beta2**step))
    decay1, decay2, mix2, eps32 = f32(1.0 - beta1), f32(beta2), f32(1.0 - beta2), f32(eps)
    for j in range(n_train):
        g = grad[j] * scale
        exp_avg[j] += (g - exp_avg[j]) * decay1
        exp_avg_sq[j] = exp_avg_sq[j] * decay2 + mix2 * g * g
        theta[j] -= step_size * exp_avg[j] / (math.sqrt(exp_avg_sq[j]) / root_bias2 + eps32)


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
    ``orders``: (epochs, n) the sample order of each epoch; ``settings``: the entries of
    :data:`SETTINGS` (:func:`update_settings`). Returns (Adam's step count, the minibatches
    stepped, the sums of (policy loss, value loss, approx KL, clip fraction) over them); like SB3,
    an update stops before the step of the first minibatch whose KL exceeds 1.5 target_kl."""
    grad = np.zeros_like(theta)
    totals = np.zeros(len(STATS))
    count = 0
    n = orders.shape[1]
    for epoch in range(orders.shape[0]):
        for start in range(0, n, batch_size):
            idx = orders[epoch, start : start + batch_size]
            stats = minibatch_gradient(
                theta, grad, pi_layers, vf_layers, log_std_off, obs[idx], actions[idx], old_logp[idx],
                advantages[idx], returns[idx], settings, parallel,
            )  # fmt: skip
            if stats[STAT_APPROX_KL] > 1.5 * settings[SETTING_TARGET_KL]:
                return step, count, totals
            step += 1
            adam_step(theta, grad, exp_avg, exp_avg_sq, step, n_train, settings)
            totals += stats
            count += 1
    return step, count, totals


@jit(parallel=True)
def _forward_parallel(
    theta: np.ndarray, pi_layers: np.ndarray, vf_layers: np.ndarray, obs: np.ndarray, mean: np.ndarray,
    value: np.ndarray,
) -> None:  # fmt: skip
    for branch in prange(2):  # the actor's and the critic's passes, one thread each
        if branch == 0:  # (copy_into, row by row: no slice assignment in a kernel)
            out = _forward(theta, pi_layers, obs)[-1]
            for i in range(out.shape[0]):
                copy_into(mean[i], out[i])
        else:
            copy_into(value, _forward(theta, vf_layers, obs)[-1][:, 0])


@jit
def policy_step(
    theta: np.ndarray, pi_layers: np.ndarray, vf_layers: np.ndarray, log_std_off: int, obs: np.ndarray,
    noise: np.ndarray, parallel: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """A rollout slot's (actions, log-probabilities, values) for the rows' observations ``obs``:
    actions = mean + sigma * ``noise`` (standard normal draws, one per row and action entry),
    their log-probability as :func:`minibatch_gradient` computes it (so that an update's first
    ratios are 1 to float rounding). ``parallel``: the actor's and the critic's passes on two
    of numba's threads."""
    m, act_dim = noise.shape
    if parallel:
        mean = np.empty((m, act_dim), dtype=theta.dtype)
        value = np.empty(m, dtype=theta.dtype)
        _forward_parallel(theta, pi_layers, vf_layers, obs, mean, value)
    else:
        mean = _forward(theta, pi_layers, obs)[-1]
        value = _forward(theta, vf_layers, obs)[-1][:, 0].copy()
    log_std = theta[log_std_off : log_std_off + act_dim]
    actions = mean + np.exp(log_std) * noise
    log_std64 = log_std.astype(np.float64)
    inv_var = np.exp(-2.0 * log_std64)
    const = log_std64.sum() + act_dim * 0.5 * math.log(2.0 * math.pi)
    logp = np.empty(m, dtype=np.float32)
    for i in range(m):
        logp[i] = _log_prob_row(actions, mean, inv_var, const, i)
    return actions, logp, value
