"""Global optimum of problem (10) by dynamic programming over a grid of positions.

With the closed-form phases of eq. (13) the rate of slot n depends only on the UAV's
horizontal position, r(q[n]) (``ios_uav_env.slot_rates``). Problem (10),

    max (1/N) sum_n r(q[n])  s.t.  q[1] = q0, q[N] = qF, |q[n] - q[n-1]| <= D,

is then a longest-path problem: restrict the way-points q[2..N-1] to a grid and the moves
to the grid offsets inside the Euclidean disk of radius D, and a backward value recursion

    V_{N-1}(c) = r(c) + r(qF)                 if |c - qF| <= D, else -inf
    V_n(c)     = r(c) + max_{|c' - c| <= D} V_{n+1}(c'),   n = N-2, ..., 2
    optimum    = (r(q0) + max_{|c' - q0| <= D} V_2(c')) / N

gives the exact optimum over all such grid paths. The grid is anchored at q0 (so q[1] is a
grid cell) with spacing ``resolution``; qF need not be on the grid: the last move goes to
qF exactly. The disk maximum is computed, per layer and vectorised, as the maximum over the
disk's rows of 1-D running maxima (``scipy.ndimage.maximum_filter1d``), which equals
``maximum_filter`` with the disk footprint (tested) and is much faster.

**Grid box.** The axis-aligned bounding box of q0, qF, G and the IOS centre, widened by
``margin`` (m, default 100) on every side and clipped to the bounding box of the points the UAV
can reach in N - 1 moves widened by ``margin`` (``baselines.grid.grid_box``: a far-away node
does not blow the grid up). Rate peaks lie near G and near the IOS, so the
box holds them with room; paths that leave the box are not considered (raise ``margin``
to check). As ``resolution`` -> 0 and ``margin`` grows the value converges to the optimum
of problem (10).

**Ties** (equal values, e.g. cells of equal rate) are broken in the forward pass towards
the shortest move, then the smallest (dy, dx) offset: when indifferent the UAV stays put.

**A multi-antenna UAV** (``config.antennas`` = N_t) serving one node has the slot rate
log2(1 + G) of its phases and beam at their closed-form joint optimum (``ios_uav_env.model.miso``),
again a function of the position alone: :func:`solve_miso` (planner ``dp-miso``) runs the same DP
on that rate map.

**A STAR surface of b-bit phases** (``ScenarioConfig(surface="star", star_bits=b)``, TDMA): the slot
rate is that of the node's exact b-bit phases (``channel.slot_rates``: the per-slot optimum of
``ios_uav_env.model.star_slot``), again a function of the position alone, so :func:`solve` runs
the same DP on the b-bit rate map (each cell searched element by element: a few seconds more for
M = 6000). It is the trajectory reference of the STAR flight ids made with ``star_bits``.

**Parity.** The plan's ``mean_rate`` is ``ios_uav_env.average_rate`` of the trajectory; the
DP's own optimum is in ``plan.info["dp_objective"]`` and is checked equal to it (1e-9).
"""

from __future__ import annotations

import time

import numpy as np

from baselines.grid import (
    DEFAULT_MARGIN,
    MAX_TABLE_BYTES,
    check_grid_bytes,
    disk_max,
    disk_offsets,
    grid_axes,
    grid_box,
    grid_path,
    rate_map,
    validate_grid_args,
)
from baselines.plan import Plan
from baselines.registry import check as check_planner
from ios_uav_env import ScenarioConfig, slot_rates

__all__ = [
    "DEFAULT_MARGIN", "MAX_TABLE_BYTES", "disk_max", "disk_offsets", "grid_axes", "grid_box", "grid_path",
    "rate_map", "solve", "solve_miso",
]  # fmt: skip


def solve(
    config: ScenarioConfig,
    resolution: float = 2.5,
    margin: float = DEFAULT_MARGIN,
    progress: bool = False,
) -> Plan:
    """Globally optimal grid trajectory of problem (10) by dynamic programming.

    Parameters
    ----------
    config : ScenarioConfig
        The scenario; its ``surface`` decides the rate map.
    resolution : float
        Grid spacing in m, in (0, D]. Prefer one
        that divides D: otherwise the longest axial grid move, floor(D / resolution) *
        resolution, is shorter than D and tight horizons have no grid path.
    margin : float
        Widening (m, >= 0) of the grid box around q0, qF, G and the IOS centre.
    progress : bool
        Show a tqdm progress bar over the backward pass.

    Returns
    -------
    Plan
        Scheme ``"dp"``; ``info`` holds ``dp_objective`` (the DP's optimum, equal to
        ``mean_rate``), ``resolution``, ``margin``, ``box`` and ``grid_shape``.

    Several ground nodes (K > 1): :func:`baselines.dp_bound.solve_multinode`, the best plan
    found by grid DPs on the dual's per-slot rewards, with ``info["upper_bound"]``, a bound no
    feasible continuous trajectory can beat (``info["gap"]`` = upper_bound / mean_rate - 1).

    Raises
    ------
    ValueError
        Bad ``resolution``/``margin``; a value table above ``MAX_TABLE_BYTES``; or no grid
        path reaches qF in N - 1 moves (horizon too tight for this grid: refine it).
    """
    check_planner("dp", config)
    if config.K > 1:  # several ground nodes: best plan found + certified upper bound
        validate_grid_args(config, resolution, margin)
        from baselines.dp_bound import solve_multinode

        return solve_multinode(config, resolution=resolution, margin=margin, progress=progress)
    return _solve_one_node("dp", config, resolution, margin, progress)


def solve_miso(
    config: ScenarioConfig,
    resolution: float = 2.5,
    margin: float = DEFAULT_MARGIN,
    progress: bool = False,
) -> Plan:
    """Globally optimal grid trajectory of a multi-antenna UAV serving one node (``config.antennas``
    = N_t, any N_t >= 1): the grid DP of :func:`solve` on the slot rate log2(1 + G) of the phases
    and the beam at their closed-form joint optimum (aligned phases and MRT; ``channel.slot_rates``,
    ``ios_uav_env.model.miso``), which depends on the UAV's position only. Arguments, result and
    errors: :func:`solve`'s (scheme ``"dp-miso"``); N_t = 1 is ``dp``'s plan."""
    check_planner("dp-miso", config)
    return _solve_one_node("dp-miso", config, resolution, margin, progress)


def _solve_one_node(
    scheme: str, config: ScenarioConfig, resolution: float, margin: float, progress: bool
) -> Plan:
    """The grid DP of one node on ``config``'s rate map (module docstring), as planner ``scheme``."""
    t0 = time.perf_counter()
    validate_grid_args(config, resolution, margin)
    n_slots, d_max = config.N, config.D
    q0, q_f = np.asarray(config.q0), np.asarray(config.qF)
    info = {"resolution": float(resolution), "margin": float(margin), "box": list(grid_box(config, margin))}
    if n_slots == 2:  # no free way-point: q = [q0, qF] (feasible by ScenarioConfig's check)
        traj = np.array([q0, q_f])
        info.update(dp_objective=float(slot_rates(config, traj).sum() / n_slots), grid_shape=[0, 0])
        return _finish(scheme, config, traj, info, t0)

    check_grid_bytes(
        config, resolution, margin, 8 * (n_slots - 2), "value table (N - 2 float64 layers)", largest=d_max
    )
    xs, ys, _ = grid_axes(config, resolution, margin)
    _, _, rates = rate_map(config, resolution, margin)
    r_f = float(slot_rates(config, q_f)[0])
    info.update(grid_shape=[len(ys), len(xs)], n_offsets=len(disk_offsets(resolution, d_max)))
    traj, info["dp_objective"] = grid_path(config, rates, r_f, resolution, margin, progress)
    return _finish(scheme, config, traj, info, t0)


def _finish(scheme: str, config: ScenarioConfig, traj: np.ndarray, info: dict, t0: float) -> Plan:
    plan = Plan.from_trajectory(scheme, config, traj, time.perf_counter() - t0, info=info)
    gap = abs(plan.mean_rate - info["dp_objective"])
    if gap > 1e-9 * max(1.0, abs(plan.mean_rate)):
        raise RuntimeError(
            f"DP objective {info['dp_objective']!r} != average_rate {plan.mean_rate!r} (gap {gap:.3g})"
        )
    return plan
