"""Generalised advantage estimation on a rollout's arrays (Schulman et al., 2016).

For slot t of row b, with d_t = 1 if the episode ended at step t (the observation after it is
the next episode's first) and V_{t+1} the value of the observation after step t (the next
rollout's first for t = T - 1):

    delta_t = r_t + gamma (1 - d_t) V_{t+1} - V_t
    A_t     = delta_t + gamma lambda (1 - d_t) A_{t+1},      A_T = 0
    R_t     = A_t + V_t                                       (the value target)

as SB3's ``RolloutBuffer.compute_returns_and_advantage`` computes it row by row; here one
vectorised step per slot for all rows. An episode cut by a time limit (truncated, not
terminated) is bootstrapped before this by the caller: r_t += gamma V(final observation).
"""

from __future__ import annotations

import torch


def gae(
    rewards: torch.Tensor,
    values: torch.Tensor,
    dones: torch.Tensor,
    last_values: torch.Tensor,
    gamma: float,
    gae_lambda: float,
) -> tuple[torch.Tensor, torch.Tensor]:
    """``(advantages, returns)``, each (T, B), of a rollout: ``rewards``, ``values``, ``dones``
    (T, B) and ``last_values`` (B,), the values of the observations after the last step."""
    if rewards.shape != values.shape or rewards.shape != dones.shape or rewards.ndim != 2:
        raise ValueError(
            f"rewards, values and dones must be (T, B) arrays of one shape, got {tuple(rewards.shape)}, "
            f"{tuple(values.shape)}, {tuple(dones.shape)}"
        )
    if last_values.shape != rewards.shape[1:]:
        raise ValueError(
            f"last_values must be (B,) = {tuple(rewards.shape[1:])}, got {tuple(last_values.shape)}"
        )
    advantages = torch.empty_like(rewards)
    running = torch.zeros_like(last_values)
    next_values = last_values
    for t in range(rewards.shape[0] - 1, -1, -1):
        alive = 1.0 - dones[t]
        delta = rewards[t] + gamma * alive * next_values - values[t]
        running = delta + (gamma * gae_lambda) * alive * running
        advantages[t] = running
        next_values = values[t]
    return advantages, advantages + values
