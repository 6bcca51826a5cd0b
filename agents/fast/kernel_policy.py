"""The compiled PPO update (:mod:`agents.fast.kernel`) on an SB3 ``ActorCriticPolicy`` and its Adam.

:class:`KernelUpdate` lays the policy's actor and critic out as flat float32 vectors, copies the
parameters and Adam's state in before each update and back after it, so the torch policy stays
the model (rollouts, checkpoints, export) and a run can switch between the compiled update and
torch's at any point. The BLAS products run on one thread (:meth:`KernelUpdate.one_blas_thread`).
"""

from __future__ import annotations

from contextlib import nullcontext
from typing import Any

import numpy as np

from agents.fast.kernel import LAYER, policy_step, ppo_update, update_settings
from ios_uav_env.jit import parallel_safe


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
        self.params: list[Any] = []  # (parameter, offset) in the flat vector's order
        rows: dict[str, list[list[int]]] = {"pi": [], "vf": []}
        offset = 0
        for name, stack in (("pi", pi), ("vf", vf)):
            for linear in stack:
                w, b = linear.weight, linear.bias
                layer = dict(w_off=offset, b_off=offset + w.numel(), n_in=w.shape[1], n_out=w.shape[0])
                rows[name].append([layer[column] for column in LAYER])
                self.params += [(w, offset), (b, offset + w.numel())]
                offset += w.numel() + b.numel()
        self.log_std_off = offset
        self.params.append((policy.log_std, offset))
        self.size = offset + policy.log_std.numel()
        self.n_train = self.size if policy.log_std.requires_grad else offset  # a scheduled log std: frozen
        self.pi_layers = np.asarray(rows["pi"], dtype=np.int64)
        self.vf_layers = np.asarray(rows["vf"], dtype=np.int64)
        self._blas = _blas_controller()
        #: the actor's and the critic's gradients, and their rollout passes, on two of numba's threads
        #: (where they may run)
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
        parallel = self.parallel and parallel_safe()
        return policy_step(theta, self.pi_layers, self.vf_layers, self.log_std_off, obs, noise, parallel)  # type: ignore[no-any-return]

    def _gather(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """The parameters (:meth:`parameters`) and Adam's moments and step count, flat."""
        theta = self.parameters()
        exp_avg, exp_avg_sq = np.zeros_like(theta), np.zeros_like(theta)
        step = 0
        for p, off in self.params:
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
        settings = update_settings(
            lr=group["lr"], clip=clip, vf_coef=vf_coef, ent_coef=ent_coef, max_grad_norm=max_grad_norm,
            target_kl=target_kl, normalize=normalize_advantage, beta1=beta1, beta2=beta2, eps=group["eps"],
        )  # fmt: skip
        theta, exp_avg, exp_avg_sq, step = self._gather()
        orders = np.ascontiguousarray(orders, dtype=np.int64)  # (torch.randperm's: no copy)
        with self.one_blas_thread():
            step, count, stats = ppo_update(
                theta, exp_avg, exp_avg_sq, step, self.n_train, self.pi_layers, self.vf_layers,
                self.log_std_off, obs, actions, old_logp, advantages, returns, orders, int(batch_size),
                settings, self.parallel and parallel_safe(),
            )  # fmt: skip
        self._scatter(theta, exp_avg, exp_avg_sq, step)
        return count, stats
