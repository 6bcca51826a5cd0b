"""A multi-node policy that sees the nodes as a set: the same weights for every node slot.

An MLP over the concatenated node blocks of a multi-node observation learns each slot on its
own, and a generalist trained that way can fly one numbering of a scenario well and skip a node
in another (``results/log.md``). :class:`NodeSetPolicy` is an SB3 ``ActorCriticPolicy`` whose
actor is permutation-equivariant by construction (:class:`NodeSetActor`):

- **encode**: each node block, with the scenario's features (``BASE_FEATURES``, and with the
  energy objective the energy features after the node blocks), through one MLP (the
  ``net_arch`` widths, tanh): h_k;
- **context**: c = the mean of h_k over the scenario's nodes (the block's ``mask``);
- **relate**: g_k = tanh(W [h_k, c] + b), each node against the others;
- **node scores**: a linear map of g_k, one score per node (0 in a padding slot);
- **move**: attention over the nodes, a = softmax_k(w . g_k) (padding slots excluded), and an
  MLP of [scenario features, c, sum_k a_k g_k]: the move is steered by the nodes it attends to.

The layout (K_max, the node block's width, the scenario features after the blocks) is read from
the env's ``observation_names`` when the policy is given them (``policy_kwargs``'
``observation_names``, as ``agents.imitation`` does), else from the spaces' sizes among the
layouts the multi-node env publishes (``agents.node_orders.NodeLayout``).

Renumbering the nodes permutes the node scores alike and leaves the move unchanged (tested).
The observation statistics must then be the same for every slot, too: :func:`pooled_statistics`
pools each node feature over the real nodes of every slot and leaves the mask unscaled. The
critic is SB3's MLP on the whole observation. The actor reads each slot's mask after the
normalisation (pooled statistics leave it 0 or 1): a PPO fine-tune must keep the observation
statistics frozen (VecNormalize's ``training = False``), as its per-slot updates would undo the
pooling.
:meth:`NodeSetActor.to_numpy` is the same forward pass in float64 (numpy's products on a
batch; one observation compiled by numba, on its real nodes), which
``agents.numpy_policy.NumpyPolicy`` exports.

    python -m agents.imitation --out runs/set --policy node-set ...
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import torch as th
from stable_baselines3.common.policies import ActorCriticPolicy
from stable_baselines3.common.torch_layers import MlpExtractor, create_mlp
from torch import nn

from agents.node_orders import MASK, MOVE, NodeLayout  # the node block's mask entry, the move's entries
from ios_uav_env.envs.multi import BASE_FEATURES
from ios_uav_env.jit import HAVE_NUMBA, copy_into, jit

#: The encoder's widths when ``net_arch`` gives none for the actor.
DEFAULT_ARCH = (64, 64)
#: Whether one observation's forward pass runs compiled (with numba; else numpy's products).
COMPILED = True
#: Logit of a padding slot in the move's attention: exp() of it is 0 in float32 and float64.
PADDING_LOGIT = -1e9


def node_set_layout(obs_size: int, action_size: int, names: Sequence[str] | None = None) -> NodeLayout:
    """The layout the node-set actor reads: from ``names`` (an env's ``observation_names``;
    checked against the sizes) if given, else from the sizes (``NodeLayout.from_sizes``: the
    layouts the multi-node env publishes). ``ValueError`` naming the sizes or the names otherwise."""
    if names is None:
        return NodeLayout.from_sizes(obs_size, action_size)
    layout = NodeLayout.from_names(names, "the node-set policy")
    if (
        layout.base != len(BASE_FEATURES)
        or layout.size != int(obs_size)
        or layout.k_max != int(action_size) - MOVE
    ):
        raise ValueError(
            f"observation_names: {layout.describe()} features with {layout.base} before the node blocks, "
            f"but the spaces have {obs_size} observations ({len(BASE_FEATURES)} before the blocks) and "
            f"{action_size} actions ({MOVE} + k_max)"
        )
    return layout


def node_layout(obs_size: int, action_size: int) -> tuple[int, int]:
    """(k_max, width) of a multi-node env's flat observation and action sizes; ``ValueError``
    naming the sizes if they are not ``BASE_FEATURES`` + k_max blocks and 2 + k_max scores (and
    naming the features after the blocks, which it does not give: :func:`node_set_layout` does)."""
    layout = NodeLayout.from_sizes(obs_size, action_size)
    if layout.extra:
        raise ValueError(
            f"observation size {obs_size}: {layout.extra} scenario features after the node blocks "
            f"({', '.join(layout.names[layout.nodes_end :])}); node_layout gives (k_max, width) only: "
            "read the layout with node_set_layout"
        )
    return layout.k_max, layout.width


def pooled_statistics(
    obs: np.ndarray, k_max: int, width: int, extra: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """(mean, var) for VecNormalize's ``obs_rms`` that treat every node slot alike: each scenario
    feature (the ``BASE_FEATURES`` and the ``extra`` ones after the node blocks) over the rows,
    each node feature over the real nodes (mask 1) of every slot, the same in every slot; the
    mask itself has mean 0 and var 1 (left as it is, 0 or 1)."""
    x = np.asarray(obs, dtype=np.float64)
    base = len(BASE_FEATURES)
    end = base + k_max * width
    if x.ndim != 2 or x.shape[1] != end + extra or len(x) < 2:
        raise ValueError(f"obs: shape {x.shape}; (rows >= 2, {end + extra}) expected")
    nodes = x[:, base:end].reshape(-1, width)
    real = nodes[nodes[:, MASK] > 0.5]
    if len(real) < 2:
        raise ValueError("obs: fewer than 2 real nodes in all; node statistics need more")
    node_mean, node_var = real.mean(0), real.var(0)
    node_mean[MASK], node_var[MASK] = 0.0, 1.0
    mean = np.concatenate([x[:, :base].mean(0), np.tile(node_mean, k_max), x[:, end:].mean(0)])
    var = np.concatenate([x[:, :base].var(0), np.tile(node_var, k_max), x[:, end:].var(0)])
    return mean, var


@jit(inline=True)
def _dense(inp: np.ndarray, w: np.ndarray, bias: np.ndarray, squash: bool) -> np.ndarray:
    """inp (n, a) @ w (a, b) + bias, then tanh if ``squash``: loops that numba compiles."""
    out = np.empty((inp.shape[0], w.shape[1]))
    for i in range(inp.shape[0]):
        copy_into(out[i], bias)  # (not `out[i] = bias`: numba's shape-error path)
        for a in range(w.shape[0]):  # rows of w: the innermost loop runs along memory (SIMD)
            value = inp[i, a]
            for j in range(w.shape[1]):
                out[i, j] += value * w[a, j]
        if squash:
            for j in range(w.shape[1]):
                out[i, j] = math.tanh(out[i, j])
    return out


@jit
def _forward_one(scene: np.ndarray, nodes: np.ndarray, k_real: int, k_max: int, width: int,
                 w_base: np.ndarray, w_node: np.ndarray, b_in: np.ndarray, w_deep: np.ndarray,
                 b_deep: np.ndarray, w_rel_h: np.ndarray, w_rel_c: np.ndarray, b_rel: np.ndarray,
                 w_heads: np.ndarray, b_heads: np.ndarray, w_move: np.ndarray, b_move: np.ndarray,
                 w_out: np.ndarray, b_out: np.ndarray) -> np.ndarray:  # fmt: skip
    """:meth:`NodeSetActor.to_numpy`'s forward pass of one observation whose ``k_real`` nodes fill
    the first slots, compiled: a plan calls it once a slot, and numpy's per-call overhead is
    most of the small products' time. ``scene``: the scenario features (before the node blocks,
    then after them), ``nodes``: the node blocks, flat; ``w_deep`` (L, H, H): the encoder's layers
    after the first."""
    base = w_base.shape[0]
    pre = _dense(scene.reshape(1, base), w_base, b_in, False)[0]
    h = _dense(nodes[: k_real * width].reshape(k_real, width), w_node, pre, True)
    for layer in range(w_deep.shape[0]):
        h = _dense(h, w_deep[layer], b_deep[layer], True)
    context = np.zeros((1, h.shape[1]))
    for i in range(k_real):
        for j in range(h.shape[1]):
            context[0, j] += h[i, j] / k_real
    g = _dense(h, w_rel_h, _dense(context, w_rel_c, b_rel, False)[0], True)
    heads = _dense(g, w_heads, b_heads, False)
    top = heads[0, 1]
    for i in range(k_real):
        top = max(top, heads[i, 1])
    weights = np.exp(heads[:, 1] - top)
    weights /= weights.sum()
    joined = np.zeros((1, base + 2 * h.shape[1]))
    copy_into(joined[0], scene)  # (jit.copy_into: no slice assignment in a kernel)
    copy_into(joined[0, base:], context[0])
    pooled = joined[0, base + h.shape[1] :]  # (a view: `joined[0, a:] += ...` would assign a slice)
    for i in range(k_real):  # (elementwise: an array `+=` compiles numba's shape-error path)
        for j in range(pooled.size):
            pooled[j] += weights[i] * g[i, j]
    move = _dense(_dense(joined, w_move, b_move, True), w_out, b_out, False)[0]
    out = np.zeros(MOVE + k_max)
    copy_into(out, move)
    copy_into(out[MOVE:], heads[:, 0])
    return out


class NodeSetActor(nn.Module):
    """The equivariant actor of the module docstring: (B, obs_size) -> (B, 2 + k_max) action means;
    the observation: ``BASE_FEATURES``, ``k_max`` node blocks of ``width``, then ``extra`` scenario
    features (the energy features), which join the ``BASE_FEATURES`` as the scenario's."""

    def __init__(self, k_max: int, width: int, arch: Sequence[int], extra: int = 0) -> None:
        super().__init__()
        if not arch or any(int(w) < 1 for w in arch):
            raise ValueError(f"net_arch: must be layer widths >= 1, got {list(arch)!r}")
        if int(extra) < 0:
            raise ValueError(f"extra: {extra} features after the node blocks; it must be >= 0")
        self.k_max, self.width, self.base, self.extra = int(k_max), int(width), len(BASE_FEATURES), int(extra)
        self.end = self.base + self.k_max * self.width  # after the node blocks
        scene = self.base + self.extra  # the scenario features each node's encoder sees
        hidden = int(arch[-1])
        # SB3's tanh MLPs: (Linear, Tanh) pairs, with a last Linear where an output width is given
        self.encode = nn.Sequential(*create_mlp(scene + self.width, -1, list(map(int, arch)), nn.Tanh))
        self.relate = nn.Sequential(*create_mlp(2 * hidden, -1, [hidden], nn.Tanh))
        self.score = nn.Linear(hidden, 1)
        self.attend = nn.Linear(hidden, 1)
        self.move = nn.Sequential(*create_mlp(scene + 2 * hidden, MOVE, [hidden], nn.Tanh))

    def forward(self, x: th.Tensor) -> th.Tensor:
        b, k = x.shape[0], self.k_max
        if x.shape[1] != self.end + self.extra:
            raise ValueError(
                f"observations of {x.shape[1]} features; the actor reads {self.end + self.extra}"
            )
        base = th.cat([x[:, : self.base], x[:, self.end :]], 1) if self.extra else x[:, : self.base]
        nodes = x[:, self.base : self.end].reshape(b, k, self.width)
        mask = (nodes[..., MASK] > 0.5).to(x.dtype)
        h = self.encode(th.cat([base[:, None, :].expand(b, k, base.shape[1]), nodes], -1))
        context = (h * mask[..., None]).sum(1) / mask.sum(1, keepdim=True).clamp(min=1.0)
        g = self.relate(th.cat([h, context[:, None, :].expand_as(h)], -1))
        scores = self.score(g)[..., 0] * mask  # a padding slot's score is 0 (the env ignores it)
        logits = self.attend(g)[..., 0].masked_fill(mask < 0.5, PADDING_LOGIT)
        attended = (th.softmax(logits, 1)[..., None] * g).sum(1)
        return th.cat([self.move(th.cat([base, context, attended], -1)), scores], 1)

    def to_numpy(self) -> Callable[[np.ndarray], np.ndarray]:
        """The same forward pass in float64, for one (obs_size,) observation or a batch: numpy's
        products on a batch; one observation compiled (:func:`_forward_one`, with numba), on its
        real nodes only. The layers of concatenations are split into sums of products (a layer of
        [u, v] is u W_u + v W_v)."""
        p = {
            name: value.detach().cpu().numpy().astype(np.float64) for name, value in self.state_dict().items()
        }
        base, k, width, end = self.base, self.k_max, self.width, self.end
        scene = base + self.extra
        hidden = p["relate.0.weight"].shape[0]
        w_in = p["encode.0.weight"].T  # (scene + width, H): the scenario's rows, then the node block's
        w_base, w_node, b_in = w_in[:scene].copy(), w_in[scene:].copy(), p["encode.0.bias"]
        deeper = [(p[f"encode.{2 * i}.weight"].T.copy(), p[f"encode.{2 * i}.bias"])
                  for i in range(1, sum(1 for m in self.encode if isinstance(m, nn.Linear)))]  # fmt: skip
        w_rel = p["relate.0.weight"].T
        w_rel_h, w_rel_c, b_rel = w_rel[:hidden].copy(), w_rel[hidden:].copy(), p["relate.0.bias"]
        w_heads = np.concatenate([p["score.weight"], p["attend.weight"]]).T.copy()  # (H, 2)
        b_heads = np.concatenate([p["score.bias"], p["attend.bias"]])
        w_move, b_move = p["move.0.weight"].T.copy(), p["move.0.bias"]
        w_out, b_out = p["move.2.weight"].T.copy(), p["move.2.bias"]

        # the compiled path takes the deeper encoder layers stacked: every one of them (H, H)
        stackable = all(w.shape == (hidden, hidden) for w, _ in deeper) and w_base.shape[1] == hidden
        compiled = None
        if COMPILED and HAVE_NUMBA and stackable:
            compiled = (np.array([w for w, _ in deeper]).reshape(len(deeper), hidden, hidden),
                        np.array([b for _, b in deeper]).reshape(len(deeper), hidden))  # fmt: skip

        def scenario(x: np.ndarray) -> np.ndarray:
            """The scenario features of observations (..., obs_size): before the blocks, then after."""
            return np.concatenate([x[..., :base], x[..., end:]], -1) if end < x.shape[-1] else x[..., :base]

        def one(x: np.ndarray) -> np.ndarray | None:
            """One observation whose real nodes fill the first slots, compiled, on those nodes only
            (None otherwise: the batch's path)."""
            mask = x[base + MASK : end : width] > 0.5
            k_real = int(mask.sum())
            if compiled is None or k_real == 0 or not mask[:k_real].all():
                return None
            return _forward_one(scenario(x), x[base:end], k_real, k, width, w_base, w_node, b_in,
                                *compiled, w_rel_h, w_rel_c, b_rel, w_heads, b_heads, w_move, b_move,
                                w_out, b_out)  # fmt: skip

        def forward(obs: np.ndarray) -> np.ndarray:
            x = np.ascontiguousarray(obs, dtype=np.float64)  # the compiled path reshapes views
            if x.shape[-1] != end + self.extra:
                raise ValueError(
                    f"observations of {x.shape[-1]} features; the actor reads {end + self.extra}"
                )
            if x.ndim == 1 and (out := one(x)) is not None:
                return out
            single = x.ndim == 1
            x = x[None] if single else x
            b = len(x)
            s = scenario(x)
            nodes = x[:, base:end].reshape(b * k, width)  # 2-D products: numpy's fastest at these sizes
            real = (nodes[:, MASK] > 0.5).reshape(b, k)
            h = np.tanh(nodes @ w_node + np.repeat(s @ w_base + b_in, k, axis=0))
            for w, bias in deeper:
                h = np.tanh(h @ w + bias)
            weight = real.astype(np.float64)
            count = np.maximum(weight.sum(1), 1.0)[:, None]
            context = (weight[:, None, :] @ h.reshape(b, k, hidden))[:, 0] / count
            g = np.tanh(h @ w_rel_h + np.repeat(context @ w_rel_c + b_rel, k, axis=0))
            heads = (g @ w_heads + b_heads).reshape(b, k, 2)
            logits = np.where(real, heads[..., 1], PADDING_LOGIT)
            a = np.exp(logits - logits.max(1, keepdims=True))
            attended = ((a / a.sum(1, keepdims=True))[:, None, :] @ g.reshape(b, k, hidden))[:, 0]
            move = np.tanh(np.concatenate([s, context, attended], 1) @ w_move + b_move) @ w_out + b_out
            out = np.concatenate([move, heads[..., 0] * weight], 1)
            return out[0] if single else out

        return forward


class NodeSetExtractor(MlpExtractor):
    """SB3's ``MlpExtractor`` with :class:`NodeSetActor` as its policy network: its latent is the
    action mean itself (the policy's ``action_net`` is the identity)."""

    def __init__(self, feature_dim: int, k_max: int, width: int, pi: Sequence[int], vf: Sequence[int],
                 activation_fn: Any, device: Any, extra: int = 0) -> None:  # fmt: skip
        super().__init__(
            feature_dim, net_arch=dict(pi=[], vf=list(vf)), activation_fn=activation_fn, device=device
        )
        self.policy_net = NodeSetActor(k_max, width, pi, extra).to(device)
        self.latent_dim_pi = MOVE + k_max


class NodeSetPolicy(ActorCriticPolicy):
    """An SB3 ``ActorCriticPolicy`` with the node-set actor (module docstring). ``net_arch``: the
    encoder's widths (a list, or a dict whose ``pi`` is used for the actor and ``vf`` for the
    critic's MLP); the node layout comes from ``observation_names`` (an env's, e.g. in
    ``policy_kwargs``; kept with the saved model) if given, else from the spaces
    (:func:`node_set_layout`): with the energy objective the features after the node blocks
    are scenario features, as ``BASE_FEATURES``."""

    def __init__(self, *args: Any, observation_names: Sequence[str] | None = None, **kwargs: Any) -> None:
        # read by _build_mlp_extractor, which ActorCriticPolicy.__init__ calls
        self.observation_names = None if observation_names is None else tuple(map(str, observation_names))
        super().__init__(*args, **kwargs)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        return {**super()._get_constructor_parameters(), "observation_names": self.observation_names}

    def _build_mlp_extractor(self) -> None:
        arch = self.net_arch
        pi, vf = (arch.get("pi", []), arch.get("vf", [])) if isinstance(arch, dict) else (arch, arch)
        layout = node_set_layout(
            int(self.features_dim), int(self.action_space.shape[0]), self.observation_names
        )
        self.mlp_extractor = NodeSetExtractor(self.features_dim, layout.k_max, layout.width,
                                              pi or DEFAULT_ARCH, vf, self.activation_fn, self.device,
                                              layout.extra)  # fmt: skip

    def _build(self, lr_schedule: Any) -> None:
        super()._build(lr_schedule)
        self.action_net = nn.Identity()  # the actor's output is the action mean
        actor = self.mlp_extractor.policy_net
        for head in (actor.score, actor.attend, actor.move[-1]):
            self.init_weights(head, gain=0.01)  # small first actions, as SB3's action_net
        self.optimizer = self.optimizer_class(self.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs)
