"""The fit of an SB3 PPO actor to expert labels, for ``agents.imitation``: the loss (:func:`imitation_loss`),
the node-permutation augmentation (:func:`permute_nodes`) and the training loop (:func:`fit`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from agents.expert import Dataset, node_mask
from agents.node_orders import NodeLayout
from ios_uav_env.envs.multi import BASE_FEATURES

#: Weight of the move's squared error against a node score's: the trajectory is what the rates
#: depend on most, and a drift while hovering adds up over the slots.
MOVE_WEIGHT = 4.0


def imitation_loss(mean: Any, labels: Any, mask: Any) -> tuple[Any, Any]:
    """(move loss, share loss) of a batch of policy action means against expert labels (torch):
    ``MOVE_WEIGHT`` x the squared error of the move (x and y) and the squared error of the
    scenario's node scores (``mask``; padding entries are ignored, as the env ignores them),
    each summed per state, divided by the action's size and averaged over the batch."""
    error = (mean.clamp(-1.5, 1.5) - labels) ** 2
    size = labels.shape[1]
    move = MOVE_WEIGHT * error[:, :2].sum(1).mean() / size
    share = (error[:, 2:] * mask.float()).sum(1).mean() / size
    return move, share


def permute_nodes(
    obs: Any, labels: Any, mask: Any, valid: Any, k_max: int, width: int, generator: Any, extra: int = 0
) -> tuple:
    """A random order of each row's real nodes (torch): the node blocks of the raw observations
    (after ``BASE_FEATURES``; the ``extra`` features after the blocks, the energy features, stay
    where they are), the node scores of the labels and the ``mask`` columns, permuted alike
    among the ``valid`` (real) node slots; padding slots stay last. The scenario is the same one
    with its nodes numbered otherwise, so the labels stay right."""
    import torch as th

    keys = th.rand(len(obs), k_max, generator=generator)
    keys[~valid] = 2.0  # padding sorts last, in its order
    order = keys.argsort(dim=1)
    base = len(BASE_FEATURES)
    end = base + k_max * width
    if obs.shape[1] != end + extra:
        raise ValueError(
            f"obs: {obs.shape[1]} features; {base} + {k_max} x {width} + {extra} after the blocks expected"
        )
    nodes = obs[:, base:end].reshape(len(obs), k_max, width)
    permuted = th.gather(nodes, 1, order[:, :, None].expand(-1, -1, width)).flatten(1)
    obs = th.cat([obs[:, :base], permuted, obs[:, end:]], 1)
    labels = th.cat([labels[:, :2], th.gather(labels[:, 2:], 1, order)], 1)
    return obs, labels, th.gather(mask, 1, order)


def obs_normalizer(vecnormalize: Any) -> Any:
    """``vecnormalize.normalize_obs`` on torch batches, bit for bit (the same float64 arithmetic,
    then float32): a function of a (B, obs_dim) float32 tensor. The identity when it does not
    normalise observations."""
    import torch as th

    if not vecnormalize.norm_obs:
        return lambda obs: obs
    rms, clip = vecnormalize.obs_rms, float(vecnormalize.clip_obs)
    mean = th.as_tensor(np.asarray(rms.mean, dtype=np.float64))
    std = th.as_tensor(np.sqrt(np.asarray(rms.var, dtype=np.float64) + vecnormalize.epsilon))
    return lambda obs: ((obs.double() - mean) / std).clamp(-clip, clip).float()


def fit(
    model: Any,
    vecnormalize: Any,
    data: Dataset,
    mask: np.ndarray,
    epochs: int,
    batch_size: int,
    learning_rate: float,
    seed: int = 0,
    progress: bool = True,
    permute: bool = False,
    observation_names: Sequence[str] | None = None,
) -> dict[str, float]:
    """Fit ``model``'s (SB3 PPO) action mean to ``data``'s labels on observations normalised by
    ``vecnormalize`` (:func:`imitation_loss`, Adam with a one-cycle rate peaking at
    ``learning_rate``); the last epoch's mean losses. ``permute``: every batch sees its
    scenarios with their nodes in a random order (:func:`permute_nodes`), the node blocks read
    from ``observation_names`` (the env's) if given, else from the sizes
    (``agents.node_orders.NodeLayout``)."""
    import torch as th
    from tqdm.auto import tqdm

    policy = model.policy
    gen = th.Generator().manual_seed(seed)
    x = th.as_tensor(data.obs, dtype=th.float32)
    y = th.as_tensor(data.labels, dtype=th.float32)
    m = th.as_tensor(mask)
    k_max = m.shape[1]
    layout = (
        NodeLayout.from_sizes(x.shape[1], y.shape[1])
        if observation_names is None
        else NodeLayout.from_names(observation_names, "the imitation fit")
    )
    layout.check_size(x.shape[1], "the imitation fit")
    if layout.k_max != k_max:
        raise ValueError(f"mask: {k_max} node columns, but the layout has k_max = {layout.k_max}")
    width, extra = layout.width, layout.extra
    valid = th.as_tensor(node_mask(data.obs, k_max, width)) if permute else None
    normalize = obs_normalizer(vecnormalize)
    params = [*policy.mlp_extractor.policy_net.parameters(), *policy.action_net.parameters()]
    opt = th.optim.Adam(params, lr=learning_rate)
    per_epoch = -(-len(x) // batch_size)
    sched = th.optim.lr_scheduler.OneCycleLR(opt, learning_rate, epochs * per_epoch, pct_start=0.05)
    losses = {"move": float("nan"), "share": float("nan")}
    policy.set_training_mode(True)
    for _ in tqdm(range(epochs), desc="fit", unit="epoch", disable=not progress):
        order = th.randperm(len(x), generator=gen)
        total_move = total_share = 0.0
        for start in range(0, len(x), batch_size):
            idx = order[start : start + batch_size]
            xb, yb, mb = x[idx], y[idx], m[idx]
            if valid is not None:
                xb, yb, mb = permute_nodes(xb, yb, mb, valid[idx], k_max, width, gen, extra)
            xb = normalize(xb)  # after permuting
            features = policy.extract_features(xb, policy.pi_features_extractor)
            latent = policy.mlp_extractor.forward_actor(features)
            move, share = imitation_loss(policy.action_net(latent), yb, mb)
            opt.zero_grad()
            (move + share).backward()
            opt.step()
            sched.step()
            total_move += move.item() * len(idx)
            total_share += share.item() * len(idx)
        losses = {"move": total_move / len(x), "share": total_share / len(x)}
    policy.set_training_mode(False)
    return losses
