"""Each moving row's node kernels of the slot it flies to, computed in the step's call: no track arrays.

The batched multi-node env with moving or roughly known nodes (``node_rows.NodeBlockRows``) used
to build, at every reset, each row's (K, N, 3, Q) kernels of every node and slot
(``knowledge.start_nodes_track``: ``channel.path_kernels``) and to copy a slot's out of them
before each step (``nodes_kernels.gather_node_kernels``): per episode a few hundred kB written
and read back from scattered arrays. A moving node's kernel changes from slot to slot only in its
surface weights (``nodes[2]``, ``surface.path_weights_into``: J ky B kz^T, B the beta of the ground
point at the interpolation points) and G's scalars (``g_side``, ``gx``, ``gy``). So here a row's
episode keeps per slot and node only the ground point and its scale ((B, S, K_max, 3): gx, gy and
|gx - x_c|^3 = dx2 ** 1.5, the power computed by numpy at reset exactly as ``path_kernels``
computes it: numpy's power is not libm's); the point's other terms (dx2 = (gx - x_c)^2, the
side) are IEEE arithmetic of gx, computed where they are used. :func:`put_node_weights` computes
the weights of the slot each row flies to straight into the row's kernel
(``NodeRows.nodes[i, k, 2]``), one point after another in the order of ``weight_kernels``' sums
(IEEE arithmetic, each sum from 0 in index order: the block form's and the point form's bits,
tested equal to the old path's bit for bit).

The row's track (:class:`BareNodesTrack`) holds the paths and the records but builds its kernels
only when read (the energy objective's reference, a score that falls back to the track's
kernels, a caller inspecting it): the same numbers as ``start_nodes_track``'s.

A row the compiled weights do not take (no numba, a surface whose weights are not interpolated)
keeps the old path (``slots[i] == 0``: its track's kernels, gathered per step).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ios_uav_env.envs.knowledge import (
    REPORT_CLIP,
    NodesTrack,
    _rectangles,
    nodes_track_kernels,
)
from ios_uav_env.jit import HAVE_NUMBA, copy_into, jit, prange, run_batched, threads_for
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.motion import node_paths
from ios_uav_env.model.node_kernels import kernel_config
from ios_uav_env.model.rate_kernels import PARAM_G_SIDE, PARAM_GX, PARAM_GY, _base_kernel
from ios_uav_env.model.surface import _Geometry, _projection
from ios_uav_env.model.weight_kernels import WEIGHT_BLOCK, block_weights

__all__ = ["BareNodesTrack", "NodeWeights", "put_node_weights", "start_bare_track"]

#: The columns of a ground point in ``NodeWeights.points``: its x, y and scale |x - x_c|^3.
PT_GX, PT_GY, PT_SCALE = range(3)


class BareNodesTrack(NodesTrack):
    """A ``knowledge.NodesTrack`` whose kernels (``nodes``, ``params``, ``held``) are built when first
    read (``knowledge.nodes_track_kernels`` of its paths, padded to ``width``): the numbers
    ``start_nodes_track`` builds at once."""

    def __init__(self, paths: np.ndarray, lo: np.ndarray, hi: np.ndarray, config: ScenarioConfig,
                 width: int) -> None:  # fmt: skip
        self._kernels: tuple[np.ndarray, np.ndarray] | None = None
        self._width = width
        super().__init__(
            paths, None, None, lo, hi, np.full((config.N, config.K, 2), np.nan),  # type: ignore[arg-type]
            np.full((config.K, config.N), np.nan), np.zeros(config.K), config,
        )  # fmt: skip

    def _built(self) -> tuple[np.ndarray, np.ndarray]:
        if self._kernels is None:
            nodes, params, held = nodes_track_kernels(self.config, self.paths, self._width)
            self._kernels, self.held = (nodes, params), held
        return self._kernels

    def _get_nodes(self) -> np.ndarray:
        return self._built()[0]

    def _get_params(self) -> np.ndarray:
        return self._built()[1]

    def _ignore(self, value: Any) -> None:  # (the dataclass's __init__ sets them: built when read)
        if value is not None:
            raise AttributeError("a BareNodesTrack builds its own kernels")

    nodes = property(_get_nodes, _ignore)  # type: ignore[assignment]
    params = property(_get_params, _ignore)  # type: ignore[assignment]


def start_bare_track(
    config: ScenarioConfig, rng: np.random.Generator, sigma: float, width: int
) -> BareNodesTrack:
    """``knowledge.start_nodes_track`` without building the kernels (the same draws from ``rng``:
    the node paths)."""
    paths = node_paths(config, rng)
    lo, hi = _rectangles(config)
    margin = REPORT_CLIP * sigma
    return BareNodesTrack(paths, lo - margin, hi + margin, config, width)


class NodeWeights:
    """The rows' ground points of every slot and node (``points`` (B, S, K_max, 3), module
    docstring) and the IOS centre's x (``cx`` (B,)), each row's episode slot count (``slots``: 0,
    the row keeps its track's kernels), node count, projection (an index into the
    lists of the projections met), J and the kernel scalars G's do not replace (``base`` (B, P))."""

    def __init__(self, rows: int, max_nodes: int, params: int) -> None:
        self.points = np.zeros((rows, 1, max_nodes, 3))
        self.cx = np.zeros(rows)
        self.slots = np.zeros(rows, dtype=np.int64)
        self.counts = np.zeros(rows, dtype=np.int64)
        self.which = np.zeros(rows, dtype=np.int64)
        self.factors = np.zeros(rows)
        self.base = np.zeros((rows, params))
        self._index: dict[Any, int] = {}  # a projection's geometry -> its entry in the lists
        self.ky_t, self.kz_t = _typed_list(np.zeros((1, 1))), _typed_list(np.zeros((1, 1)))
        self.gy, self.gz2 = _typed_list(np.zeros(1)), _typed_list(np.zeros(1))
        self._held: dict[int, tuple[Any, Any]] = {}  # id(kernel config) -> (it, _geometry's tuple)
        self._last: tuple[ScenarioConfig, Any] | None = None  # (the config asked last, its tuple)

    def _geometry(self, config: ScenarioConfig) -> tuple[Any, ...] | None:
        """(kernel config, projection index, Q, the kernels' node coordinates (2, Q), the kernel
        scalars, J, the IOS centre's x) of ``config``'s node kernels, held per kernel config
        (``node_kernels.kernel_config``: one per surface geometry and the other kernel fields);
        None where the compiled weights do not apply (no numba, weights not interpolated)."""
        if not HAVE_NUMBA:
            return None
        if self._last is not None and self._last[0] is config:
            return self._last[1]
        kc = kernel_config(config)
        held = self._held.get(id(kc))
        if held is None or held[0] is not kc:
            projection = _projection(kc)
            if projection.ky is None:
                held = (kc, None)
            else:
                key = _Geometry(kc).key  # (the projection's cache key: one entry per surface geometry)
                index = self._index.get(key)
                if index is None:
                    index = self._index[key] = len(self.gy)
                    # (writeable C-ordered copies: the lists' type; the projection's may be read-only)
                    self.ky_t.append(np.array(projection.ky_t, dtype=np.float64, order="C"))
                    self.kz_t.append(np.array(projection.kz_t, dtype=np.float64, order="C"))
                    self.gy.append(np.array(projection.gy, dtype=np.float64, order="C"))
                    self.gz2.append(np.array(projection.gz2, dtype=np.float64, order="C"))
                base = _base_kernel(kc)
                coords = np.array(base.nodes[:2], dtype=np.float64, order="C")
                params = np.array(base.params, dtype=np.float64)
                held = (
                    kc,
                    (kc, index, int(projection.y.size), coords, params, kc.J, float(kc.ios_center[0])),
                )
            if len(self._held) >= 4096:  # (bounded: kernel_config's own cache is)
                self._held.clear()
            self._held[id(kc)] = held
        self._last = (config, held[1])
        return held[1]

    def geometry(self, config: ScenarioConfig) -> tuple[Any, ...] | None:
        """(kernel config, projection index, Q, the kernels' node coordinates (2, Q), the kernel
        scalars, J, the IOS centre's x) of ``config``'s node kernels (None: the compiled weights do
        not apply), as :meth:`load` takes them: a batch that fills its rows' entries itself."""
        return self._geometry(config)

    def width(self, config: ScenarioConfig) -> int | None:
        """Q, the surface nodes of ``config``'s node kernels (``node_kernels.kernel_width``'s), where
        the compiled weights apply to it; None where they do not."""
        geometry = self._geometry(config)
        return None if geometry is None else geometry[2]

    def load(self, i: int, config: ScenarioConfig, paths: np.ndarray, nodes: np.ndarray) -> bool:
        """Row ``i``'s episode on ``config`` whose nodes walk ``paths`` ((N, K, 2) m): the ground
        points of every slot and node, and the kernels' node coordinates and padding in ``nodes[i]``
        (the row's kernels, (K_max, 3, Q)). False (nothing kept, ``slots[i]`` 0) where the compiled
        weights do not apply: then the caller builds the track's kernels."""
        self.slots[i] = 0
        geometry = self._geometry(config)
        if geometry is None or geometry[2] > nodes.shape[3]:
            return False
        _, index, _, coords, params, factor, cx = geometry
        k_nodes, n = config.K, config.N
        if n > self.points.shape[1]:
            grown = np.zeros((self.points.shape[0], n, *self.points.shape[2:]))
            grown[:, : self.points.shape[1]] = self.points
            self.points = grown
        # the scale as surface._ground_terms and path_kernels compute it (numpy, on the same (K N, 2)
        # array of the nodes' points, node after node), then put in place compiled
        grounds = paths.transpose(1, 0, 2).reshape(k_nodes * n, 2)
        dx2 = (grounds[:, 0] - cx) ** 2
        _fill_row(self.points, i, k_nodes, n, grounds, dx2**1.5, nodes, coords)
        self.cx[i] = cx
        self.base[i] = params
        self.which[i], self.factors[i] = index, factor
        self.counts[i], self.slots[i] = k_nodes, n
        return True

    def put(
        self, rows: np.ndarray, state: np.ndarray, ahead: int, nodes: np.ndarray, params: np.ndarray,
        num_threads: int | None = 1,
    ) -> None:  # fmt: skip
        """:func:`put_node_weights` of these buffers (on ``num_threads`` of numba's threads: its
        blocks, :func:`put_node_weights_batched`; None: numba's current setting; fewer rows than
        ``jit.FEW_ROWS`` on this thread alone, ``jit.threads_for``: IEEE, the same bits)."""
        args = (rows, state, ahead, self.slots, self.counts, self.which, self.points, self.cx, self.base,
                self.factors, self.ky_t, self.kz_t, self.gy, self.gz2, nodes, params)  # fmt: skip
        if threads_for(num_threads, rows.size) == 1:
            put_node_weights(*args)
        else:
            run_batched(put_node_weights_batched, put_node_weights, num_threads, *args)


@jit(fastmath=False)
def _fill_row(
    points: np.ndarray, i: int, k_nodes: int, n: int, grounds: np.ndarray, scale: np.ndarray,
    nodes: np.ndarray, coords: np.ndarray,
) -> None:  # fmt: skip
    """Row ``i``'s ground points (``grounds`` (K n, 2) and their ``scale``, node after node) into
    ``points[i, :n, :K]``, and its kernels' node coordinates ``coords`` (2, Q) and padding (0, 1, 0)
    beyond Q into ``nodes[i, :K]``."""
    q = coords.shape[1]
    for k in range(k_nodes):
        for slot in range(n):
            p, point = k * n + slot, points[i, slot, k]
            point[PT_GX], point[PT_GY], point[PT_SCALE] = grounds[p, 0], grounds[p, 1], scale[p]
        kernel = nodes[i, k]
        for x in range(q):
            kernel[0, x], kernel[1, x] = coords[0, x], coords[1, x]
        for x in range(q, kernel.shape[1]):
            kernel[0, x], kernel[1, x], kernel[2, x] = 0.0, 1.0, 0.0


def _typed_list(template: np.ndarray) -> Any:
    """An empty numba typed list of ``template``'s array type (a plain list without numba)."""
    if not HAVE_NUMBA:
        return []
    from numba.typed import List

    out = List()
    out.append(template)  # (types the list)
    out.pop()
    return out


@jit(fastmath=False)
def _point_blocks(
    rows: np.ndarray, state: np.ndarray, ahead: int, slots: np.ndarray, counts: np.ndarray, which: np.ndarray,
    block: int,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The points (row, node, slot) whose kernels :func:`put_node_weights` computes, (points, 3),
    grouped by projection (a counting sort: the projections met are few), in row order within a
    projection, and the start of each block (at most ``block`` points of one projection; the last
    entry: the number of points)."""
    total = 0
    for j in range(rows.size):
        i = rows[j]
        slot = 0 if ahead < 0 else int(state[i, 2]) + ahead
        if slots[i] > 0 and slot < slots[i]:
            total += counts[i]
    at = np.empty((total, 3), dtype=np.int64)
    t = 0
    for j in range(rows.size):
        i = rows[j]
        slot = 0 if ahead < 0 else int(state[i, 2]) + ahead
        if slots[i] > 0 and slot < slots[i]:
            for k in range(counts[i]):
                at[t, 0], at[t, 1], at[t, 2] = i, k, slot
                t += 1
    kinds = 0
    for t in range(total):
        kinds = max(kinds, which[at[t, 0]] + 1)
    first = np.zeros(kinds + 1, dtype=np.int64)
    for t in range(total):
        first[which[at[t, 0]] + 1] += 1
    for p in range(kinds):
        first[p + 1] += first[p]
    points = np.empty((total, 3), dtype=np.int64)
    for t in range(total):
        p = which[at[t, 0]]
        copy_into(points[first[p]], at[t])  # (not `points[r] = at[t]`: numba's shape-error path)
        first[p] += 1
    starts = np.empty(total + 1, dtype=np.int64)
    count, start = 0, 0
    while start < total:
        starts[count] = start
        count += 1
        p, m = which[points[start, 0]], 1
        while m < block and start + m < total and which[points[start + m, 0]] == p:
            m += 1
        start += m
    starts[count] = total
    return points, starts[: count + 1].copy()


@jit(fastmath=False)
def _put_blocks(
    first: int, last: int, points_at: np.ndarray, starts: np.ndarray, which: np.ndarray, points: np.ndarray,
    cx: np.ndarray, base: np.ndarray, factors: np.ndarray, ky_ts: Any, kz_ts: Any, gys: Any, gz2s: Any,
    nodes: np.ndarray, params: np.ndarray, block: int,
) -> None:  # fmt: skip
    """Blocks ``first`` .. ``last - 1`` of :func:`_point_blocks`, one after another (:func:`_put_block`),
    on work arrays of ``block`` points allocated once (again where a projection's sizes differ)."""
    shape = (-1, -1, -1, -1)
    dx2, scale = np.zeros(block), np.zeros(block)  # (zeros: the unused lanes are computed, not read)
    dy2_t, beta = np.zeros((1, block)), np.zeros((1, 1, block))
    half, weights = np.zeros((1, 1, block)), np.zeros((1, 1, block))
    for b in range(first, last):
        p = which[points_at[starts[b], 0]]
        ky_t, kz_t = ky_ts[p], kz_ts[p]
        sizes = (ky_t.shape[0], ky_t.shape[1], kz_t.shape[0], kz_t.shape[1])
        if sizes != shape:
            shape = sizes
            py, ny, pz, nz = sizes
            dy2_t, beta = np.zeros((py, block)), np.zeros((py, pz, block))
            half, weights = np.zeros((pz, ny, block)), np.zeros((ny, nz, block))
        _put_block(b, points_at, starts, which, points, cx, base, factors, ky_ts, kz_ts, gys, gz2s, nodes,
                   params, dx2, scale, dy2_t, beta, half, weights)  # fmt: skip


@jit(fastmath=False)
def _put_block(
    b: int, points_at: np.ndarray, starts: np.ndarray, which: np.ndarray, points: np.ndarray, cx: np.ndarray,
    base: np.ndarray, factors: np.ndarray, ky_ts: Any, kz_ts: Any, gys: Any, gz2s: Any, nodes: np.ndarray,
    params: np.ndarray, dx2: np.ndarray, scale: np.ndarray, dy2_t: np.ndarray, beta: np.ndarray,
    half: np.ndarray, weights: np.ndarray,
) -> None:  # fmt: skip
    """Block ``b`` of :func:`_point_blocks`: its points' weights (``weight_kernels.block_weights``, on
    the work arrays ``dx2`` .. ``weights``, their last axis at least the block's points) and G's
    scalars into their rows' kernels."""
    start, m = starts[b], starts[b + 1] - starts[b]
    p = which[points_at[start, 0]]
    ky_t, kz_t, gy, gz2 = ky_ts[p], kz_ts[p], gys[p], gz2s[p]
    py, ny, nz = ky_t.shape[0], ky_t.shape[1], kz_t.shape[1]
    for j in range(m):
        at = points_at[start + j]
        point = points[at[0], at[2], at[1]]
        dx = point[PT_GX] - cx[at[0]]
        dx2[j], scale[j] = dx * dx, point[PT_SCALE]  # (dx2: numpy's (x - x_c) ** 2, a product)
        for c in range(py):
            e = point[PT_GY] - gy[c]
            dy2_t[c, j] = e * e
    block_weights(weights, half, beta, scale, dx2, dy2_t, gz2, ky_t, kz_t, 0, m)
    for j in range(m):
        at = points_at[start + j]
        i, k = at[0], at[1]
        point = points[i, at[2], k]
        factor, out = factors[i], nodes[i, k, 2]
        for x in range(ny):
            for y in range(nz):
                out[x * nz + y] = factor * weights[x, y, j]
        dx = point[PT_GX] - cx[i]
        copy_into(params[i, k], base[i])
        params[i, k, PARAM_G_SIDE] = 1.0 if dx > 0.0 else (-1.0 if dx < 0.0 else 0.0)  # (np.sign's)
        params[i, k, PARAM_GX] = point[PT_GX]
        params[i, k, PARAM_GY] = point[PT_GY]


@jit(fastmath=False)
def put_node_weights(
    rows: np.ndarray, state: np.ndarray, ahead: int, slots: np.ndarray, counts: np.ndarray, which: np.ndarray,
    points: np.ndarray, cx: np.ndarray, base: np.ndarray, factors: np.ndarray, ky_ts: Any, kz_ts: Any,
    gys: Any, gz2s: Any, nodes: np.ndarray, params: np.ndarray, block: int = WEIGHT_BLOCK,
) -> None:  # fmt: skip
    """Each row's node kernels of slot ``state[i, 2] + ahead`` (1: the slot it flies to; -1:
    the episode's first, slot 0) into ``nodes[i, k, 2, :ny nz]`` (the surface weights J ky B kz^T)
    and ``params[i, k]``, for the rows with ``slots[i]`` > 0 whose slot is in their episode (the
    others are left as they are). The points (row, node) are taken ``WEIGHT_BLOCK`` at a time (a
    block: points of one projection, :func:`_point_blocks`), as
    ``weight_kernels.interpolated_weights_into`` takes a path's: IEEE arithmetic, each point's
    sums on their own in index order (module docstring), so whatever block a point is in and
    whichever thread computes it, its numbers are the same."""
    at, starts = _point_blocks(rows, state, ahead, slots, counts, which, block)
    _put_blocks(0, starts.size - 1, at, starts, which, points, cx, base, factors, ky_ts, kz_ts, gys, gz2s,
                nodes, params, block)  # fmt: skip


#: The runs of blocks :func:`put_node_weights_batched` hands numba's threads (each allocates its
#: work arrays once).
BLOCK_RUNS = 16


@jit(fastmath=False, parallel=True)
def put_node_weights_batched(
    rows: np.ndarray, state: np.ndarray, ahead: int, slots: np.ndarray, counts: np.ndarray, which: np.ndarray,
    points: np.ndarray, cx: np.ndarray, base: np.ndarray, factors: np.ndarray, ky_ts: Any, kz_ts: Any,
    gys: Any, gz2s: Any, nodes: np.ndarray, params: np.ndarray, block: int = WEIGHT_BLOCK,
) -> None:  # fmt: skip
    """:func:`put_node_weights` with the blocks on numba's threads, in :data:`BLOCK_RUNS` runs of
    consecutive blocks (a block's points are rows' own: no two blocks write the same kernel)."""
    at, starts = _point_blocks(rows, state, ahead, slots, counts, which, block)
    blocks = starts.size - 1
    runs = min(blocks, BLOCK_RUNS)
    for r in prange(runs):
        first, last = blocks * r // runs, blocks * (r + 1) // runs
        _put_blocks(first, last, at, starts, which, points, cx, base, factors, ky_ts, kz_ts, gys, gz2s, nodes,
                    params, block)  # fmt: skip
