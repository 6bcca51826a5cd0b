"""The best-schedule value of many flown paths at once, compiled: the multi-node envs' episode
ends (``info["best_schedule_rate"]``) without a Python call per row.

Row i of a batch has a way-point path ``path[i, :N_i]`` and K_i rate kernels
(``channel.RateKernel``'s ``nodes`` and ``params``, row i's node k at ``nodes[i, k]``,
``params[i, k]``: the layout of ``ios_uav_env.envs.multi_kernels``). Its value is
:func:`~ios_uav_env.model.maxmin.maxmin_row` of the rates r_k[n] = ``channel.rate_point`` of
node k at way-point n (or, for a row marked ``stored``, ``rate_path[i, n, k]``: the rates the
env's kernels computed slot by slot, the same numbers): the value ``schedule.maxmin_rate``
gives for the static nodes of those kernels, from the same column generation
(``schedule.certified_schedule``), to rounding.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ios_uav_env.jit import jit, prange, run_batched
from ios_uav_env.model.channel import rate_point
from ios_uav_env.model.maxmin import CERTIFIED, maxmin_row

__all__ = ["OUT", "SIZES", "path_values", "path_values_rows", "path_values_rows_batched"]

#: Columns of a row of ``sizes``: the row's node count K and way-point count N.
SIZES = ("K", "N")
#: Columns of a row of ``out``: :func:`~ios_uav_env.model.maxmin.maxmin_row`'s (primal value,
#: dual value, status).
OUT = ("value", "dual", "status")
# The columns by name, as the env's kernels name theirs (``envs.single_kernels``' docstring).
SIZE_K, SIZE_N = SIZES.index("K"), SIZES.index("N")
OUT_VALUE, OUT_DUAL, OUT_STATUS = OUT.index("value"), OUT.index("dual"), OUT.index("status")


@jit(inline=True)
def _row(
    j: int, rows: np.ndarray, sizes: np.ndarray, path: np.ndarray, nodes: np.ndarray, params: np.ndarray,
    rate_path: np.ndarray, stored: np.ndarray, out: np.ndarray,
) -> None:  # fmt: skip
    i, k_n, n_n = rows[j], sizes[j, SIZE_K], sizes[j, SIZE_N]
    r = np.empty((k_n, n_n))
    for k in range(k_n):
        for n in range(n_n):
            if stored[i]:
                r[k, n] = rate_path[i, n, k]
            else:
                r[k, n] = rate_point(path[i, n, 0], path[i, n, 1], nodes[i, k], params[i, k])
    out[j, OUT_VALUE], out[j, OUT_DUAL], out[j, OUT_STATUS] = maxmin_row(r)


@jit
def path_values_rows(
    rows: np.ndarray, sizes: np.ndarray, path: np.ndarray, nodes: np.ndarray, params: np.ndarray,
    rate_path: np.ndarray, stored: np.ndarray, out: np.ndarray,
) -> None:  # fmt: skip
    """:func:`path_values_rows_batched` one row after the other."""
    for j in range(rows.shape[0]):
        _row(j, rows, sizes, path, nodes, params, rate_path, stored, out)


@jit(parallel=True)
def path_values_rows_batched(
    rows: np.ndarray, sizes: np.ndarray, path: np.ndarray, nodes: np.ndarray, params: np.ndarray,
    rate_path: np.ndarray, stored: np.ndarray, out: np.ndarray,
) -> None:  # fmt: skip
    """For each entry j: batch row ``rows[j]`` with (K, N) = ``sizes[j]``, ``out[j]`` = (primal
    value, dual value, status) of :func:`~ios_uav_env.model.maxmin.maxmin_row` of its rates
    (module docstring); the entries on numba's threads."""
    for j in prange(rows.shape[0]):
        _row(j, rows, sizes, path, nodes, params, rate_path, stored, out)


def path_values(
    rows: Sequence[int] | np.ndarray, sizes: np.ndarray, path: np.ndarray, nodes: np.ndarray,
    params: np.ndarray, num_threads: int | None = None, rate_path: np.ndarray | None = None,
    stored: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """(values, certified) of the batch rows ``rows`` (module docstring; ``sizes`` (len(rows), 2)
    their K and N; ``rate_path`` (B, N_max, K_max) and ``stored`` (B,) bool, or None: every
    row's rates from its kernels), on ``num_threads`` of numba's threads (``jit.run_batched``):
    ``certified`` false where the caller must score the row otherwise (more than
    ``maxmin.MAX_NODES`` nodes, or a certificate that failed; its value is then NaN)."""
    idx = np.ascontiguousarray(rows, dtype=np.int64)
    size = np.ascontiguousarray(sizes, dtype=np.int64).reshape(len(idx), len(SIZES))
    k_of, n_of = size[:, SIZE_K], size[:, SIZE_N]
    if len(idx) and (k_of.min() < 1 or n_of.min() < 1 or n_of.max() > path.shape[1]
                     or k_of.max() > nodes.shape[1]):  # fmt: skip
        k_got, n_got = (k_of.min(), k_of.max()), (n_of.min(), n_of.max())
        raise ValueError(
            f"sizes must be (K, N) with 1 <= K <= {nodes.shape[1]} and 1 <= N <= {path.shape[1]}, "
            f"got K in [{k_got[0]}, {k_got[1]}] and N in [{n_got[0]}, {n_got[1]}]"
        )
    if rate_path is None or stored is None:
        rate_path, stored = np.zeros((1, 1, 1)), np.zeros(path.shape[0], dtype=np.bool_)
    out = np.zeros((len(idx), len(OUT)))
    if len(idx):
        kept = np.ascontiguousarray(stored, dtype=np.bool_)
        arrays = (idx, size, path, nodes, params, rate_path, kept, out)
        run_batched(path_values_rows_batched, path_values_rows, num_threads, *arrays)
    ok = out[:, OUT_STATUS] == CERTIFIED
    return np.where(ok, out[:, OUT_VALUE], np.nan), ok
