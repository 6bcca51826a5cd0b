"""A multi-node policy made blind to how the nodes are numbered: its action averaged over every order.

The multi-node task does not depend on the nodes' numbering: numbering the same K nodes
otherwise permutes the observation's node blocks and the action's node scores alike and
changes nothing else. An MLP over the concatenated node blocks does not know that, and a
generalist can fly one numbering of a scenario well and skip a node in another
(``results/log.md``). :class:`NodeOrderAverage` wraps a policy's action function: for an
observation of K real nodes it calls the policy on the observation with its node blocks in each
of the K! orders, puts each action's node scores back in the nodes' own order, and returns the
mean. The result is equivariant by construction: renumbering the nodes permutes its scores and
leaves its move unchanged. It costs K! policy calls a step (24 for 4 nodes). Features after
the node blocks (the energy features of ``objective="energy_efficiency"``) are the scenario's
and stay where they are.

:class:`NodeLayout`: where a multi-node observation's node blocks are, read from its feature
names (``env.unwrapped.observation_names``), or from its sizes among the layouts the multi-node
env publishes; every multi-node parser of ``agents`` reads the observation through it.

    python -m agents.suite report --model <multi-node run> --node-orders
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ios_uav_env.envs.multi import BASE_FEATURES, NODE_FEATURES, NODE_PEAK_FEATURES
from ios_uav_env.envs.observation_layout import ENERGY_NAMES, node_block_names

#: The node block's entry that is 1 for a node of the scenario and 0 for a padding slot (the
#: scenario's nodes fill the first slots).
MASK = NODE_FEATURES.index("mask")
#: The action's entries before the node scores (the move's x and y).
MOVE = 2

_SLOT = re.compile(r"(.+)_(\d+)")


@dataclass(frozen=True)
class NodeLayout:
    """A multi-node observation: ``base`` scenario features, then ``k_max`` node blocks of
    ``width`` features (``<feature>_<k>``, the mask first), then ``extra`` scenario features (the
    energy features, ``ENERGY_NAMES``, with ``objective="energy_efficiency"``). ``names``: the
    features in order (those of the env, or of the exact-knowledge layout of that shape)."""

    names: tuple[str, ...]
    base: int
    k_max: int
    width: int
    extra: int

    @property
    def size(self) -> int:
        """The observation's length."""
        return self.base + self.k_max * self.width + self.extra

    @property
    def nodes_end(self) -> int:
        """The position after the last node block."""
        return self.base + self.k_max * self.width

    @property
    def scenario_names(self) -> tuple[str, ...]:
        """The scenario-level features: those before the node blocks, then those after them."""
        return self.names[: self.base] + self.names[self.nodes_end :]

    @property
    def node_features(self) -> tuple[str, ...]:
        """The features of a node block (slot 0's names without their ``_0``)."""
        return tuple(name[: -len("_0")] for name in self.names[self.base : self.base + self.width])

    @classmethod
    def from_names(cls, names: Sequence[str], who: str = "a multi-node parser") -> NodeLayout:
        """The layout of ``names`` (an env's ``observation_names``): the node blocks are the one
        run of ``<feature>_<k>`` names, k = 0 .. k_max - 1, each block the same features in the
        same order, ``mask`` first; ``ValueError`` naming ``who`` and what is wrong otherwise."""
        layout = tuple(str(n) for n in names)
        slotted = [i for i, name in enumerate(layout) if _SLOT.fullmatch(name)]
        if not slotted:
            raise ValueError(
                f"{who} reads multi-node observations (node blocks mask_0, dx_node_0, ...), but the "
                f"layout has no node block ({len(layout)} features: {', '.join(layout)}): use a "
                "multi-node id (ios_uav_env/IOSUAV-MultiNode-v0, -MultiNode-Random-v0, -MultiNode-Mobile-v0)"
            )
        start, stop = slotted[0], slotted[-1] + 1
        split = [_SLOT.fullmatch(name) for name in layout[start:stop]]
        slots = [int(m.group(2)) if m else -1 for m in split]
        width = slots.index(1) if 1 in slots else len(slots)
        k_max = len(slots) // width if width else 0
        features = [m.group(1) if m else "" for m in split[:width]]
        expected = node_block_names(features, k_max)
        if (
            not width
            or k_max * width != len(slots)
            or layout[start:stop] != expected
            or features[MASK] != "mask"
        ):
            raise ValueError(
                f"{who}: the node blocks of the layout ({', '.join(layout[start:stop])}) are not "
                f"k_max blocks <feature>_<k> (k = 0, 1, ...) of the same features, mask first"
            )
        return cls(layout, start, k_max, width, len(layout) - stop)

    @classmethod
    def from_sizes(cls, obs_size: int, action_size: int) -> NodeLayout:
        """The layout of a multi-node env's flat observation and action sizes when no names are
        at hand: K_max = ``action_size`` - 2, and the one layout of that size the multi-node env
        publishes (``BASE_FEATURES``, node blocks of ``NODE_FEATURES`` and with ``peak_hint``
        ``NODE_PEAK_FEATURES``, then with the energy objective ``ENERGY_NAMES``; those sizes never
        coincide). ``ValueError`` naming the sizes and the layouts of that K_max otherwise."""
        k_max = int(action_size) - MOVE
        candidates = [exact_layout(k_max, peak, energy) for peak in (False, True) for energy in (False, True)]
        if k_max >= 1:
            fits = [c for c in candidates if c.size == int(obs_size)]
            if len(fits) == 1:
                return fits[0]
        sizes = (
            ", ".join(f"{c.size} ({c.base} + {c.k_max} x {c.width} + {c.extra})" for c in candidates)
            if k_max >= 1
            else f"none (the action has {MOVE} + k_max entries, k_max >= 1)"
        )
        raise ValueError(
            f"observation size {obs_size} and action size {action_size}: a multi-node env has "
            f"{len(BASE_FEATURES)} + k_max x width observations (then {len(ENERGY_NAMES)} energy "
            f"features with the energy objective) and {MOVE} + k_max actions; observation sizes for "
            f"this action: {sizes}"
        )

    def check_size(self, obs_size: int, who: str = "the policy") -> None:
        """``ValueError`` naming ``who`` unless the layout has ``obs_size`` features."""
        if int(obs_size) != self.size:
            raise ValueError(
                f"{who}: observations of {obs_size} features, but the layout {self.describe()} "
                f"has {self.size}"
            )

    def describe(self) -> str:
        """``12 + 4 x 6 + 4`` and the scenario features after the blocks, for messages."""
        after = f" ({', '.join(self.names[self.nodes_end :])})" if self.extra else ""
        return f"{self.base} + {self.k_max} x {self.width} + {self.extra}{after}"


def exact_layout(k_max: int, peak: bool = False, energy: bool = False) -> NodeLayout:
    """The multi-node env's layout of ``k_max`` node slots with exact knowledge (``peak``: the
    peak hint; ``energy``: the energy objective's features after the node blocks)."""
    features = NODE_FEATURES + (NODE_PEAK_FEATURES if peak else ())
    names = BASE_FEATURES + node_block_names(features, int(k_max)) + (ENERGY_NAMES if energy else ())
    return NodeLayout(
        names, len(BASE_FEATURES), int(k_max), len(features), len(ENERGY_NAMES) if energy else 0
    )


class NodeOrderAverage:
    """``act`` (observation -> action of a multi-node env with ``k_max`` node slots of
    ``width`` features each, then ``extra`` scenario features: the energy features) averaged over
    every order of the observed nodes (module docstring). :meth:`for_layout` reads the three from
    an env's ``observation_names``."""

    def __init__(
        self, act: Callable[[np.ndarray], np.ndarray], k_max: int, width: int, extra: int = 0
    ) -> None:
        if int(k_max) < 1:
            raise ValueError(f"k_max: {k_max} node slots; it must be >= 1")
        if int(width) <= MASK:
            raise ValueError(f"width: {width} features a node; a node block has at least {MASK + 1}")
        if int(extra) < 0:
            raise ValueError(f"extra: {extra} features after the node blocks; it must be >= 0")
        self.act, self.k_max, self.width, self.extra = act, int(k_max), int(width), int(extra)
        self.obs_size = len(BASE_FEATURES) + self.k_max * self.width + self.extra
        self._orders: dict[int, np.ndarray] = {}

    @classmethod
    def for_layout(cls, act: Callable[[np.ndarray], np.ndarray], names: Sequence[str]) -> NodeOrderAverage:
        """The average of ``act`` on the layout ``names`` (an env's ``observation_names``,
        :meth:`NodeLayout.from_names`), whatever follows the node blocks."""
        layout = NodeLayout.from_names(names, "the node-order average")
        if layout.base != len(BASE_FEATURES):
            raise ValueError(
                f"the node-order average: {layout.base} features before the node blocks "
                f"({', '.join(layout.names[: layout.base])}); a multi-node env has {len(BASE_FEATURES)}"
            )
        return cls(act, layout.k_max, layout.width, layout.extra)

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
                f"{self.width} features and {self.extra} after them has shape ({self.obs_size},) (an env's "
                "layout by name: NodeOrderAverage.for_layout(act, env.unwrapped.observation_names))"
            )
        base, end = len(BASE_FEATURES), len(BASE_FEATURES) + self.k_max * self.width
        nodes = obs[base:end].reshape(self.k_max, self.width)
        k = int(np.count_nonzero(nodes[:, MASK] > 0.5))
        orders = self.orders(k)
        total = np.zeros(MOVE + self.k_max)
        for order in orders:
            action = np.asarray(self.act(np.concatenate([obs[:base], nodes[order].ravel(), obs[end:]])))
            if action.shape != total.shape:
                raise ValueError(f"act: an action of shape {action.shape}; a multi-node action with "
                                 f"{self.k_max} node slots has shape {total.shape}")  # fmt: skip
            total[:MOVE] += action[:MOVE]
            total[MOVE + order] += action[MOVE:]  # slot j of this order held node order[j]
        return (total / len(orders)).astype(np.float32)
