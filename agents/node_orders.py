"""A multi-node policy made blind to how the nodes are numbered: its action averaged over every order.

The multi-node task does not depend on the nodes' numbering: numbering the same K nodes
otherwise permutes the observation's node blocks and the action's node scores alike and
changes nothing else. An MLP over the concatenated node blocks does not know that, and a
generalist can fly one numbering of a scenario well and skip a node in another
(``results/log.md``). :class:`NodeOrderAverage` wraps a policy's action function: for an
observation of K real nodes it calls the policy on the observation with its node blocks in each
of the K! orders, puts each action's node scores back in the nodes' own order, and returns the
mean. The result is equivariant by construction: renumbering the nodes permutes its scores and
leaves its move unchanged. It costs K! policy calls a step (24 for 4 nodes).

    python -m agents.suite report --model <multi-node run> --node-orders
"""

from __future__ import annotations

import itertools
from collections.abc import Callable

import numpy as np

from ios_uav_env.envs.multi import BASE_FEATURES, NODE_FEATURES

#: The node block's entry that is 1 for a node of the scenario and 0 for a padding slot (the
#: scenario's nodes fill the first slots).
MASK = NODE_FEATURES.index("mask")
#: The action's entries before the node scores (the move's x and y).
MOVE = 2


class NodeOrderAverage:
    """``act`` (observation -> action of a multi-node env with ``k_max`` node slots of
    ``width`` features each) averaged over every order of the observed nodes (module docstring)."""

    def __init__(self, act: Callable[[np.ndarray], np.ndarray], k_max: int, width: int) -> None:
        if int(k_max) < 1:
            raise ValueError(f"k_max: {k_max} node slots; it must be >= 1")
        if int(width) <= MASK:
            raise ValueError(f"width: {width} features a node; a node block has at least {MASK + 1}")
        self.act, self.k_max, self.width = act, int(k_max), int(width)
        self.obs_size = len(BASE_FEATURES) + self.k_max * self.width
        self._orders: dict[int, np.ndarray] = {}

    def orders(self, k: int) -> np.ndarray:
        """The (k!, k_max) slot orders that permute the first ``k`` slots (padding stays last)."""
        if k not in self._orders:
            padding = list(range(k, self.k_max))
            self._orders[k] = np.array([list(p) + padding for p in itertools.permutations(range(k))])
        return self._orders[k]

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The averaged action for one observation."""
        obs = np.asarray(obs)
        if obs.shape != (self.obs_size,):
            raise ValueError(
                f"obs: shape {obs.shape}; a multi-node observation with {self.k_max} node slots of "
                f"{self.width} features has shape ({self.obs_size},)"
            )
        base = len(BASE_FEATURES)
        nodes = obs[base:].reshape(self.k_max, self.width)
        k = int(np.count_nonzero(nodes[:, MASK] > 0.5))
        orders = self.orders(k)
        total = np.zeros(MOVE + self.k_max)
        for order in orders:
            action = np.asarray(self.act(np.concatenate([obs[:base], nodes[order].ravel()])))
            if action.shape != total.shape:
                raise ValueError(f"act: an action of shape {action.shape}; a multi-node action with "
                                 f"{self.k_max} node slots has shape {total.shape}")  # fmt: skip
            total[:MOVE] += action[:MOVE]
            total[MOVE + order] += action[MOVE:]  # slot j of this order held node order[j]
        return (total / len(orders)).astype(np.float32)
