r"""The relaxed DP behind the several-node bound of ``baselines.dp_bound``: a certified upper
bound of max over feasible continuous trajectories of (1/N) sum_n f_w(q[n]), f_w(q) = max_k
w_k r_k(q), for one weight vector w (per slot with moving nodes: ``baselines.dp_bound``,
"Moving nodes").

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
"""

from __future__ import annotations

import math

import numpy as np

import ios_uav_env as ie
from baselines.grid import (
    DEFAULT_MARGIN,
    _best_move,
    check_grid_bytes,
    disk_max,
    grid_axes,
    grid_box,
)
from ios_uav_env import ScenarioConfig, scene_box
from ios_uav_env.model.motion import node_config_at

#: Relative slack on the amplitude bound (floating-point rounding of the model's sums).
ZETA_SLACK = 1e-9

__all__ = ["RelaxedDP", "check_plain_grid", "check_relaxed_grid", "region_rate_bound", "relaxed_offsets"]


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

    ``paths`` (N, K, 2) m: the nodes' true paths (``baselines.dp_bound``, "Moving nodes"); the cell
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
        """(UB(w) >= every feasible trajectory's score, the cut G with UB(w') >= G . w'); the
        states' rewards are :meth:`reward`'s."""
        c = self.config
        w = np.asarray(w, dtype=float)
        rewards = self.reward(w, np.moveaxis(self.cell_bounds, 1, 0))  # (1 or N, ny, nx)
        r_outs = self.reward(w, self.out_bounds.T)  # (1 or N,)

        def at(n: int) -> tuple[np.ndarray, float]:  # the rewards of 0-based slot n
            j = 0 if self.paths is None else n
            return rewards[j], float(r_outs[j])

        f0, ff = self.reward(w, self.end_rates)
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
        """G = (1/N) sum_n p_n (:meth:`point` of state s_n at w), G . w' <= UB(w')."""
        g = np.zeros(self.config.K)
        rewards = [self.end_rates[:, 0], self.end_rates[:, 1]]
        for i, s in enumerate(path):  # layer i is 0-based slot i + 1
            j = 0 if self.paths is None else i + 1
            rewards.append(self.out_bounds[j] if s is None else self.cell_bounds[j][:, s[0], s[1]])
        for r in rewards:
            g += self.point(w, r)
        return g / self.config.N

    def reward(self, w: np.ndarray, bounds: np.ndarray) -> np.ndarray:
        """A state's reward at w from its K rate bounds ``bounds`` (K, ...): max_k w_k Rbar_k, the
        bound of f_w = max_k w_k r_k (one node per slot share). A subclass with another slot model
        overrides this and :meth:`point` (``baselines.dp_star``)."""
        return np.max(w.reshape((-1,) + (1,) * (bounds.ndim - 1)) * bounds, axis=0)

    def point(self, w: np.ndarray, bounds: np.ndarray) -> np.ndarray:
        """A state's cut vector p (K,) from its rate bounds (K,): w . p is its reward at w and
        w' . p <= its reward at every w' (here Rbar_k on the node k of largest w_k Rbar_k)."""
        k = int(np.argmax(w * bounds))
        p = np.zeros_like(bounds)
        p[k] = bounds[k]
        return p
