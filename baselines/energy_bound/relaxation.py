r"""The relaxation's cells, its move costs and slot penalties, and the multipliers b.

:class:`CellRelaxation` builds the cells and every cost of a relaxed move; its subclass
``baselines.energy_bound.EnergyRelaxation`` adds U(mu) and Dinkelbach's iteration (the package
docstring, ``baselines.energy_bound``).

**The cells.** Fine squares of side h (``resolution``) cover the grid box of the DP planners
(``baselines.grid.grid_box``, rounded out to whole coarse cells); coarse squares of side k h,
k the largest odd number with k h <= D (:func:`coarse_factor`), cover the rest of the reach box
(``baselines.grid.reach_box``, which holds every way-point of every feasible plan). A feasible
q maps slot by slot to the cell holding q[n]; q[1] = q0 and q[N] = qF stay points. A relaxed
path moves between cells whose squares are at most D apart, keeps the time windows (at slot n
a cell within (n - 1) D of q0 and (N - n) D of qF), and earns per slot Rbar(cell) >= the sup
of the slot rate over the cell (``baselines.dp_bound.region_rate_bound``), and the exact rates
at q0 and qF.

**The energy of a relaxed path: multipliers on the moves.** Write q[n] = c_n + e_n for a slot
in the cell of centre c_n and side w_n, |e_n|_inf <= w_n / 2, and e = 0 at q0 and qF. Move n is
m_n = g_n + delta_n with g_n = c_{n+1} - c_n and delta_n = e_{n+1} - e_n. For any vectors b_n
(the *multipliers*, one per move, J/m), summation by parts gives

    E(q) = sum_n [f(m_n) - b_n . delta_n] + sum_{n=2}^{N-1} e_n . (b_{n-1} - b_n)

(the e's of q0 and qF are 0). Each bracket is >= the *move cost* C(g_n, w, b_n) = min over m in
the box g_n + [-w, w]^2 with |m| <= D of f(m) - b_n . (m - g_n), w = (w_n + w_{n+1}) / 2 (the
side of a point q0 or qF being 0), and e_n . a >= -(w_n / 2) |a|_1. So

    L(p) = sum_n C(g_n, w, b_n) - sum_{n=2}^{N-1} (w_n / 2) |b_{n-1} - b_n|_1 <= E(q)

for every q of p. With b = 0 this is the plain bound: each move costs the least energy the two
squares allow, and a path of relaxed moves can travel up to ~sqrt(2) h per slot farther than
its centres for that energy, an error of first order in h that adds up along the legs. With b_n
the energy gradient along a good plan the bracket is stationary at that plan's move, so the
error is of second order in h where the relaxed path follows it; the b's telescope on a
straight leg and the penalty charges only their changes (:func:`multipliers`: a weighted moving
average of a reference plan's gradient, whose weights cancel the gradient of an oscillating
loiter, about 0 at the minimum-power speed anyway). Where the relaxed path does not follow the
reference (it hovers while b is large, say), the bracket's minimum saves up to about |b| h per
move, a first-order error again; so :func:`solve` tries a few scalings of b, and b = 0, and
keeps the smallest bound (each is certified). :meth:`EnergyRelaxation.image` maps a trajectory
to its relaxed path (a test of the two inequalities).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

import ios_uav_env as ie
from baselines.dp_bound import region_rate_bound, relaxed_offsets
from baselines.energy_bound.lower_bounds import check_terms, move_cost_lower_bound, power_slope
from baselines.grid import DEFAULT_MARGIN, MAX_TABLE_BYTES, grid_box, reach_box
from ios_uav_env import ScenarioConfig

#: Default window of the weighted moving average that makes the multipliers (even, >= 2).
DEFAULT_WINDOW = 12
#: The multipliers are rounded to this fraction of the largest gradient component.
MULTIPLIER_STEP = 1.0 / 16.0
#: Smallest sub-box (fraction of the box's half-width) of the fine-coarse moves' costs.
INTERFACE_SPLIT = 0.5


def multipliers(config: ScenarioConfig, reference: Any = None, window: int = DEFAULT_WINDOW) -> np.ndarray:
    """The move multipliers b (N - 1, 2) (J/m): the centred weighted moving average (weights
    1, 2, ..., 2, 1 over ``window`` + 1 moves, fewer at the ends) of the energy gradient
    P'(V_n) m_n / |m_n| of the ``reference`` trajectory (N, 2) or Plan (0 for a move of length
    0), rounded to ``MULTIPLIER_STEP`` of its largest component; zeros when ``reference`` is
    None. Any b gives a valid bound; this one makes it tight where the reference is good."""
    n_moves = config.N - 1
    if reference is None:
        return np.zeros((n_moves, 2))
    q = np.asarray(getattr(reference, "trajectory", reference), dtype=float)
    if q.shape != (config.N, 2) or not np.all(np.isfinite(q)):
        raise ValueError(
            f"reference must be a finite (N={config.N}, 2) trajectory or a Plan, got shape {q.shape}"
        )
    if isinstance(window, bool) or not isinstance(window, (int, np.integer)) or window < 2 or window % 2:
        raise ValueError(f"window must be an even integer >= 2 (moves), got {window!r}")
    k = check_terms(config)
    m = np.diff(q, axis=0)
    length = np.linalg.norm(m, axis=1)
    unit = np.where(length[:, None] > 0, m / np.where(length > 0, length, 1.0)[:, None], 0.0)
    grad = power_slope(length / config.dt, k)[:, None] * unit
    # the kernel [1, 2, ..., 2, 1] cancels a sign flip every move exactly (an oscillating loiter)
    kernel = np.r_[1.0, np.full(int(window) - 1, 2.0), 1.0]
    counts = np.convolve(np.ones(n_moves), kernel, mode="same")
    b = np.column_stack([np.convolve(grad[:, j], kernel, mode="same") / counts for j in range(2)])
    # rounded to a few levels (any b is valid): the move costs are computed once per distinct b,
    # and what is left of a cancelled gradient (rounding) becomes 0
    step = MULTIPLIER_STEP * float(np.max(np.abs(grad))) if grad.size else 0.0
    return np.round(b / step) * step if step > 0 else np.zeros_like(b)


# --- the relaxation ---------------------------------------------------------------------------------


def coarse_factor(config: ScenarioConfig, resolution: float) -> int:
    """k, the odd number of fine cells per side of a coarse cell: the largest odd k with
    k h <= D (at least 1), so a coarse cell is about a move wide."""
    k = int(math.floor(config.D / resolution + 1e-9))
    return max(1, k if k % 2 else k - 1)


@dataclass
class _Grid:
    """Square cells of side ``side`` (m) centred at ``xs`` x ``ys``: which are states of the
    relaxation (a coarse cell inside the fine region is not), their rate bounds and their
    distances to q0 and qF."""

    side: float
    xs: np.ndarray
    ys: np.ndarray
    state: np.ndarray  # (ny, nx) bool
    reward: np.ndarray = field(default_factory=lambda: np.empty(0))  # (ny, nx) bps/Hz, Rbar
    d0: np.ndarray = field(default_factory=lambda: np.empty(0))  # (ny, nx) m, q0 to the square
    df: np.ndarray = field(default_factory=lambda: np.empty(0))  # (ny, nx) m, qF to the square

    @property
    def centres(self) -> np.ndarray:
        xx, yy = np.meshgrid(self.xs, self.ys)
        return np.stack([xx, yy], axis=-1)

    def fill(self, config: ScenarioConfig) -> None:
        """Compute the rate bounds and the distances to q0 and qF."""
        cen, half = self.centres, 0.5 * self.side
        x, y = cen[..., 0], cen[..., 1]
        self.reward = region_rate_bound(config, x - half, x + half, y - half, y + half)
        self.d0 = _square_distance(np.asarray(config.q0, float), cen, half)
        self.df = _square_distance(np.asarray(config.qF, float), cen, half)


def _square_distance(p: np.ndarray, centres: np.ndarray, half: float) -> np.ndarray:
    """Distance (m) from the point p to each square of half-side ``half`` at ``centres`` (..., 2)."""
    gap = np.maximum(0.0, np.abs(centres - p) - half)
    return np.hypot(gap[..., 0], gap[..., 1])


class CellRelaxation:
    """The cells, move costs and slot penalties of the relaxation for one config, cell side and
    multipliers b (module docstring), and :meth:`image`; ``EnergyRelaxation`` solves it."""

    def __init__(
        self,
        config: ScenarioConfig,
        resolution: float,
        margin: float = DEFAULT_MARGIN,
        b: np.ndarray | None = None,
    ):
        if not isinstance(config, ScenarioConfig):
            raise TypeError(f"config must be a ScenarioConfig, got {type(config).__name__}")
        config.require_single_node("the energy-efficiency bound")
        if not (
            isinstance(resolution, (int, float)) and math.isfinite(resolution) and 0 < resolution <= config.D
        ):
            raise ValueError(
                f"resolution must be a finite number in (0, D={config.D:g}] m, got {resolution!r}"
            )
        if not (isinstance(margin, (int, float)) and math.isfinite(margin) and margin >= 0):
            raise ValueError(f"margin must be a finite number >= 0 (m), got {margin!r}")
        c, h = config, float(resolution)
        self.config, self.h = c, h
        self.b = np.zeros((c.N - 1, 2)) if b is None else np.asarray(b, dtype=float)
        if self.b.shape != (c.N - 1, 2) or not np.all(np.isfinite(self.b)):
            raise ValueError(
                f"b must be finite multipliers of shape (N - 1 = {c.N - 1}, 2), got {self.b.shape}"
            )
        check_terms(c)
        q0, qf = np.asarray(c.q0, float), np.asarray(c.qF, float)
        self.r0, self.rf = (float(r) for r in ie.slot_rates(c, np.array([q0, qf])))
        # N = 2: the one move q0 -> qF, exactly
        self.direct_cost = c.dt * float(ie.propulsion_power(math.dist(c.q0, c.qF) / c.dt, c.propulsion))
        if c.N < 3:
            return
        self.fine, self.coarse = self._grids(margin)
        self._check_size()
        self.fine.fill(c)
        self.coarse.fill(c)
        self._costs()

    def _grids(self, margin: float) -> tuple[_Grid, _Grid]:
        c, h = self.config, self.h
        k = coarse_factor(c, h)
        big = k * h
        x0, y0 = c.q0
        r_lo_x, r_hi_x, r_lo_y, r_hi_y = reach_box(c)
        g_lo_x, g_hi_x, g_lo_y, g_hi_y = grid_box(c, margin)

        def span(lo: float, hi: float, origin: float) -> tuple[int, int]:  # coarse indices meeting [lo, hi]
            return math.ceil((lo - origin) / big - 0.5), math.floor((hi - origin) / big + 0.5)

        cx0, cx1 = span(min(r_lo_x, g_lo_x), max(r_hi_x, g_hi_x), x0)
        cy0, cy1 = span(min(r_lo_y, g_lo_y), max(r_hi_y, g_hi_y), y0)
        fx0, fx1 = span(g_lo_x, g_hi_x, x0)
        fy0, fy1 = span(g_lo_y, g_hi_y, y0)
        cxs, cys = x0 + big * np.arange(cx0, cx1 + 1), y0 + big * np.arange(cy0, cy1 + 1)
        state = np.ones((len(cys), len(cxs)), dtype=bool)
        state[fy0 - cy0 : fy1 - cy0 + 1, fx0 - cx0 : fx1 - cx0 + 1] = False  # the fine region
        coarse = _Grid(big, cxs, cys, state)
        half_k = (k - 1) // 2
        fxs = x0 + h * np.arange(k * fx0 - half_k, k * fx1 + half_k + 1)
        fys = y0 + h * np.arange(k * fy0 - half_k, k * fy1 + half_k + 1)
        fine = _Grid(h, fxs, fys, np.ones((len(fys), len(fxs)), dtype=bool))
        self.k, self.fine_origin = k, (fy0 - cy0, fx0 - cx0)  # the fine region's first coarse cell
        return fine, coarse

    def _check_size(self) -> None:
        c = self.config
        cells = self.fine.state.size + self.coarse.state.size
        needed = 8 * max(c.N - 2, 0) * cells
        if needed > MAX_TABLE_BYTES:
            raise ValueError(
                f"resolution={self.h:g} m gives {self.fine.state.size} fine and {self.coarse.state.size} "
                f"coarse cells whose N - 2 float64 layers need {needed / 2**30:.1f} GiB, above "
                f"MAX_TABLE_BYTES={MAX_TABLE_BYTES / 2**30:g} GiB: use a coarser resolution, a smaller "
                "margin or a shorter T"
            )

    def _costs(self) -> None:
        """Every move cost C (module docstring) and every slot penalty, per move k."""
        c, h = self.config, self.h
        big = self.coarse.side
        n = c.N
        interior = np.arange(1, n - 2)  # moves between two free slots
        self.off_f = relaxed_offsets(h, c.D)  # (dy, dx)
        self.off_c = relaxed_offsets(big, c.D)
        # interface: fine cells whose square is within D of a coarse cell's (fine-index offsets u
        # from the coarse centre, which is a fine centre since k is odd)
        r = math.floor((c.D + 0.5 * (h + big)) / h) + 1
        uy, ux = np.mgrid[-r : r + 1, -r : r + 1]
        gap = np.hypot(
            np.maximum(0.0, np.abs(ux) * h - 0.5 * (h + big)),
            np.maximum(0.0, np.abs(uy) * h - 0.5 * (h + big)),
        )
        self.off_i = np.column_stack([uy[gap <= c.D * (1 + 1e-12)], ux[gap <= c.D * (1 + 1e-12)]])
        self._pairs()

        def table(g: np.ndarray, half: float, min_size: float | None = None) -> np.ndarray:
            out = np.zeros((n - 1, len(g)))
            if len(interior) and len(g):
                gg = np.tile(g, (len(interior), 1))
                bb = np.repeat(self.b[interior], len(g), axis=0)
                out[interior] = move_cost_lower_bound(c, gg, half, bb, min_size).reshape(
                    len(interior), len(g)
                )
            return out

        self.cost_f = table(self.off_f[:, ::-1] * h, h)
        self.cost_c = table(self.off_c[:, ::-1] * big, big)
        g_i = self.off_i[:, ::-1] * h  # fine cell -> coarse cell: c_C - c_F = -u h; coarse -> fine: u h
        # the interface's moves are few on any path (its cells lie a margin away from the scene):
        # coarser sub-boxes there
        w_i = 0.5 * (h + big)
        self.cost_fc = table(-g_i, w_i, INTERFACE_SPLIT * w_i)
        self.cost_cf = table(g_i, w_i, INTERFACE_SPLIT * w_i)
        q0, qf = np.asarray(c.q0, float), np.asarray(c.qF, float)
        self.first, self.last = {}, {}
        for name, grid in (("fine", self.fine), ("coarse", self.coarse)):
            cells = grid.centres.reshape(-1, 2)
            half = 0.5 * grid.side
            first = np.full(len(cells), np.inf)
            last = np.full(len(cells), np.inf)
            near0 = grid.d0.ravel() <= c.D * (1 + 1e-9)
            nearf = grid.df.ravel() <= c.D * (1 + 1e-9)
            if near0.any():
                first[near0] = move_cost_lower_bound(c, cells[near0] - q0, half, self.b[0])
            if nearf.any():
                last[nearf] = move_cost_lower_bound(c, qf - cells[nearf], half, self.b[-1])
            self.first[name], self.last[name] = (
                first.reshape(grid.state.shape),
                last.reshape(grid.state.shape),
            )
        jump = np.abs(self.b[0 : n - 2] - self.b[1 : n - 1]).sum(axis=1)  # |b_{k-1} - b_k|_1, k = 1..N-2
        self.pen_f = np.r_[0.0, 0.5 * h * jump]
        self.pen_c = np.r_[0.0, 0.5 * big * jump]

    def _pairs(self) -> None:
        """The interface pairs (fine flat index, coarse flat index, offset index)."""
        fine, coarse, k = self.fine, self.coarse, self.k
        fy0, fx0 = self.fine_origin
        nyf, nxf = fine.state.shape
        # only coarse cells within reach of the fine region (D plus a coarse cell, in coarse cells)
        reach = math.ceil(self.config.D / coarse.side) + 1
        near = np.zeros_like(coarse.state)
        ky, kx = nyf // k, nxf // k  # the fine region's size in coarse cells
        near[max(0, fy0 - reach) : fy0 + ky + reach, max(0, fx0 - reach) : fx0 + kx + reach] = True
        cj, ci = np.nonzero(coarse.state & near)
        half_k = (k - 1) // 2
        # the coarse cell's centre in fine indices (may lie outside the fine grid)
        cy_f, cx_f = (cj - fy0) * k + half_k, (ci - fx0) * k + half_k
        fy = cy_f[:, None] + self.off_i[None, :, 0]
        fx = cx_f[:, None] + self.off_i[None, :, 1]
        inside = (fy >= 0) & (fy < nyf) & (fx >= 0) & (fx < nxf)
        rows, cols = np.nonzero(inside)
        self.pair_f = fy[rows, cols] * nxf + fx[rows, cols]
        self.pair_c = cj[rows] * coarse.state.shape[1] + ci[rows]
        self.pair_o = cols

    def _allowed(self, grid: _Grid, k: int) -> np.ndarray:
        """The cells of ``grid`` allowed at slot k (0-based): within k D of q0 and (N-1-k) D of qF."""
        c, tol = self.config, 1 + 1e-9
        return grid.state & (grid.d0 <= k * c.D * tol) & (grid.df <= (c.N - 1 - k) * c.D * tol)

    def image(self, trajectory: Any) -> tuple[float, float, list[tuple[str, int, int]]]:
        """The relaxed path of a feasible ``trajectory`` (N, 2): (sum Rbar, L, its states), each
        slot mapped to the cell holding it (fine where the fine squares cover it). By the
        construction sum Rbar >= sum_n r(q[n]) and L <= E(q) (module docstring); ``ValueError``
        if a move of the image is not a relaxed move (an infeasible trajectory)."""
        c, q = self.config, np.asarray(trajectory, dtype=float)
        if q.shape != (c.N, 2):
            raise ValueError(f"trajectory must be (N={c.N}, 2), got {q.shape}")
        if c.N == 2:
            return self.r0 + self.rf, self.direct_cost, []
        fine, coarse = self.fine, self.coarse
        states: list[tuple[str, int, int]] = []
        for p in q[1:-1]:
            fx = int(np.clip(np.rint((p[0] - fine.xs[0]) / fine.side), 0, len(fine.xs) - 1))
            fy = int(np.clip(np.rint((p[1] - fine.ys[0]) / fine.side), 0, len(fine.ys) - 1))
            if np.all(np.abs(p - (fine.xs[fx], fine.ys[fy])) <= 0.5 * fine.side * (1 + 1e-12)):
                states.append(("fine", fy, fx))
                continue
            cx = int(np.rint((p[0] - coarse.xs[0]) / coarse.side))
            cy = int(np.rint((p[1] - coarse.ys[0]) / coarse.side))
            states.append(("coarse", cy, cx))
        grids = {"fine": fine, "coarse": coarse}
        rates = self.r0 + self.rf + sum(float(grids[s[0]].reward[s[1], s[2]]) for s in states)
        cost = float(self.first[states[0][0]][states[0][1:]]) + float(
            self.last[states[-1][0]][states[-1][1:]]
        )
        half_k = (self.k - 1) // 2
        fy0, fx0 = self.fine_origin
        columns = {
            "fine": {tuple(o): j for j, o in enumerate(self.off_f.tolist())},
            "coarse": {tuple(o): j for j, o in enumerate(self.off_c.tolist())},
            "interface": {tuple(o): j for j, o in enumerate(self.off_i.tolist())},
        }
        for k in range(1, c.N - 1):
            name, y, x = states[k - 1]
            cost -= float((self.pen_f if name == "fine" else self.pen_c)[k])
            if k == c.N - 2:
                break
            nxt = states[k]
            try:
                if nxt[0] == name:
                    j = columns[name][(nxt[1] - y, nxt[2] - x)]
                    cost += float((self.cost_f if name == "fine" else self.cost_c)[k][j])
                else:  # u: the fine cell's offset from the coarse cell's centre, in fine cells
                    (fy, fx), (cy, cx) = ((y, x), nxt[1:]) if name == "fine" else (nxt[1:], (y, x))
                    u = (fy - ((cy - fy0) * self.k + half_k), fx - ((cx - fx0) * self.k + half_k))
                    j = columns["interface"][u]
                    cost += float((self.cost_fc if name == "fine" else self.cost_cf)[k][j])
            except KeyError:
                raise ValueError(f"move {k} of the trajectory is not a relaxed move (infeasible?)") from None
        return rates, cost, states
