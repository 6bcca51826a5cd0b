"""The compiled node weights of the surface's ground side (``ios_uav_env.model.surface``, module
docstring): ky B kz^T for each ground point, B the beta at the interpolation points, in IEEE
arithmetic in the numpy form's order, element by element, so bit for bit the numpy weights.
:func:`interpolated_weights` takes the points of a moving node's path :data:`WEIGHT_BLOCK` at a
time (its innermost loops over the points, which vectorise); :func:`point_weights` one point
after another, for a few points (a configured node's one)."""

from __future__ import annotations

import numpy as np

from ios_uav_env.jit import jit

__all__ = [
    "WEIGHT_BLOCK",
    "block_weights",
    "interpolated_weights",
    "interpolated_weights_into",
    "point_weights",
]


#: Points :func:`interpolated_weights` computes side by side (its innermost loops run over them).
WEIGHT_BLOCK = 32
#: The interpolation points per axis whose products :func:`_block_product` unrolls (the paper's
#: geometry's, ``surface.ground_count``): a point's sum over them then stays in a register, the
#: block's points side by side in the vector lanes.
UNROLLED_POINTS = 9


@jit(fastmath=False)
def interpolated_weights(
    scale: np.ndarray, dx2: np.ndarray, dy2: np.ndarray, z2: np.ndarray, ky_t: np.ndarray, kz_t: np.ndarray
) -> np.ndarray:
    """out[p] = ky B kz^T, (ny, nz), with B[c, d] = scale[p] / d2^2, d2 = (dx2[p] + dy2[p, c]) +
    z2[d] (``ky_t`` = ky^T, ``kz_t`` = kz^T): ``surface._ground_weights``' numpy form element by
    element, in IEEE arithmetic (no fused multiply-add, no reassociation; each sum from 0 in index
    order), so bit for bit the same. The points are taken :data:`WEIGHT_BLOCK` at a time and the
    innermost loops run over a block's points, each point's sums on their own, so they vectorise
    without reordering any sum."""
    out = np.empty((dy2.shape[0], ky_t.shape[1], kz_t.shape[1]))
    interpolated_weights_into(out.reshape(dy2.shape[0], ky_t.shape[1] * kz_t.shape[1]), 1.0, scale, dx2, dy2,
                              z2, ky_t, kz_t)  # fmt: skip
    return out


@jit(fastmath=False)
def interpolated_weights_into(
    out: np.ndarray, factor: float, scale: np.ndarray, dx2: np.ndarray, dy2: np.ndarray, z2: np.ndarray,
    ky_t: np.ndarray, kz_t: np.ndarray,
) -> None:  # fmt: skip
    """:func:`interpolated_weights` written into ``out`` ((points, ny nz), point p's (ny, nz) weights
    flattened in C order into row p; any 2-d view, e.g. the weight rows of a path's kernels), each
    weight multiplied by ``factor`` (one IEEE product per weight after its sums, as numpy's
    ``factor * weights``; 1.0: the weights themselves, bit for bit)."""
    py, ny, pz, nz = ky_t.shape[0], ky_t.shape[1], kz_t.shape[0], kz_t.shape[1]
    points, block = dy2.shape[0], WEIGHT_BLOCK
    dy2_t = np.ascontiguousarray(dy2.T)
    beta = np.zeros((py, pz, block))  # (zeros: a last block's unused lanes, computed but not read)
    half = np.zeros((pz, ny, block))  # (ky B)^T of the block's points
    weights = np.zeros((ny, nz, block))
    for start in range(0, points, block):
        m = min(block, points - start)
        block_weights(weights, half, beta, scale, dx2, dy2_t, z2, ky_t, kz_t, start, m)
        for j in range(m):
            for x in range(ny):
                for y in range(nz):
                    out[start + j, x * nz + y] = factor * weights[x, y, j]


@jit(fastmath=False)
def block_weights(
    weights: np.ndarray, half: np.ndarray, beta: np.ndarray, scale: np.ndarray, dx2: np.ndarray,
    dy2_t: np.ndarray, z2: np.ndarray, ky_t: np.ndarray, kz_t: np.ndarray, start: int, m: int,
) -> None:  # fmt: skip
    """The unscaled weights of the block of points ``start`` .. ``start + m - 1`` into
    ``weights[:, :, :m]`` ((ny, nz, block)): B = ``scale`` / d^4 at the interpolation points
    (d^2 = (dx^2 + dy^2) + z^2, ``dy2_t`` (py, points)) into ``beta`` ((py, pz, block)), then
    (ky B)^T into ``half`` ((pz, ny, block)) and kz^T (ky B)^T (:func:`_block_product`), IEEE.
    The lanes past ``m`` may be computed too (from what the work arrays hold there: finite
    numbers, e.g. zeros or an earlier block's) and are not to be read."""
    for c in range(ky_t.shape[0]):
        for d in range(kz_t.shape[0]):
            z, beta_cd = z2[d], beta[c, d]
            for j in range(m):
                d2 = (dx2[start + j] + dy2_t[c, start + j]) + z
                beta_cd[j] = scale[start + j] / (d2 * d2)
    _block_product(half, ky_t, beta, m)
    _block_product(weights, kz_t, half, m)


@jit(fastmath=False)
def _block_product(out: np.ndarray, scalars: np.ndarray, vectors: np.ndarray, m: int) -> None:
    """out[x, y, :m] = the sum over z, from 0 in index order, of scalars[z, y] x vectors[z, x, :m]
    (IEEE products and sums: a block's (ky B)^T from ky^T and B, then its weights from kz^T and
    (ky B)^T; a product's operands in either order are the same number). With
    :data:`UNROLLED_POINTS` terms and blocks of :data:`WEIGHT_BLOCK` lanes the same sums in the same
    order, each in a register (:func:`_unrolled_product`: all the lanes)."""
    if (
        vectors.shape[0] == UNROLLED_POINTS
        and out.shape[2] == WEIGHT_BLOCK
        and vectors.shape[2] == WEIGHT_BLOCK
    ):
        _unrolled_product(out, scalars, vectors)
        return
    out[:] = 0.0
    for z in range(vectors.shape[0]):
        for x in range(out.shape[0]):
            vector = vectors[z, x]
            for y in range(out.shape[1]):
                k, row = scalars[z, y], out[x, y]
                for j in range(m):
                    row[j] += k * vector[j]


@jit(fastmath=False)
def _unrolled_product(out: np.ndarray, scalars: np.ndarray, vectors: np.ndarray) -> None:
    """:func:`_block_product` of :data:`UNROLLED_POINTS` terms on every one of the
    :data:`WEIGHT_BLOCK` lanes: a lane's sum ((0 + s_0 v_0) + s_1 v_1) + ... in a register, the
    constant counts letting the compiler unroll the terms and vectorise the lanes (IEEE: the
    same sums, bit for bit)."""
    for x in range(out.shape[0]):
        for y in range(out.shape[1]):
            row = out[x, y]
            for j in range(WEIGHT_BLOCK):
                total = 0.0
                for z in range(UNROLLED_POINTS):
                    total += scalars[z, y] * vectors[z, x, j]
                row[j] = total


@jit(fastmath=False)
def point_weights(
    scale: np.ndarray, dx2: np.ndarray, dy2: np.ndarray, z2: np.ndarray, ky_t: np.ndarray, kz_t: np.ndarray
) -> np.ndarray:
    """:func:`interpolated_weights` (the same arguments, the same bits) one point after another,
    its inner loops over a row of a point's sums: for fewer points than a block (a configured
    node's one), where the blocks cost more than they save."""
    py, ny, pz, nz = ky_t.shape[0], ky_t.shape[1], kz_t.shape[0], kz_t.shape[1]
    out = np.empty((dy2.shape[0], ny, nz))
    beta = np.empty((py, pz))
    half = np.empty((pz, ny))  # (ky B)^T
    for p in range(dy2.shape[0]):
        for c in range(py):
            row, beta_c = dx2[p] + dy2[p, c], beta[c]
            for d in range(pz):
                d2 = row + z2[d]
                beta_c[d] = scale[p] / (d2 * d2)
        _row_product(half, beta, ky_t)
        _row_product(out[p], half, kz_t)
    return out


@jit(fastmath=False)
def _row_product(out: np.ndarray, scalars: np.ndarray, rows: np.ndarray) -> None:
    """out[x, :] = the sum over z, from 0 in index order, of scalars[z, x] x rows[z, :] (IEEE:
    a point's (ky B)^T from B and ky^T, then its weights from (ky B)^T and kz^T)."""
    out[:] = 0.0
    for z in range(rows.shape[0]):
        row = rows[z]
        for x in range(out.shape[0]):
            k, target = scalars[z, x], out[x]
            for y in range(row.shape[0]):
                target[y] += k * row[y]
