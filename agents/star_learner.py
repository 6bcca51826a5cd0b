"""A learned surface controller for ``ios_uav_env/STARControl-v0`` and its suite ``star-v1``.

:class:`StarLearner` plays every scenario of the suite (any M, phase resolution and access) with
one set of weights: it is :class:`~ios_uav_env.benchmark.star_policies.ChannelPhases` (the
observed channel phases, the TDMA share or NOMA power split from the observed rate share, equal
amplitude splits) plus a learned residual, so its zero residual is that heuristic. The residual
comes from two small networks in float64 numpy (no torch at play time):

- a network shared by the G groups (one per group, as ``examples/star_control_ppo.py``'s element
  actor): group k's features (the cos and sin of the rounding error of its two observed phases
  on the b-bit grid) and the global features -> offsets of group k's two phase actions (/ pi,
  then rounded by the env) and of its amplitude action (NOMA; ES: the split angle, MS: the mode,
  transmitting iff the action is > 0);
- a network of the global features -> the offset of the split, in log-odds (:func:`compose`):
  the TDMA share of user r or its NOMA power fraction.

The global features (:func:`global_features`) do not depend on M in width, so one set of weights
plays every M. The action is direct (the suite's task, the env's ``control="direct"``): the policy
reads the aligned phases from its observation, as the residual control does inside the env, and
outputs the whole action.

A model folder holds ``weights.npz`` (the two networks' layers) and ``config.json`` (how it was
trained: :mod:`agents.star_training`). Play it on the suite with
``python -m ios_uav_env.benchmark evaluate --suite star-v1 --policy agents.star_learner:StarLearner``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from ios_uav_env.benchmark.star_policies import ChannelPhases
from ios_uav_env.benchmark.star_suite import StarTask
from ios_uav_env.model.star import quantise

#: The shipped model.
DEFAULT_MODEL = Path(__file__).resolve().parent / "models" / "star_learner_STARControl-v0"
#: The observation's scalar features ahead of the group phases.
HEAD = 8
#: Per-group features (cos, sin of each side's rounding error) and task features.
GROUP_FEATURES, TASK_FEATURES = 4, 5
#: The global features: the head, the task, the group features' mean, two log efficiencies, a log-odds.
GLOBAL_FEATURES = HEAD + TASK_FEATURES + GROUP_FEATURES + 4
#: The smallest rounding efficiency taken (its log stays finite); the split's fraction is kept
#: within ``ODDS_EPS`` of 0 and 1 before its log-odds are taken.
EFFICIENCY_FLOOR, ODDS_EPS = 1e-3, 1e-9
#: The steepness of the order feature (:func:`global_features`).
ORDER_GAIN = 100.0
#: A group network's input (its own features, then the global ones) and outputs.
ELEMENT_IN, ELEMENT_OUT = GROUP_FEATURES + GLOBAL_FEATURES, 3


def task_features(task: StarTask) -> np.ndarray:
    """The task as 5 numbers: TDMA, ES-NOMA, MS-NOMA (one-hot), the grid step 2^-b (0: continuous),
    log2(M) / 8."""
    kind = [task.access == "tdma", task.access == "noma" and task.protocol == "es",
            task.access == "noma" and task.protocol == "ms"]  # fmt: skip
    step = 0.0 if task.bits is None else 2.0**-task.bits
    return np.array([*map(float, kind), step, math.log2(task.M) / 8])


def features(obs: np.ndarray, task: StarTask) -> tuple[np.ndarray, np.ndarray]:
    """The group features (B, G, 4) and the global features (B, 21) of observations (B, 8 + 2G)
    (module docstring); the phases are read at the observation's layout of ``task``."""
    o = np.asarray(obs, dtype=np.float64)
    g = task.G
    parts = []
    for side in (o[:, HEAD : HEAD + g], o[:, HEAD + g : HEAD + 2 * g]):
        theta = np.pi * side
        error = quantise(theta, task.bits) - np.mod(theta, 2 * np.pi)
        parts += [np.cos(error), np.sin(error)]
    group = np.stack(parts, axis=-1)
    return group, global_features(o[:, :HEAD], group, task)


def global_features(head: np.ndarray, group: np.ndarray, task: StarTask) -> np.ndarray:
    """The global features (B, 21): the head (B, 8), the task, the group features' mean, each
    side's log rounding efficiency log |mean_k e^{j e_k}| (what rounding keeps of an aligned
    side's amplitude, the groups' channels taken alike), the log-odds of the observed rate share,
    and tanh(``ORDER_GAIN`` (log-odds + 2 (log efficiency r - log efficiency t))): the sign of
    the users' order after rounding, which decides the side of the NOMA power split's optimum
    when the two users are near each other (the suite's users stand symmetric about the surface,
    so their rates differ by a few % and the rounding decides), made steep for the networks."""
    mean = group.mean(axis=1)
    efficiency = [np.log(np.maximum(np.hypot(mean[:, i], mean[:, i + 1]), EFFICIENCY_FLOOR)) for i in (0, 2)]
    share = np.clip(head[:, HEAD - 1], ODDS_EPS, 1 - ODDS_EPS)
    odds = np.log(share / (1 - share))
    order = np.tanh(ORDER_GAIN * (odds + 2 * (efficiency[0] - efficiency[1])))
    task_row = np.broadcast_to(task_features(task), (head.shape[0], TASK_FEATURES))
    return np.column_stack([head, task_row, mean, *efficiency, odds, order])


def mlp(layers: list[tuple[np.ndarray, np.ndarray]], x: np.ndarray) -> np.ndarray:
    """Linear layers ``(W, b)`` (x @ W + b) with tanh between them."""
    for i, (w, b) in enumerate(layers):
        x = x @ w + b
        if i < len(layers) - 1:
            x = np.tanh(x)
    return x


def residuals(
    weights: dict[str, list[tuple[np.ndarray, np.ndarray]]], group: np.ndarray, glob: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The group residuals (B, G, 3) and the split residual (B,) of the features."""
    g = group.shape[1]
    inputs = np.concatenate([group, np.broadcast_to(glob[:, None, :], (*group.shape[:2], glob.shape[1]))], -1)
    element = mlp(weights["element"], inputs.reshape(-1, ELEMENT_IN)).reshape(-1, g, ELEMENT_OUT)
    return element, mlp(weights["split"], glob)[:, 0]


def compose(base: np.ndarray, group_out: np.ndarray, split_out: np.ndarray, task: StarTask) -> np.ndarray:
    """Direct actions (B, A): ``ChannelPhases``' actions ``base`` (B, A) plus the residuals
    ``group_out`` (B, G, 3) and ``split_out`` (B,). Group k's two phase actions are offset by its
    outputs 0 and 1 and wrapped to [-1, 1); under NOMA its amplitude action by its output 2,
    clipped to [-1, 1]; the split's fraction f = (a + 1) / 2 (the TDMA share of user r, or its NOMA
    power fraction) is offset in log-odds, f = sigmoid(logit(f0) + d), so that a fraction near 0
    or 1 is reached by a residual of order 1."""
    g = task.G
    out = np.array(base, dtype=np.float64)
    phases = out[:, : 2 * g] + np.concatenate([group_out[..., 0], group_out[..., 1]], axis=-1)
    out[:, : 2 * g] = np.mod(phases + 1, 2) - 1
    if task.access == "noma":
        out[:, 2 * g : 3 * g] = np.clip(out[:, 2 * g : 3 * g] + group_out[..., 2], -1.0, 1.0)
    f0 = np.clip((out[:, -1] + 1) / 2, ODDS_EPS, 1 - ODDS_EPS)
    out[:, -1] = 2 / (1 + np.exp(-(np.log(f0 / (1 - f0)) + split_out))) - 1
    return out


def load_weights(path: str | Path) -> dict[str, list[tuple[np.ndarray, np.ndarray]]]:
    """The two networks of ``path/weights.npz`` (arrays ``<net>_w<i>``, ``<net>_b<i>``), checked
    against the feature widths (``ValueError`` naming the file and the array)."""
    nets = (("element", ELEMENT_IN, ELEMENT_OUT), ("split", GLOBAL_FEATURES, 1))
    return load_layers(path, nets, "StarLearner")


def load_layers(
    path: str | Path, nets: tuple[tuple[str, int, int], ...], owner: str
) -> dict[str, list[tuple[np.ndarray, np.ndarray]]]:
    """The networks ``(name, width in, width out)`` of ``path/weights.npz``: each the arrays
    ``<name>_w<i>``, ``<name>_b<i>`` (x @ W + b) for i = 0, 1, ..., chained from ``width in`` to
    ``width out`` features (``ValueError`` naming the file and the network otherwise; ``owner``:
    the policy whose model folder it is)."""
    file = Path(path) / "weights.npz"
    if not file.exists():
        raise ValueError(f"{file}: no such file (a {owner} model folder holds weights.npz and config.json)")
    with np.load(file) as data:
        arrays = {key: np.asarray(data[key], dtype=np.float64) for key in data.files}
    out: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {}
    for net, width_in, width_out in nets:
        layers, i = [], 0
        while f"{net}_w{i}" in arrays:
            layers.append((arrays[f"{net}_w{i}"], arrays[f"{net}_b{i}"]))
            i += 1
        shapes = [w.shape for w, _ in layers]
        ok = bool(layers) and shapes[0][0] == width_in and shapes[-1][1] == width_out
        ok = (
            ok
            and all(a[1] == b[0] for a, b in zip(shapes[:-1], shapes[1:], strict=True))
            and all(b.shape == (w.shape[1],) for w, b in layers)
        )
        if not ok:
            raise ValueError(
                f"{file}: {net}_w0.. must be layers from {width_in} to {width_out} features, got {shapes}"
            )
        out[net] = layers
    return out


class StarLearner(ChannelPhases):
    """The learned residual over :class:`ChannelPhases` (module docstring); ``bind`` it to a
    scenario. ``path``: the model folder (default: the shipped one)."""

    def __init__(self, path: str | Path = DEFAULT_MODEL) -> None:
        super().__init__()
        self.path = Path(path)
        self.weights = load_weights(self.path)
        if not (self.path / "config.json").exists():
            raise ValueError(f"{self.path / 'config.json'}: no such file (how the model was trained)")
        self.config: dict[str, Any] = json.loads((self.path / "config.json").read_text(encoding="utf-8"))
        self.name = f"learned residual over ChannelPhases ({self.path.name}, StarLearner)"

    def bind(self, task: StarTask) -> StarLearner:
        """A copy that acts on ``task``'s scenario (``ValueError`` unless the observation is the
        8 scalars, the rate share last, then the 2G channel phases in order)."""
        bound = super().bind(task)
        phases = [f"star_phase_{s}_{k}" for s in ("r", "t") for k in range(task.G)]
        names = list(task.observation_names)
        if names[HEAD:] != phases or names[HEAD - 1] != "star_rate_share_r":
            raise ValueError(
                f"StarLearner reads the observation's layout (8 scalars, star_rate_share_r last, then "
                f"{phases[0]}..{phases[-1]}): got {names[HEAD - 1 : HEAD + 1]}... of {len(names)} features"
            )
        return bound

    def act(self, obs: np.ndarray) -> np.ndarray:
        """Actions (B, A) of observations (B, 8 + 2G) at the bound scenario."""
        task = self.task
        if task is None:
            raise ValueError("StarLearner is unbound: bind it to the scenario (policy.bind(task))")
        o = np.atleast_2d(np.asarray(obs, dtype=np.float64))
        base = np.stack([ChannelPhases.__call__(self, row) for row in o])
        group, glob = features(o, task)
        return compose(base, *residuals(self.weights, group, glob), task)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return self.act(np.asarray(obs)[None])[0]

    def __repr__(self) -> str:
        return f"StarLearner({str(self.path)!r})"
