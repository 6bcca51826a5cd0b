r"""Several ground nodes: a certified upper bound on the max-min rate, and DP plans below it.

**The bound.** For any w in the simplex and any trajectory q, by weak duality
(``ios_uav_env.model.schedule``)

    V(q) <= (1/N) sum_n f_w(q[n]),   f_w(q) = max_k w_k r_k(q),

so UB(w) = max over *feasible continuous* trajectories of the right-hand side bounds every
trajectory's score, and so does min_w UB(w). UB(w) is convex in w (a maximum of linear
functions of w), so it is minimised by Kelley's cutting planes (below).

**Accounting for the grid** (so that UB(w) bounds the continuous problem, not only grid
paths). The plane is cut into the square cells of side h of ``baselines.grid.grid_axes``
(centred on the grid points; their union is the box B) plus one state O, "outside B": the
half-planes beyond the sides of B that come from the scene's box. No feasible trajectory goes
beyond a side that the reach box clipped (``baselines.grid.grid_box``), so those sides are
closed to O (and a box clipped on all four sides has no state O). A feasible trajectory is
mapped slot by slot to the cell holding q[n] (or O); q[1] = q0 and q[N] = qF keep their exact
rewards. The relaxed DP maximises over sequences of states with

1. reward per state: an upper bound of f_w over the whole cell (or over the complement of
   B), max_k w_k Rbar_k, with Rbar_k >= sup of r_k over the region (:func:`region_rate_bound`);
2. moves: cell A -> cell B allowed when the distance between the two squares is <= D;
   cell <-> O allowed when the cell is within D of the complement of B; O -> O always;
3. time windows: at slot n a state is allowed only if it holds a point within (n - 1) D of
   q0 and (N - n) D of qF (for O: if the complement of B is that close to q0 and qF).

Every feasible trajectory's image is an allowed sequence with no smaller reward, so the
relaxed optimum is >= UB(w). The DP is the single-node machinery (``disk_max`` on the
relaxed offsets) with the extra state O.

**Rate bound over a rectangle** [x_lo, x_hi] x [y_lo, y_hi] (bounds may be infinite), for
zeta = direct + surface (``ios_uav_env.model.channel``): the direct amplitude
K (d^2 + z_U^2)^(-alpha/4) is largest at the rectangle's point nearest to w_k (exact). The
surface amplitude is s sum_j c_j phi(|dx|, rho_j), phi(d, rho) = d^3 / (d^2 + rho^2)^2,
rho_j^2 = (y - y_j)^2 + (z_U - z_j)^2, over the weighted nodes (y_j, z_j, c_j) of
``ios_uav_env.model.surface.surface_nodes`` (the scorer's model). For fixed rho, phi increases in d up to
d = sqrt(3) rho and decreases after; it decreases in rho. So over the rectangle
sup phi = phi(clamp(sqrt(3) rho_min, d_lo, d_hi), rho_min) for c_j > 0 and, for c_j < 0
(the compression may make some weights negative), the term is bounded by c_j times
inf phi = c_j min(phi(d_lo, rho_max), phi(d_hi, rho_max)). The side factor s is 1 on node
k's side, ``transmit_factor`` on the other, max of both for a rectangle that straddles the
plane. A relative slack ``ZETA_SLACK`` covers rounding. rate = log2(1 + eta zeta^2) is
increasing in zeta.

**Minimising over w (Kelley).** The optimal relaxed path at w_i gives, per slot, the node
k_n maximising w_k Rbar_k and the linear minorant G_i . w' <= UB(w') (the same path with
the same choice of node). The next w minimises max_i G_i . w over the simplex (an LP),
whose value L is a lower bound of min_w UB(w): iterations stop when min_i UB(w_i) - L is
below ``tol`` (relative) or after ``max_cuts``. The start is the tour's dual weights.

**Below the bound** (plans): at every w_i, the plain grid DP (``baselines.grid.grid_path``:
moves <= D between grid points, rewards f_w at the grid points) gives a feasible
trajectory; each is scored by ``ios_uav_env.maxmin_rate``. These are good only when one
point serves all nodes, so the longest hovers of those paths, with the nodes' peaks, are
also given to the tour heuristic (routes mixing them), and the tour's own plan competes:
the plan returned is the best of all, ``info["plan_source"]`` says which.

**Moving nodes** (``paths`` (N, K, 2), the nodes' true paths known in advance: the
clairvoyant bound). Weak duality holds for any rate matrix, so with r_k[n] = r_k(q[n]; w_k[n])
V(q) <= (1/N) sum_n f_w^n(q[n]), f_w^n(q) = max_k w_k r_k(q; w_k[n]): the reward is a function
of the slot too. The relaxed DP is unchanged but for its rewards, which become per slot: the
cell bound of slot n is max_k w_k Rbar_k^n, Rbar_k^n >= sup of r_k(.; w_k[n]) over the cell
(:func:`region_rate_bound` on node k's single-node config at w_k[n], ``node_config_at``), the
same for O, and slots 1 and N keep their exact rates at w_k[1] and w_k[N]. Each step of the
argument above holds slot by slot (the image of a feasible trajectory is an allowed sequence
whose reward in slot n is no smaller than f_w^n(q[n])), so the relaxed optimum still bounds
every feasible trajectory's score on these paths, and no online policy, which knows less,
can exceed it; Kelley's cuts are built from the same per-slot rewards. Static paths give
the static tables exactly. The plans below the bound are the plain grid DP's with the
per-slot rewards f_w^n at the grid points (:func:`moving_dp_path`) at every w, and the
clairvoyant tour (``baselines.tour.solve(config, paths=...)``), all scored on the paths.

**Which side is loose.** Two things separate UB from the best plan: (i) the grid
relaxation, chiefly the move rule (two squares at most D apart may have centres up to
D + sqrt(2) h apart, so the relaxed path travels up to ~h/D faster per slot and hovers
longer); it shrinks about linearly with h; (ii) the duality gap of the non-convex problem
(min_w max_q >= max_q min_w): min_w max_q is the best point of the convex hull of the
per-node rate vectors single trajectories achieve, so it mixes hovering near different
nodes without paying the flight between them (the measured gaps: ``results/log.md``).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

import ios_uav_env as ie
from baselines.grid import (
    DEFAULT_MARGIN,
    _best_move,
    check_grid_bytes,
    disk_max,
    disk_offsets,
    grid_axes,
    grid_box,
    grid_path,
    validate_grid_args,
)
from baselines.plan import Plan
from baselines.registry import check as check_planner
from ios_uav_env import ScenarioConfig, scene_box
from ios_uav_env.model.motion import check_paths, node_config_at

#: Relative slack on the amplitude bound (floating-point rounding of the model's sums).
ZETA_SLACK = 1e-9
#: Default cap on Kelley iterations (relaxed DP solves) and their relative stopping gap.
MAX_CUTS = 25
CUT_TOL = 1e-4

__all__ = ["RelaxedDP", "clairvoyant_bound", "region_rate_bound", "solve_multinode"]


def _phi(d: np.ndarray, rho: np.ndarray) -> np.ndarray:
    """d^3 / (d^2 + rho^2)^2, 0 at d = inf or rho = inf."""
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        out = d**3 / (d * d + rho * rho) ** 2
    return np.where(np.isfinite(d) & np.isfinite(rho), out, 0.0)


def region_rate_bound(
    config: ScenarioConfig, x_lo: np.ndarray, x_hi: np.ndarray, y_lo: np.ndarray, y_hi: np.ndarray
) -> np.ndarray:
    """An upper bound of r(q) over each rectangle [x_lo, x_hi] x [y_lo, y_hi] (m; infinite
    bounds allowed) for the single-node ``config`` (module docstring). Shape of the inputs."""
    k = ie.rate_kernel(config)
    x_lo, x_hi, y_lo, y_hi = (np.asarray(v, dtype=float) for v in (x_lo, x_hi, y_lo, y_hi))
    dxg = np.clip(k.gx, x_lo, x_hi) - k.gx
    dyg = np.clip(k.gy, y_lo, y_hi) - k.gy
    zeta = k.k_direct * (dxg * dxg + dyg * dyg + k.z_u2) ** k.d_exp
    if k.has_surface:
        a, b = x_lo - k.x_c, x_hi - k.x_c  # dx interval
        straddle = (a < 0) & (b > 0)
        d_lo = np.where(straddle, 0.0, np.minimum(np.abs(a), np.abs(b)))
        d_hi = np.maximum(np.abs(a), np.abs(b))
        sign = np.where(a >= 0, 1.0, -1.0)  # the rectangle's side when it does not straddle
        side = np.where(straddle, max(1.0, k.t_factor), np.where(sign * k.g_side > 0, 1.0, k.t_factor))
        surface = np.zeros_like(zeta)
        for yj, dz2, c in zip(k.node_y, k.dz2, k.jw, strict=True):
            gap_y = np.maximum(0.0, np.maximum(y_lo - yj, yj - y_hi))
            if c > 0:
                rho = np.sqrt(gap_y * gap_y + dz2)
                surface += c * _phi(np.clip(math.sqrt(3.0) * rho, d_lo, d_hi), rho)
            elif c < 0:
                far = np.maximum(np.abs(y_lo - yj), np.abs(y_hi - yj))
                rho = np.sqrt(far * far + dz2)
                surface += c * np.minimum(_phi(d_lo, rho), _phi(d_hi, rho))
        zeta = zeta + side * np.maximum(surface, 0.0)
    zeta = zeta * (1.0 + ZETA_SLACK)
    return np.log2(1.0 + k.eta * zeta * zeta)


def relaxed_offsets(h: float, d_max: float) -> np.ndarray:
    """Cell offsets (dy, dx) whose squares (side h) are at most ``d_max`` apart."""
    r = math.floor(d_max / h) + 1
    dy, dx = np.mgrid[-r : r + 1, -r : r + 1]
    gap2 = np.maximum(0, np.abs(dx) - 1) ** 2 + np.maximum(0, np.abs(dy) - 1) ** 2
    inside = gap2 * h * h <= d_max * d_max * (1 + 1e-12)
    return np.column_stack([dy[inside], dx[inside]])


def check_relaxed_grid(
    config: ScenarioConfig, resolution: float, margin: float = DEFAULT_MARGIN, moving: bool = False
) -> None:
    """``ValueError`` when :class:`RelaxedDP`'s arrays at cell side ``resolution`` would exceed
    ``baselines.grid.MAX_TABLE_BYTES``: the float32 table of N - 2 layers, the K cell bounds (per
    slot with ``moving`` nodes) and the per-cell geometry."""
    per_cell = 4 * max(config.N - 2, 0) + 8 * (config.K * (config.N if moving else 1) + 8)
    check_grid_bytes(
        config, resolution, margin, per_cell, "relaxed DP (N - 2 float32 layers)", "bound_resolution"
    )


def check_plain_grid(
    config: ScenarioConfig, resolution: float, margin: float = DEFAULT_MARGIN, moving: bool = False
) -> None:
    """``ValueError`` when the plain grid DP's arrays (``baselines.grid.grid_path``'s float64
    table of N - 2 layers and the K node rate maps, per slot with ``moving`` nodes) would exceed
    ``MAX_TABLE_BYTES``."""
    per_cell = 8 * max(config.N - 2, 0) + 8 * (config.K * (config.N if moving else 1) + 4)
    check_grid_bytes(
        config, resolution, margin, per_cell, "plain DP (N - 2 float64 layers)", largest=config.D
    )


class RelaxedDP:
    """The relaxed DP of the module docstring for one config and cell size: :meth:`value`.

    ``paths`` (N, K, 2) m: the nodes' true paths (module docstring, "Moving nodes"); the cell
    bounds are then per slot, ``cell_bounds`` (N, K, ny, nx) and ``out_bounds`` (N, K), else
    (1, K, ny, nx) and (1, K)."""

    def __init__(
        self,
        config: ScenarioConfig,
        resolution: float,
        margin: float = DEFAULT_MARGIN,
        paths: np.ndarray | None = None,
    ):
        from baselines.tour import moving_paths

        if not (isinstance(resolution, (int, float)) and math.isfinite(resolution) and resolution > 0):
            raise ValueError(f"resolution must be a finite number > 0 (m), got {resolution!r}")
        moving = moving_paths(config, paths)
        check_relaxed_grid(config, resolution, margin, moving is not None)
        self.config, self.h, self.paths = config, float(resolution), moving
        xs, ys, _ = grid_axes(config, self.h, margin)
        self.xs, self.ys = xs, ys
        h2 = 0.5 * self.h
        xx, yy = np.meshgrid(xs, ys)
        # the single-node configs of each slot (one slot for static nodes), shared where a node stays
        slots = [[config.node_config(k) for k in range(config.K)]] if moving is None else [
            [node_config_at(config, k, moving[n, k]) for k in range(config.K)] for n in range(config.N)
        ]  # fmt: skip
        cache: dict[ScenarioConfig, np.ndarray] = {}
        for c in {c for row in slots for c in row}:
            cache[c] = region_rate_bound(c, xx - h2, xx + h2, yy - h2, yy + h2)
        self.cell_bounds = np.stack([np.stack([cache[c] for c in row]) for row in slots])
        bx0, bx1, by0, by1 = xs[0] - h2, xs[-1] + h2, ys[0] - h2, ys[-1] + h2
        # O is the part of the plane outside B the UAV can reach: nothing beyond a side of B
        # that the reach box clipped (baselines.grid.grid_box), so only the other sides open
        self.open_sides = np.array(grid_box(config, margin)) == np.array(scene_box(config, margin))
        inf = np.inf
        halves = np.array([[-inf, bx0, -inf, inf], [bx1, inf, -inf, inf], [-inf, inf, -inf, by0],
                           [-inf, inf, by1, inf]])[self.open_sides]  # fmt: skip
        if len(halves):
            out = {c: region_rate_bound(c, *halves.T).max() for c in cache}
            self.out_bounds = np.array([[out[c] for c in row] for row in slots])
        else:  # O is never allowed (o0 = of = inf below); any finite reward keeps the DP's arithmetic
            self.out_bounds = np.zeros((len(slots), config.K))
        ends = np.array([config.q0, config.qF], dtype=float)
        end_paths = None if moving is None else moving[[0, -1]]
        self.end_rates = ie.node_rates(config, ends, end_paths)  # (K, 2): exact rewards of slots 1 and N
        ny, nx = xx.shape
        iy, ix = np.mgrid[0:ny, 0:nx]
        to_side = np.stack([ix, nx - 1 - ix, iy, ny - 1 - iy])[self.open_sides]  # cells to each open side
        self.band = (to_side.min(axis=0) * self.h <= config.D) if len(to_side) else np.zeros(xx.shape, bool)
        self.offsets = relaxed_offsets(self.h, config.D)
        self.d0 = np.hypot(
            np.maximum(0, np.abs(xx - ends[0, 0]) - h2), np.maximum(0, np.abs(yy - ends[0, 1]) - h2)
        )
        self.df = np.hypot(
            np.maximum(0, np.abs(xx - ends[1, 0]) - h2), np.maximum(0, np.abs(yy - ends[1, 1]) - h2)
        )
        gaps = np.array([[e[0] - bx0, bx1 - e[0], e[1] - by0, by1 - e[1]] for e in ends])[:, self.open_sides]
        self.o0, self.of = (float(g.min()) if g.size else inf for g in gaps)

    def _allowed(self, n: int) -> tuple[np.ndarray, bool]:
        """Cells and O allowed at slot n (1-based): the time windows."""
        c, tol = self.config, 1e-9
        reach0, reachf = (n - 1) * c.D * (1 + tol), (c.N - n) * c.D * (1 + tol)
        return (self.d0 <= reach0) & (self.df <= reachf), bool(self.o0 <= reach0 and self.of <= reachf)

    def value(self, w: np.ndarray) -> tuple[float, np.ndarray]:
        """(UB(w) >= every feasible trajectory's score, the cut G with UB(w') >= G . w')."""
        c = self.config
        w = np.asarray(w, dtype=float)
        rewards = np.max(w[None, :, None, None] * self.cell_bounds, axis=1)  # (1 or N, ny, nx)
        r_outs = np.max(w * self.out_bounds, axis=1)  # (1 or N,)

        def at(n: int) -> tuple[np.ndarray, float]:  # the rewards of 0-based slot n
            j = 0 if self.paths is None else n
            return rewards[j], float(r_outs[j])

        f0, ff = np.max(w[:, None] * self.end_rates, axis=0)
        if c.N == 2:
            return (f0 + ff) / 2, self._cut(w, [])
        n_layers = c.N - 2  # slots 2..N-1
        table = np.empty((n_layers, *rewards.shape[1:]), dtype=np.float32)
        outside = np.full(n_layers, -np.inf)
        cells, o_ok = self._allowed(c.N - 1)
        reward, r_out = at(c.N - 2)
        v = np.where(cells, reward + ff, -np.inf)
        vo = r_out + ff if o_ok else -np.inf
        table[-1], outside[-1] = v, vo
        for i in range(n_layers - 2, -1, -1):
            cells, o_ok = self._allowed(i + 2)
            reward, r_out = at(i + 1)
            best_next = disk_max(v, self.offsets)
            best_next = np.where(self.band, np.maximum(best_next, vo), best_next)
            band_max = float(np.max(np.where(self.band, v, -np.inf)))
            vo = r_out + max(vo, band_max) if o_ok else -np.inf
            v = np.where(cells, reward + best_next, -np.inf)
            table[i], outside[i] = v, vo
        first = max(float(np.max(v)), vo)
        path = self._path(table, outside)
        return (f0 + first) / c.N, self._cut(w, path)

    def _path(self, table: np.ndarray, outside: np.ndarray) -> list[tuple[int, int] | None]:
        """A best state sequence of slots 2..N-1 (None = O), recovered from the float32 table
        (ties or rounding may pick a slightly worse path: its cut is still valid)."""
        first = np.unravel_index(int(np.argmax(table[0])), table[0].shape)
        state: tuple[int, int] | None = (int(first[0]), int(first[1]))
        if outside[0] > table[0][state]:
            state = None
        path = [state]
        for i in range(1, len(table)):
            if state is None:
                band_vals = np.where(self.band, table[i], -np.inf)
                j = np.unravel_index(int(np.argmax(band_vals)), band_vals.shape)
                state = None if outside[i] >= band_vals[j] else (int(j[0]), int(j[1]))
            else:
                nxt = _best_move(table[i], state, self.offsets)
                if self.band[state] and (nxt is None or outside[i] > table[i][nxt]):
                    nxt = None
                state = nxt
            path.append(state)
        return path

    def _cut(self, w: np.ndarray, path: list[tuple[int, int] | None]) -> np.ndarray:
        """G with G . w' = (1/N) sum_n w'_{k_n} Rbar_{k_n}(s_n) (k_n best at w) <= UB(w')."""
        g = np.zeros(self.config.K)
        rewards = [self.end_rates[:, 0], self.end_rates[:, 1]]
        for i, s in enumerate(path):  # layer i is 0-based slot i + 1
            j = 0 if self.paths is None else i + 1
            rewards.append(self.out_bounds[j] if s is None else self.cell_bounds[j][:, s[0], s[1]])
        for r in rewards:
            k = int(np.argmax(w * r))
            g[k] += r[k]
        return g / self.config.N


def weighted_dp_path(
    config: ScenarioConfig, weights: np.ndarray, resolution: float = 5.0, margin: float = DEFAULT_MARGIN
) -> np.ndarray | None:
    """The plain grid DP's best path for the per-slot reward f_w = max_k w_k r_k (moves <= D
    between grid points; ``baselines.grid.grid_path``): a feasible trajectory, or None when no
    grid path reaches qF in time."""
    check_plain_grid(config, resolution, margin)
    w = np.asarray(weights, dtype=float)
    xs, ys, _ = grid_axes(config, resolution, margin)
    xx, yy = np.meshgrid(xs, ys)
    rates = ie.node_rates(config, np.column_stack([xx.ravel(), yy.ravel()])).reshape(config.K, *xx.shape)
    r_f = float(np.max(w * ie.node_rates(config, np.array([config.qF]))[:, 0]))
    try:
        return grid_path(config, np.max(w[:, None, None] * rates, axis=0), r_f, resolution, margin)[0]
    except ValueError:
        return None


def moving_rate_maps(config: ScenarioConfig, paths: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """(N, K, ny, nx) bps/Hz: r_k(grid point; w_k[n]) for every slot n (one map per distinct
    node position, ``node_config_at``)."""
    xx, yy = np.meshgrid(xs, ys)
    points = np.column_stack([xx.ravel(), yy.ravel()])
    out = np.empty((config.N, config.K, *xx.shape))
    maps: dict[ScenarioConfig, np.ndarray] = {}
    for n in range(config.N):
        for k in range(config.K):
            c = node_config_at(config, k, paths[n, k])
            if c not in maps:
                maps[c] = ie.slot_rates(c, points).reshape(xx.shape)
            out[n, k] = maps[c]
    return out


def moving_dp_path(
    config: ScenarioConfig, rewards: np.ndarray, resolution: float, margin: float = DEFAULT_MARGIN
) -> np.ndarray | None:
    """The best grid path for a reward map per slot, ``rewards`` (N, ny, nx) on the grid of
    ``baselines.grid.grid_axes`` (slot 1 at q0, slot N at qF; their rewards are fixed): the DP
    of ``baselines.grid.grid_path`` with layer n's reward taken from slot n. A feasible
    trajectory (N, 2) (moves <= D between grid points, the last one onto qF), or None when no
    grid path reaches qF in time."""
    n_slots, d_max = config.N, config.D
    xs, ys, (iy0, ix0) = grid_axes(config, resolution, margin)
    if rewards.shape != (n_slots, len(ys), len(xs)):
        raise ValueError(
            f"rewards must have shape (N, ny, nx) = {(n_slots, len(ys), len(xs))}, got {rewards.shape}"
        )
    q_f = np.asarray(config.qF, dtype=float)
    if n_slots == 2:
        return np.vstack([np.asarray(config.q0, dtype=float), q_f])
    offsets = disk_offsets(resolution, d_max)
    values = np.empty((n_slots - 2, len(ys), len(xs)))  # values[j]: layer of 0-based slot j + 1
    near_f = np.hypot(xs[None, :] - q_f[0], ys[:, None] - q_f[1]) <= d_max
    values[-1] = np.where(near_f, rewards[n_slots - 2], -np.inf)
    for j in range(n_slots - 4, -1, -1):
        values[j] = rewards[j + 1] + disk_max(values[j + 1], offsets)
    first = _best_move(values[0], (iy0, ix0), offsets)
    if first is None:
        return None
    path = [(iy0, ix0), first]
    for j in range(1, n_slots - 2):
        path.append(_best_move(values[j], path[-1], offsets))
    idx = np.array(path)
    return np.vstack([np.column_stack([xs[idx[:, 1]], ys[idx[:, 0]]]), q_f])


def hover_points(paths: list[np.ndarray], limit: int) -> list[tuple[str, tuple[float, float]]]:
    """The ``limit`` longest hovers (way-points repeated in consecutive slots) of the paths."""
    stays: dict[tuple[float, float], int] = {}
    for q in paths:
        same = np.all(np.diff(q, axis=0) == 0, axis=1)
        for n in np.flatnonzero(same):
            key = (float(q[n, 0]), float(q[n, 1]))
            stays[key] = stays.get(key, 0) + 1
    ranked = sorted(stays, key=lambda p: -stays[p])[:limit]
    return [(f"dp-hover({p[0]:g},{p[1]:g})", p) for p in ranked]


def _kelley_step(cuts: list[np.ndarray]) -> tuple[np.ndarray, float]:
    """argmin and min over the simplex of max_i G_i . w (an LP)."""
    from scipy.optimize import linprog

    g = np.array(cuts)
    k = g.shape[1]
    c = np.zeros(k + 1)
    c[-1] = 1.0
    a_ub = np.hstack([g, -np.ones((len(g), 1))])
    a_eq = np.hstack([np.ones((1, k)), np.zeros((1, 1))])
    res = linprog(c, A_ub=a_ub, b_ub=np.zeros(len(g)), A_eq=a_eq, b_eq=[1.0],
                  bounds=[(0, None)] * k + [(None, None)], method="highs")  # fmt: skip
    if res.status != 0:
        raise RuntimeError(f"Kelley LP failed: {res.message}")
    w = np.maximum(res.x[:k], 0.0)
    return w / w.sum(), float(res.fun)


def solve_multinode(
    config: ScenarioConfig,
    *,
    resolution: float = 2.5,
    margin: float = DEFAULT_MARGIN,
    bound_resolution: float | None = None,
    max_cuts: int = MAX_CUTS,
    tol: float = CUT_TOL,
    start_weights: np.ndarray | None = None,
    progress: bool = False,
    paths: np.ndarray | None = None,
) -> Plan:
    """K > 1: the best DP plan found and the certified upper bound (module docstring).

    ``paths`` (N, K, 2) m: the nodes' true paths, known in advance (module docstring, "Moving
    nodes"): the clairvoyant bound, with the clairvoyant tour as the plan (scored on the paths).

    ``resolution``: grid of the plain DPs (the plans); ``bound_resolution``: cell side of
    the relaxed DP (default ``resolution``); ``max_cuts``, ``tol``: Kelley's iterations and
    relative stopping gap; ``start_weights``: the first w (default: the tour's dual weights).
    ``info``: ``upper_bound`` (>= every feasible trajectory's max-min rate), ``weights`` (its
    w), ``kelley_lower`` (no w gives a bound below it on this grid), ``gap`` (upper_bound /
    mean_rate - 1; inf when the plan scores 0 below a positive bound), ``cuts`` (per iteration:
    w, UB(w), plan score), ``resolution``, ``bound_resolution``.
    """
    t0 = time.perf_counter()
    check_planner("dp-bound", config, paths)
    validate_grid_args(config, resolution, margin)
    if config.K < 2:
        raise ValueError(f"solve_multinode needs K >= 2 ground nodes, got K={config.K}")
    if not (isinstance(max_cuts, int) and max_cuts >= 1):
        raise ValueError(f"max_cuts must be an integer >= 1, got {max_cuts!r}")
    h = resolution if bound_resolution is None else bound_resolution
    if not (isinstance(h, (int, float)) and math.isfinite(h) and h > 0):
        raise ValueError(f"bound_resolution must be a finite number > 0 (m), got {h!r}")
    from baselines import tour

    moving = tour.moving_paths(config, paths)
    # every grid is sized before anything is computed: the plain DPs', the relaxed DP's, the tour's
    check_plain_grid(config, resolution, margin, moving is not None)
    check_relaxed_grid(config, h, margin, moving is not None)
    tour.check_candidate_grid(config)

    tour_plan = tour.solve(config, paths=moving)
    if start_weights is None:
        start_weights = ie.schedule(config, tour_plan.trajectory, moving).weights
    w = np.asarray(start_weights, dtype=float)
    if w.shape != (config.K,) or not (np.all(w >= 0) and abs(w.sum() - 1) < 1e-9):
        raise ValueError(f"start_weights must be K={config.K} numbers >= 0 summing to 1, got {w!r}")
    relaxed = RelaxedDP(config, h, margin, moving)
    xs, ys, _ = grid_axes(config, resolution, margin)
    xx, yy = np.meshgrid(xs, ys)
    if moving is None:
        centre_rates = ie.node_rates(config, np.column_stack([xx.ravel(), yy.ravel()]))
        centre_rates = centre_rates.reshape(config.K, *xx.shape)
    else:  # (N, K, ny, nx): the grid's rate maps of every slot
        centre_rates = moving_rate_maps(config, moving, xs, ys)
    rf = ie.node_rates(config, np.array([config.qF]))[:, 0]
    cuts: list[np.ndarray] = []
    records: list[dict[str, Any]] = []
    best_ub, best_w, lower = math.inf, w, -math.inf
    best_plan: tuple[float, np.ndarray, str] | None = None
    dp_paths: list[np.ndarray] = []
    for it in range(max_cuts):
        ub, g = relaxed.value(w)
        cuts.append(g)
        if ub < best_ub:
            best_ub, best_w = ub, w
        score, traj = None, None
        if moving is None:
            try:
                reward = np.max(w[:, None, None] * centre_rates, axis=0)
                traj, _ = grid_path(config, reward, float(np.max(w * rf)), resolution, margin)
            except ValueError:  # no grid path in time on this grid: the bound still holds
                traj = None
        else:  # the per-slot rewards f_w^n
            traj = moving_dp_path(
                config, np.max(w[None, :, None, None] * centre_rates, axis=1), resolution, margin
            )
        if traj is not None:
            dp_paths.append(traj)
            score = ie.maxmin_rate(config, traj, moving)
            if best_plan is None or score > best_plan[0]:
                best_plan = (score, traj, f"dp{it}")
        records.append({"iteration": it, "weights": w.tolist(), "upper_bound": ub, "plan_score": score})
        w, lower = _kelley_step(cuts)
        if progress:
            print(f"[dp-bound] it {it:2d}: UB(w) {ub:.6f}  best UB {best_ub:.6f}  Kelley lower {lower:.6f}")
        if best_ub - lower <= tol * best_ub:
            break
    if best_plan is None and moving is None:  # (with moving nodes the tour's plan stands in)
        raise ValueError(f"no grid path reaches qF in time at resolution={resolution:g} m: use a finer grid")
    # the DP paths hover where some f_w peaks: routes through those points (and the nodes'
    # peaks) mix them; the tour heuristic's own plan competes too
    peaks = [(n, p) for n, p in tour_plan.info["candidates"].items() if n.startswith("peak")]
    routed = tour.solve(config, candidates=peaks + hover_points(dp_paths, config.K), paths=moving)
    if best_plan is None:  # moving nodes with no grid path in time: the tours' plans
        best_plan = (-math.inf, tour_plan.trajectory, "tour")
    for source, plan in (("tour", tour_plan), ("tour-dp-hovers", routed)):
        if plan.mean_rate > best_plan[0]:
            best_plan = (plan.mean_rate, plan.trajectory, source)
    info = {
        "upper_bound": best_ub,
        "weights": best_w.tolist(),
        "kelley_lower": lower,
        "cuts": records,
        "resolution": float(resolution),
        "bound_resolution": float(h),
        "margin": float(margin),
        "plan_source": best_plan[2],
    }
    plan = tour.plan_on_paths("dp", config, best_plan[1], time.perf_counter() - t0, moving, info)
    if plan.mean_rate > 0:
        plan.info["gap"] = best_ub / plan.mean_rate - 1.0
    else:  # a node no reachable point serves: the plan scores 0
        plan.info["gap"] = 0.0 if best_ub <= 0 else math.inf
    return plan


def clairvoyant_bound(
    config: ScenarioConfig,
    paths: np.ndarray | None,
    *,
    resolution: float = 2.5,
    margin: float = DEFAULT_MARGIN,
    **kwargs: Any,
) -> float:
    """The certified upper bound (bps/Hz) of the frame's score given the nodes' ``paths``
    (N, K, 2) m in advance (None: the configured positions): no flight, and so no online
    policy, scores more on those paths. K = 1: the relaxed DP at w = (1,) (the single node's
    average rate; module docstring, "Moving nodes"); K > 1: :func:`solve_multinode`'s
    ``upper_bound`` (``kwargs`` go to it)."""
    check_planner("dp-bound", config, paths)
    validate_grid_args(config, resolution, margin)
    if config.K == 1:
        if paths is not None:
            check_paths(config, paths)
        return RelaxedDP(config, resolution, margin, paths).value(np.ones(1))[0]
    return solve_multinode(config, resolution=resolution, margin=margin, paths=paths, **kwargs).info[
        "upper_bound"
    ]
