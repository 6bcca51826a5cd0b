r"""Several ground nodes: their rates along a flight, TDMA shares and the max-min average rate
(the scorer for K >= 1).

Contract (model.md, "Several ground nodes"): node k's rate in slot n is the single-node
expected-gain rate r_k(q[n]) with G = w_k (``config.node_config(k)``: phases (13) and the
reflect/transmit side for node k; :func:`node_rates`, on moving nodes' paths too); slot n is
shared by TDMA, alpha_k[n] >= 0, sum_k alpha_k[n] <= 1; node k's average rate is
R_k = (1/N) sum_n alpha_k[n] r_k(q[n]) and the score of a trajectory is its best schedule,

    V(q) = max_alpha min_k R_k                                                        (P)

a linear programme whose dual (D) certifies it: :mod:`ios_uav_env.model.schedule_lp` (the LP,
its dual, the certificate and how every scale is handled; its names are importable from here
too).

**The scorer's solver.** :func:`schedule` (and so :func:`maxmin_rate`, ``score_plan`` and the
multi-node envs' ``best_schedule_rate``) takes :func:`certified_schedule`: for 2 <= K <= 8 the
exact column generation of :mod:`ios_uav_env.model.maxmin` (compiled, no LP solver), certified
to ``maxmin.FAST_TOL`` relative; HiGHS (``schedule_lp.maxmin_schedule``) below for more nodes or
when that certificate fails.

For K = 1 nothing is solved: the shares are all ones and the score is
:func:`ios_uav_env.average_rate` (no scipy needed). scipy (and HiGHS, ``ios_uav_env.model.lp``) is
imported only by ``maxmin_schedule`` for K > 1: the certified column generation needs none.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ios_uav_env.model.channel import slot_rates
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.maxmin import MAX_NODES, fast_schedule
from ios_uav_env.model.motion import check_paths, is_static
from ios_uav_env.model.rate_kernels import PARAMS, as_positions, path_kernels, rates_of_rows
from ios_uav_env.model.schedule_lp import (
    CERTIFY_TOL,
    FREE_RATIO,
    SCALE_BELOW,
    SHARE_TOL,
    SMALL_SHARE,
    Schedule,
    check_rates,
    dual_value,
    maxmin_schedule,
)
from ios_uav_env.model.trajectory import as_trajectory, average_rate

__all__ = [
    "CERTIFY_TOL",
    "FREE_RATIO",
    "SCALE_BELOW",
    "SMALL_SHARE",
    "Schedule",
    "best_schedule",
    "certified_schedule",
    "dual_value",
    "maxmin_rate",
    "maxmin_schedule",
    "node_rates",
    "schedule",
    "scheduled_rates",
]

#: Each node's rate kernels along its path: entry k is node k's (``nodes`` (n, 3, Q), ``params``
#: (n, len(PARAMS))), as ``rate_kernels.path_kernels(config.node_config(k), paths[:, k])`` returns
#: them (e.g. the views a moving-node episode's track holds, ``knowledge.NodesTrack.held``).
PathKernels = Sequence[tuple[np.ndarray, np.ndarray]]


def node_rates(
    config: ScenarioConfig,
    positions: np.ndarray,
    paths: np.ndarray | None = None,
    kernels: PathKernels | None = None,
) -> np.ndarray:
    """r_k(q) (bps/Hz) of every node k at every position, shape (K, n) (``slot_rates`` per node).

    With ``paths`` (n, K, 2) m (moving nodes, ``ios_uav_env.model.motion``) position i is slot i
    and node k's rate there is r_k(q[i]; w_k[i]), the single-node model with G = w_k[i]
    (``motion.node_config_at``). Paths with every node at its configured position (the static
    model) give the arrays of ``paths=None`` bit for bit. ``kernels`` (``PathKernels``), the
    kernels of moving ``paths`` that the caller already has, are used instead of building them
    again (the same rates bit for bit; only their shapes are checked).
    """
    q = as_positions(positions)
    if paths is not None:
        w = check_paths(config, paths, len(q))
        if not is_static(config, w):
            return _moving_rates(config, q, w, kernels)
    return np.stack([slot_rates(config.node_config(k), q) for k in range(config.K)])


def _moving_rates(
    config: ScenarioConfig, q: np.ndarray, w: np.ndarray, kernels: PathKernels | None = None
) -> np.ndarray:
    """(K, n): r_k(q[i]; w_k[i]), slot i under node k's kernel at w_k[i]: ``kernels[k]`` when
    given, else ``path_kernels`` (one surface projection for every slot, no config per position);
    the compiled sum of ``rates_of_rows``, equal to ``slot_rates`` of ``node_config_at`` to rounding."""
    if kernels is not None and len(kernels) != config.K:
        raise ValueError(
            f"kernels must hold one (nodes, params) pair per node (K = {config.K}), got {len(kernels)}"
        )
    out = np.empty((config.K, len(q)))
    points = np.ascontiguousarray(q, dtype=np.float64)
    for k in range(config.K):
        if kernels is None:
            nodes, params = path_kernels(config.node_config(k), w[:, k])
        else:  # (C-contiguous float64, as path_kernels returns them: the same compiled sum)
            nodes, params = (np.ascontiguousarray(a, dtype=np.float64) for a in kernels[k])
            if nodes.ndim != 3 or nodes.shape[:2] != (len(q), 3) or params.shape != (len(q), len(PARAMS)):
                raise ValueError(
                    f"node {k}'s kernels must have shapes ({len(q)}, 3, Q) and ({len(q)}, {len(PARAMS)}), "
                    f"got {nodes.shape} and {params.shape}"
                )
        out[k] = rates_of_rows(points, nodes, params)
    return out


def certified_schedule(rates: np.ndarray) -> Schedule:
    """The best schedule (P) of a (K, N) rate matrix, certified: :func:`maxmin.fast_schedule
    <ios_uav_env.model.maxmin.fast_schedule>` for 2 <= K <= ``MAX_NODES`` when every node can be
    served (its primal and dual values within ``maxmin.FAST_TOL`` relative), else
    :func:`maxmin_schedule` (HiGHS; K = 1 and a node that cannot be served included)."""
    r = check_rates(rates)
    if 2 <= r.shape[0] <= MAX_NODES and np.all(np.sum(r, axis=1) > 0):
        found = fast_schedule(r)
        if found is not None:
            shares, weights = found[0], found[1]
            per_node = np.mean(shares * r, axis=1)
            return Schedule(shares, weights, float(per_node.min()), dual_value(r, weights), per_node)
    return maxmin_schedule(r)


def _moving(config: ScenarioConfig, paths: np.ndarray | None) -> np.ndarray | None:
    """``paths`` checked as (N, K, 2), or None when absent or static (the static nodes' computation)."""
    if paths is None:
        return None
    w = check_paths(config, paths)
    return None if is_static(config, w) else w


def schedule(
    config: ScenarioConfig,
    trajectory: np.ndarray,
    paths: np.ndarray | None = None,
    kernels: PathKernels | None = None,
) -> Schedule:
    """The certified best schedule of ``trajectory`` (:func:`certified_schedule`), on the node
    ``paths`` (N, K, 2) when given (:func:`node_rates`; with their ``kernels`` when the caller
    has them)."""
    q = as_trajectory(config, trajectory)
    w = _moving(config, paths)
    if config.K == 1:  # the single-node score, exactly: average_rate (static nodes)
        value = average_rate(config, q) if w is None else float(np.mean(node_rates(config, q, w, kernels)[0]))
        return Schedule(np.ones((1, len(q))), np.ones(1), value, value, np.array([value]))
    return certified_schedule(node_rates(config, q, w, kernels))


def best_schedule(
    config: ScenarioConfig, trajectory: np.ndarray, paths: np.ndarray | None = None
) -> np.ndarray:
    """The shares alpha (K, N) of the best schedule of ``trajectory`` (all ones for K = 1)."""
    return schedule(config, trajectory, paths).shares


def maxmin_rate(
    config: ScenarioConfig,
    trajectory: np.ndarray,
    paths: np.ndarray | None = None,
    kernels: PathKernels | None = None,
) -> float:
    """Score V(q) = max_alpha min_k R_k (bps/Hz) of a trajectory with its best schedule (on the
    node ``paths`` (N, K, 2) when given, with their ``kernels`` when the caller has them:
    :func:`node_rates`).

    For K = 1 this is :func:`ios_uav_env.average_rate` exactly (static nodes). For K > 1 the
    value is certified by its dual (:func:`certified_schedule`; ``schedule_lp``'s docstring).
    """
    return schedule(config, trajectory, paths, kernels).value


def scheduled_rates(
    config: ScenarioConfig, trajectory: np.ndarray, shares: np.ndarray, paths: np.ndarray | None = None
) -> np.ndarray:
    """R_k = (1/N) sum_n alpha_k[n] r_k(q[n]) for given shares, shape (K,); ``min`` of it is
    the score of an agent that schedules itself (never above :func:`maxmin_rate`). With node
    ``paths`` (N, K, 2), r_k(q[n]; w_k[n]).

    ``shares`` must be a finite (K, N) array, >= 0, with column sums <= 1 (+ ``SHARE_TOL``).
    """
    q = as_trajectory(config, trajectory)
    a = np.asarray(shares, dtype=float)
    if a.shape != (config.K, config.N):
        raise ValueError(f"shares must have shape (K, N) = ({config.K}, {config.N}), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError("shares must be finite (no NaN or inf)")
    if np.any(a < 0):
        raise ValueError(f"shares must be >= 0, got a minimum of {a.min():.3g}")
    sums = a.sum(axis=0)
    if np.any(sums > 1.0 + SHARE_TOL):
        n = int(np.argmax(sums))
        raise ValueError(
            f"shares' column sums (sum_k alpha_k[n]) must be <= 1, got {sums[n]:.6g} at slot {n}"
        )
    return np.mean(a * node_rates(config, q, _moving(config, paths)), axis=1)


_SCIPY: list[bool] = []  # [is scipy importable], found at the first call


def scipy_or_warn() -> bool:
    """Whether scipy (HiGHS's LP, the fallback of :func:`certified_schedule`) imports: without it
    the multi-node envs report ``info["best_schedule_rate"]`` as NaN for a flight that needs
    that fallback (:func:`reported_maxmin_rate`), with one warning the first time (an env needs
    only numpy and Gymnasium; ``pip install scipy``, or the ``planners`` extra, brings the score
    back)."""
    if not _SCIPY:
        try:
            import scipy.optimize  # noqa: F401

            _SCIPY.append(True)
        except ImportError:
            _SCIPY.append(False)
            import warnings

            warnings.warn(
                "scipy is not installed: info['best_schedule_rate'] is NaN where the certified schedule "
                "falls back to HiGHS (pip install scipy)",
                stacklevel=3,
            )
    return _SCIPY[0]


def reported_maxmin_rate(
    config: ScenarioConfig,
    trajectory: np.ndarray,
    paths: np.ndarray | None = None,
    kernels: PathKernels | None = None,
) -> float:
    """:func:`maxmin_rate` (on the node ``paths`` when given, with their ``kernels``) for the envs'
    ``info["best_schedule_rate"]``. scipy is needed only where :func:`certified_schedule` falls
    back to HiGHS (K > ``maxmin.MAX_NODES``, or a failed certificate): without it such a flight
    gets NaN (:func:`scipy_or_warn`); K = 1 and the certified column generation need no scipy."""
    try:
        return maxmin_rate(config, trajectory, paths, kernels)
    except ImportError:  # scipy, imported by the HiGHS fallback only (maxmin_schedule, lp.solve_lp)
        if scipy_or_warn():
            raise
        return float("nan")
