r"""Node motion: where the ground nodes are at slot n (``docs/model.md``, "Node motion").

The static model (``ScenarioConfig.motion = None``, the default) is the paper: every node stays
at its configured position w_k. :class:`GaussMarkov` is the Gauss-Markov mobility model of
Liang and Haas (INFOCOM 1999), per node k and per slot n (dt the slot length):

    v[n+1] = a v[n] + (1 - a) m_k + sqrt(1 - a^2) sigma u[n],   u[n] ~ N(0, I_2)
    w[n+1] = w[n] + v[n] dt

with memory a in [0, 1), stationary standard deviation sigma (m/s) of each velocity component
about the node's mean velocity m_k = s (cos theta_k, sin theta_k): the mean speed s and a mean
heading theta_k, either one given heading for every node or drawn uniformly in [0, 2 pi) per
node. The first velocity is drawn from the stationary law of the recursion given m_k,
v[0] ~ N(m_k, sigma^2 I_2) (the fixed point of Var v = a^2 Var v + (1 - a^2) sigma^2), so the
speed process is stationary from the first slot; w[0] is the configured position.

**The box and the IOS plane.** Each node stays in a rectangle: the motion's ``box`` (default:
the scene box of the nodes and the IOS centre, :func:`~ios_uav_env.model.config.scene_box`
with ``ends=False``, widened by ``BOX_MARGIN``), cut, when there is a surface, to the node's own
side of the IOS plane x = x_c at least ``plane_margin`` from it. The config refuses a node on
the plane, where its side of the surface (reflection or transmission) is undefined; a node
that kept its side along its whole path keeps that channel model, so the plane is treated as
a wall. A step that leaves the rectangle is reflected: the position is mirrored at the edge
(folded as often as needed), and the velocity and the mean velocity components normal to that
edge are negated (so a node walks away from the wall instead of pressing against it, as the
edge rule of Liang and Haas intends).

**Draws.** :func:`node_paths` draws from the given numpy ``Generator`` in this order: the K mean
headings (when ``heading`` is None), the (K, 2) initial velocities, then (K, 2) normals per
slot; one generator state gives one set of paths, bit for bit.
"""

from __future__ import annotations

import dataclasses
import math
from functools import lru_cache
from typing import Any

import numpy as np

from ios_uav_env.jit import HAVE_NUMBA, copy_into, jit
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.mobility import BOX_MARGIN, GaussMarkov, as_motion, rectangles, reflect

__all__ = [
    "BOX_MARGIN",
    "GaussMarkov",
    "as_motion",
    "check_paths",
    "is_static",
    "node_bounds",
    "node_config_at",
    "node_paths",
    "reflect",
    "static_paths",
]


def node_bounds(config: ScenarioConfig) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi), each (K, 2) m: the rectangle each node moves in (the box, cut to the node's side
    of the IOS plane ``plane_margin`` away from it; :func:`~ios_uav_env.model.mobility.rectangles`)."""
    if config.motion is None:
        raise ValueError("node_bounds needs a motion model (config.motion is None: the nodes are static)")
    bounds = vars(config).get("_node_bounds")  # (the validation's, config_checks.check_motion)
    if bounds is None:
        return rectangles(
            config.motion, np.asarray(config.nodes, dtype=float), config.ios_center, config.surface
        )
    return bounds[0].copy(), bounds[1].copy()


def static_paths(config: ScenarioConfig) -> np.ndarray:
    """(N, K, 2) m: every node at its configured position in every slot (the static model)."""
    nodes = np.asarray(config.nodes, dtype=float)
    return np.repeat(nodes[None], config.N, axis=0)


def node_paths(config: ScenarioConfig, rng: np.random.Generator) -> np.ndarray:
    """(N, K, 2) m: the node positions w_k[n] of every slot, drawn from ``rng`` (module docstring;
    the static model returns :func:`static_paths` and draws nothing)."""
    motion = config.motion
    if motion is None:
        return static_paths(config)
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy Generator (np.random.default_rng(seed)), got {rng!r}")
    lo, hi = node_bounds(config)
    k_nodes, a, sigma = config.K, motion.memory, motion.sigma
    if motion.heading is None:
        theta = rng.uniform(0.0, 2.0 * math.pi, k_nodes)
    else:
        theta = np.full(k_nodes, motion.heading)
    mean = motion.speed * np.column_stack([np.cos(theta), np.sin(theta)])
    v = mean + sigma * rng.standard_normal((k_nodes, 2))
    w = np.asarray(config.nodes, dtype=float)
    gain = math.sqrt(1.0 - a * a) * sigma
    if HAVE_NUMBA:  # the slots' normals in one draw (the same stream), the walk compiled
        normals = rng.standard_normal((config.N - 1, k_nodes, 2))
        return _walk(w, v, mean, normals, lo, hi, a, gain, config.dt)
    out = np.empty((config.N, k_nodes, 2))
    out[0] = w
    for n in range(config.N - 1):
        step = w + v * config.dt
        v = a * v + (1.0 - a) * mean + gain * rng.standard_normal((k_nodes, 2))
        w, flip = reflect(step, lo, hi)
        v = np.where(flip, -v, v)
        mean = np.where(flip, -mean, mean)
        out[n + 1] = w
    return out


@jit(fastmath=False)
def _walk(
    w: np.ndarray, v: np.ndarray, mean: np.ndarray, normals: np.ndarray, lo: np.ndarray,
    hi: np.ndarray, a: float, gain: float, dt: float,
) -> np.ndarray:  # fmt: skip
    """The loop of :func:`node_paths` (and :func:`~ios_uav_env.model.mobility.reflect`) per
    component, slot n + 1 from slot n's ``normals[n]``: the same IEEE operations in the same
    order (no fused multiply-add, no reassociation), so the same paths bit for bit."""
    v, mean = v.copy(), mean.copy()
    out = np.empty((normals.shape[0] + 1, w.shape[0], 2))
    for k in range(w.shape[0]):  # (copy_into, row by row: out[0] = w is a row assignment)
        copy_into(out[0, k], w[k])
    for n in range(normals.shape[0]):
        for k in range(w.shape[0]):
            for c in range(2):
                out[n + 1, k, c], v[k, c], mean[k, c] = walk_component(
                    out[n, k, c], v[k, c], mean[k, c], normals[n, k, c], lo[k, c], hi[k, c], a, gain, dt
                )
    return out


@jit(inline=True, fastmath=False)
def walk_component(
    w: float, v: float, mean: float, normal: float, low: float, high: float, a: float, gain: float, dt: float
) -> tuple[float, float, float]:
    """One slot of one component of :func:`node_paths`' walk: (w[n+1], v[n+1], the mean velocity
    after it) from w[n], v[n], the mean velocity and the slot's standard ``normal``, reflected into
    [``low``, ``high``] as :func:`~ios_uav_env.model.mobility.reflect` does (an odd number of
    mirrorings reverses the velocity and the mean). IEEE operations in :func:`_walk`'s order: the
    batched envs' compiled draws walk with it too."""
    p = w + v * dt
    vel = a * v + (1.0 - a) * mean + gain * normal
    if low <= p <= high:
        return p, vel, mean
    width = high - low
    u = p - low
    times = np.floor(u / width)
    r = u - times * width
    if times % 2 != 0:  # mirrored an odd number of times: reversed
        return high - r, -vel, -mean
    return low + r, vel, mean


def check_paths(config: ScenarioConfig, paths: Any, n_slots: int | None = None) -> np.ndarray:
    """``paths`` as a finite float (n, K, 2) array, n = ``n_slots`` (default N); ``ValueError``
    naming the expected shape otherwise."""
    n = config.N if n_slots is None else n_slots
    arr = np.asarray(paths, dtype=float)
    if arr.shape != (n, config.K, 2):
        raise ValueError(f"paths must have shape (N, K, 2) = ({n}, {config.K}, 2) (m), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("paths must be finite (no NaN or inf)")
    return arr


def is_static(config: ScenarioConfig, paths: np.ndarray) -> bool:
    """Every node at its configured position in every slot of ``paths`` (n, K, 2)."""
    return bool(np.array_equal(paths, np.broadcast_to(np.asarray(config.nodes, dtype=float), paths.shape)))


def node_config_at(config: ScenarioConfig, k: int, position: Any) -> ScenarioConfig:
    """The static single-node config of node k at ``position`` (m): ``config.node_config(k)``
    when that is where node k is configured, else the same with G = ``position`` and no motion
    (the model of r_k(q; w_k[n])). Cached: a path's configs are built once, and the same
    position gives the same object (so the model's per-config caches find it)."""
    return _node_config_at(config, int(k), float(position[0]), float(position[1]))


@lru_cache(maxsize=16384)
def _node_config_at(config: ScenarioConfig, k: int, x: float, y: float) -> ScenarioConfig:
    base = config.node_config(k)
    if (x, y) == base.ground_node and base.motion is None:
        return base
    return dataclasses.replace(base, ground_node=(x, y), motion=None)
