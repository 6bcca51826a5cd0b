"""Fast deterministic inference: an SB3 MLP policy as a few numpy matrix products.

``model.predict`` pays a per-call overhead (tensor conversion, distribution objects) that
outweighs a small MLP's arithmetic, and a plan is a whole episode of calls, so the
deterministic actor is exported to numpy once: the VecNormalize observation transform (if
any), the actor MLP (or a module's own numpy forward, its ``to_numpy()``: the node-set actor
of ``agents.node_set``), and the action's post-processing (PPO: the Gaussian mean clipped to
the action space; SAC: the tanh-squashed mean). :meth:`NumpyPolicy.act` equals
``Agent.act(obs, True)`` to float precision (tested).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

_ACTIVATIONS: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "Tanh": np.tanh,
    "ReLU": lambda x: np.maximum(x, 0.0),
    "Identity": lambda x: x,
}


def _layers(module: Any) -> list[tuple[str, Any]]:
    """Flatten a torch Sequential (or a single layer) into (kind, params) steps."""
    import torch.nn as nn

    steps: list[tuple[str, Any]] = []
    mods = list(module) if isinstance(module, nn.Sequential) else [module]
    for m in mods:
        name = type(m).__name__
        if isinstance(m, nn.Linear):
            w = m.weight.detach().cpu().numpy().astype(np.float64)
            b = m.bias.detach().cpu().numpy().astype(np.float64)
            steps.append(("linear", (w.T.copy(), b)))
        elif hasattr(m, "to_numpy"):  # a module with its own numpy forward (agents.node_set)
            steps.append(("fn", m.to_numpy()))
        elif name in _ACTIVATIONS:
            steps.append(("act", _ACTIVATIONS[name]))
        elif isinstance(m, nn.Sequential):
            steps += _layers(m)
        else:
            raise ValueError(f"cannot export layer {name} to numpy (MLP layers, or a module with to_numpy())")
    return steps


@dataclass
class NumpyPolicy:
    """The deterministic actor of an SB3 PPO/SAC policy (an MlpPolicy, or ``agents.node_set``'s), in numpy."""

    steps: list[tuple[str, Any]]
    squash: bool  # SAC: tanh of the mean, then rescaled to the action space
    low: np.ndarray
    high: np.ndarray
    obs_mean: np.ndarray | None = None  # VecNormalize statistics
    obs_std: np.ndarray | None = None
    obs_clip: float = np.inf
    repeat: int = 1  # slots each action is held (an agent trained with agents.wrappers.ActionRepeat)
    batched = True  # act takes a (B, obs_dim) batch too (ios_uav_env.envs.rollout.batch_policy)
    observation_space: Any = None  # the model's (a Gymnasium space): what it was trained on
    history: Any = None  # agents.tricks.History: a memory model's last observations (act feeds it)

    @classmethod
    def from_sb3(cls, model: Any, vecnormalize: Any = None, repeat: int = 1) -> NumpyPolicy:
        """Export ``model`` (PPO or SAC with an MLP policy, or PPO with ``agents.node_set``'s) and its
        VecNormalize statistics;
        ``repeat``: the agent's (``agents.loading.Agent.repeat``)."""
        policy = model.policy
        space = model.action_space
        if hasattr(policy, "actor") and hasattr(policy.actor, "mu"):  # SAC
            actor = policy.actor
            steps = _layers(actor.latent_pi) + _layers(actor.mu)
            squash = True
        elif hasattr(policy, "mlp_extractor") and hasattr(policy, "action_net"):  # PPO / A2C
            steps = _layers(policy.mlp_extractor.policy_net) + _layers(policy.action_net)
            squash = False
        else:
            raise ValueError(
                f"unsupported policy {type(policy).__name__}: MlpPolicy (PPO, SAC) or NodeSetPolicy expected"
            )
        mean = std = None
        clip = np.inf
        if vecnormalize is not None and getattr(vecnormalize, "norm_obs", False):
            rms = vecnormalize.obs_rms
            mean = np.asarray(rms.mean, dtype=np.float64)
            std = np.sqrt(np.asarray(rms.var, dtype=np.float64) + vecnormalize.epsilon)
            clip = float(vecnormalize.clip_obs)
        low = np.asarray(space.low, dtype=np.float64)
        high = np.asarray(space.high, dtype=np.float64)
        return cls(steps, squash, low, high, mean, std, clip, repeat, model.observation_space)

    def act(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
        """The deterministic action for one observation (``deterministic`` must be True)."""
        if not deterministic:
            raise ValueError("NumpyPolicy is deterministic only; use the SB3 model to sample actions")
        x = np.asarray(obs, dtype=np.float64)
        if self.history is not None:  # the env's own observation joins the memory the model reads
            x = self.history(x)
        if self.obs_mean is not None:
            x = np.clip((x - self.obs_mean) / self.obs_std, -self.obs_clip, self.obs_clip)
        for kind, p in self.steps:
            x = x @ p[0] + p[1] if kind == "linear" else p(x)
        if self.squash:
            return (self.low + 0.5 * (np.tanh(x) + 1.0) * (self.high - self.low)).astype(np.float32)
        return np.clip(x, self.low, self.high).astype(np.float32)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The deterministic action (:meth:`act`): a policy for ``ios_uav_env.benchmark``."""
        return self.act(obs)
