r"""U(mu) as a DP over relaxed paths, Dinkelbach's iteration on it, and :func:`solve`.

:class:`EnergyRelaxation` adds to the cells and costs of
:class:`~baselines.energy_bound.relaxation.CellRelaxation` the value U(mu), a backward DP over
relaxed paths (fine and coarse cells, the moves between them), a best path recovered forwards,
and Dinkelbach's iteration (package docstring, ``baselines.energy_bound``). :func:`solve` runs
it with b = 0 and with each multiplier variant and returns the smallest certified bound.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

import ios_uav_env as ie
from baselines.energy_bound.relaxation import CellRelaxation, multipliers
from baselines.grid import DEFAULT_MARGIN
from baselines.registry import check as check_planner
from ios_uav_env import ScenarioConfig

#: Default cell side (m) of the relaxation.
DEFAULT_RESOLUTION = 5.0
#: Default multiplier variants of :func:`solve`, (scale, window): b = scale x the averaged gradient.
DEFAULT_VARIANTS = ((1.0, 12), (0.5, 12), (1.0, 24))
#: Each Dinkelbach step goes to the path's ratio times 1 + BOUND_SLACK (so the last DP certifies).
BOUND_SLACK = 1e-9
#: Default cap on Dinkelbach's relaxed DP solves (the certificate included).
MAX_ITERS = 50


class NonPositiveEnergy(ValueError):
    """A relaxed path's energy bound L is <= 0 (multipliers b too large for the cells): the
    ratio sum Rbar / L, and with it Dinkelbach's iteration on this relaxation, is undefined."""


class EnergyRelaxation(CellRelaxation):
    """U(mu) of the package docstring for one config, cell side and multipliers b.

    The cells: fine squares of side h over the grid box (``baselines.grid.grid_box``, rounded
    out to whole coarse cells) and coarse squares of side k h (:func:`coarse_factor`) over the
    rest of the reach box (``baselines.grid.reach_box``: every way-point of a feasible plan lies
    in it). ``value(mu)`` -> (U, sum Rbar, L) of a best relaxed path, mu = lambda / (B dt)."""

    def dinkelbach(
        self, start: float = 0.0, max_iters: int = MAX_ITERS, label: str = "", progress: bool = False
    ) -> tuple[float, float, float, list[dict[str, Any]]]:
        """Dinkelbach's iteration on this relaxation from lambda = ``start`` (bits/J) (package
        docstring): (the certified bound lambda, bits/J, with U <= 0 there; the best path ratio
        found, bits/J; U at the bound; one record per DP). ``RuntimeError`` if ``max_iters`` DPs
        give no certificate."""
        c = self.config
        scale = c.bandwidth_hz * c.dt  # lambda = mu B dt
        mu = float(start) / scale
        records: list[dict[str, Any]] = []
        best_ratio = 0.0
        for _ in range(int(max_iters)):
            u, rates, cost = self.value(mu)
            if not cost > 0:
                raise NonPositiveEnergy(
                    f"a relaxed path has an energy bound L = {cost!r} J <= 0: the multipliers are too "
                    f"large for resolution={self.h!r} m (use a smaller resolution or no reference)"
                )
            ratio = rates / cost
            best_ratio = max(best_ratio, ratio)
            records.append({"b": label, "lambda": mu * scale, "U": u, "path_ratio": ratio * scale})
            if progress:
                lam_now, ratio_now = mu * scale, ratio * scale
                print(f"[ee-bound] b {label}: lambda {lam_now:.6f} bits/J  U {u:.3e}  ratio {ratio_now:.6f}")
            if u <= 0:
                return mu * scale, best_ratio * scale, u, records
            mu = max(ratio, mu) * (1.0 + BOUND_SLACK)
        raise RuntimeError(
            f"no certificate within max_iters={max_iters} relaxed DPs (b {label}, last U = {u:.3g})"
        )

    def value(self, mu: float) -> tuple[float, float, float]:
        """(U, sum Rbar, L) at mu = lambda / (B dt): U = max over relaxed paths of
        sum Rbar - mu L (>= G_lambda(q) / (B dt) for every feasible q), and a best path's two
        sums (bps/Hz summed over the N slots; J)."""
        c = self.config
        if c.N == 2:
            rates = self.r0 + self.rf
            return rates - mu * self.direct_cost, rates, self.direct_cost
        tables = self._tables(mu)
        return self._best_path(mu, tables)

    @staticmethod
    def _shift_max(values: np.ndarray, offsets: np.ndarray, costs: np.ndarray) -> np.ndarray:
        """out[y, x] = max over offsets o of values[(y, x) + o] - costs[o] (-inf outside)."""
        ny, nx = values.shape
        best = np.full((ny, nx), -np.inf)
        for (dy, dx), cost in zip(offsets, costs, strict=True):
            ys, yd = (slice(0, ny - dy), slice(dy, ny)) if dy >= 0 else (slice(-dy, ny), slice(0, ny + dy))
            xs, xd = (slice(0, nx - dx), slice(dx, nx)) if dx >= 0 else (slice(-dx, nx), slice(0, nx + dx))
            np.maximum(best[ys, xs], values[yd, xd] - cost, out=best[ys, xs])
        return best

    def _tables(self, mu: float) -> list[tuple[np.ndarray, np.ndarray]]:
        """(fine, coarse) values of slots k = 1..N-2 (index k - 1): the best of slots k..N-1
        (rewards minus mu times the costs of moves k..N-2, plus mu times the penalties of slots
        k..N-2: L subtracts them)."""
        c, fine, coarse = self.config, self.fine, self.coarse
        n = c.N
        tables: list[tuple[np.ndarray, np.ndarray]] = [(np.empty(0), np.empty(0))] * (n - 2)
        k = n - 2
        last = []
        for name, grid, pen in (("fine", fine, self.pen_f), ("coarse", coarse, self.pen_c)):
            ok = self._allowed(grid, k) & np.isfinite(self.last[name])
            last.append(
                np.where(
                    ok, grid.reward + self.rf - mu * (np.where(ok, self.last[name], 0.0) - pen[k]), -np.inf
                )
            )
        tables[-1] = (last[0], last[1])
        for k in range(n - 3, 0, -1):
            vf, vc = tables[k]  # slot k + 1
            af = self._shift_max(vf, self.off_f, mu * self.cost_f[k])
            ac = self._shift_max(vc, self.off_c, mu * self.cost_c[k])
            if len(self.pair_f):
                np.maximum.at(
                    af.ravel(), self.pair_f, vc.ravel()[self.pair_c] - mu * self.cost_fc[k][self.pair_o]
                )
                np.maximum.at(
                    ac.ravel(), self.pair_c, vf.ravel()[self.pair_f] - mu * self.cost_cf[k][self.pair_o]
                )
            tables[k - 1] = (
                np.where(self._allowed(fine, k), fine.reward + mu * self.pen_f[k] + af, -np.inf),
                np.where(self._allowed(coarse, k), coarse.reward + mu * self.pen_c[k] + ac, -np.inf),
            )
        return tables

    def _best_path(
        self, mu: float, tables: list[tuple[np.ndarray, np.ndarray]]
    ) -> tuple[float, float, float]:
        """U and a best path's sums, recovered forwards from the tables (a state is (grid, y, x))."""
        c = self.config
        grids = {"fine": self.fine, "coarse": self.coarse}
        best, state, cost = -math.inf, None, 0.0
        for idx, name in enumerate(("fine", "coarse")):
            first = self.first[name]
            vals = np.where(
                np.isfinite(first), tables[0][idx] - mu * np.where(np.isfinite(first), first, 0.0), -np.inf
            )
            j = int(np.argmax(vals))
            if vals.flat[j] > best:
                best, state = float(vals.flat[j]), (name, *np.unravel_index(j, vals.shape))
                cost = float(first.flat[j])
        if state is None or not math.isfinite(best):
            raise ValueError("no relaxed path reaches qF in time (the scenario admits no feasible plan)")
        total, rates = self.r0 + best, self.r0
        for k in range(1, c.N - 1):
            name, y, x = state
            grid = grids[name]
            rates += float(grid.reward[y, x])
            cost -= float((self.pen_f if name == "fine" else self.pen_c)[k])
            if k == c.N - 2:
                cost += float(self.last[name][y, x])
                break
            cands = self._successors(mu, k, state, tables[k])
            state, move_cost = max(cands, key=lambda t: t[2])[:2]
            cost += move_cost
        return total, rates + self.rf, cost

    def _successors(self, mu: float, k: int, state: tuple, nxt: tuple[np.ndarray, np.ndarray]) -> list[tuple]:
        """[(next state, move cost, value of the choice)] for move k from ``state``."""
        name, y, x = state
        out = []
        if name == "fine":
            own, offsets, costs, other = nxt[0], self.off_f, self.cost_f[k], "coarse"
        else:
            own, offsets, costs, other = nxt[1], self.off_c, self.cost_c[k], "fine"
        ny, nx = own.shape
        tgt = offsets + np.array([y, x])
        ok = (tgt[:, 0] >= 0) & (tgt[:, 0] < ny) & (tgt[:, 1] >= 0) & (tgt[:, 1] < nx)
        if ok.any():
            vals = np.full(len(tgt), -np.inf)
            vals[ok] = own[tgt[ok, 0], tgt[ok, 1]] - mu * costs[ok]
            j = int(np.argmax(vals))
            out.append(((name, int(tgt[j, 0]), int(tgt[j, 1])), float(costs[j]), float(vals[j])))
        flat = y * own.shape[1] + x
        if name == "fine":
            sel = np.flatnonzero(self.pair_f == flat)
            target, ctab, grid = self.pair_c[sel], self.cost_fc[k], nxt[1]
        else:
            sel = np.flatnonzero(self.pair_c == flat)
            target, ctab, grid = self.pair_f[sel], self.cost_cf[k], nxt[0]
        if len(sel):
            vals = grid.ravel()[target] - mu * ctab[self.pair_o[sel]]
            j = int(np.argmax(vals))
            yy, xx = np.unravel_index(int(target[j]), grid.shape)
            out.append(((other, int(yy), int(xx)), float(ctab[self.pair_o[sel][j]]), float(vals[j])))
        return out


@dataclass(frozen=True)
class EnergyBound:
    """The certified bound: no feasible plan of the scenario has an EE above ``upper_bound``."""

    upper_bound: float  # bits/J, certified: U(upper_bound / (B dt)) <= 0 for its relaxation
    relaxed_ratio: float  # bits/J, the best relaxed path's ratio found (<= upper_bound)
    certificate: float  # U at the bound (bps/Hz summed over the slots), <= 0
    resolution: float  # m, fine cell side h
    margin: float  # m, grid box margin
    variant: tuple[float, int] | None  # the winner's multipliers, (scale, window); None: b = 0
    plain_bound: float  # bits/J, the bound with b = 0 (= upper_bound when no reference is given)
    seconds: float  # wall time
    iterations: list[dict[str, float]] = field(default_factory=list)  # per DP: b, lambda, U, path ratio
    # the variants left out: a relaxed path of theirs had an energy bound L <= 0 (NonPositiveEnergy)
    skipped: tuple[tuple[float, int], ...] = ()


def solve(
    config: ScenarioConfig,
    *,
    resolution: float = DEFAULT_RESOLUTION,
    margin: float = DEFAULT_MARGIN,
    reference: Any = None,
    variants: Any = DEFAULT_VARIANTS,
    start: float | None = None,
    max_iters: int = MAX_ITERS,
    progress: bool = False,
) -> EnergyBound:
    """The certified upper bound on the EE (bits/J) of every feasible plan of ``config`` (one node).

    Parameters
    ----------
    config : ScenarioConfig
        One ground node; its ``propulsion`` and ``bandwidth_hz`` define the EE.
    resolution : float
        Fine cell side h (m), in (0, D]; the bound tightens as it shrinks (package docstring).
    margin : float
        Widening (m, >= 0) of the fine cells' box, as the DP planners' grid box.
    reference : trajectory (N, 2) or Plan, optional
        The plan whose energy gradient makes the multipliers (:func:`multipliers`), typically
        the best plan found. None: b = 0 only.
    variants : sequence of (scale, window)
        With a reference, one bound per variant, b = scale x :func:`multipliers` with that
        window (scale in (0, 1], window even >= 2), and the bound with b = 0: every b is
        valid, and the smallest is returned. A variant whose relaxation has a path with an
        energy bound L <= 0 (b too large for the cells) gives no ratio: it is left out and
        named in ``skipped`` (the bound with b = 0 always stands). Which is tightest depends
        on how closely the relaxed optimum follows the reference: a relaxed path that hovers where b is large
        saves about |b| h per move, which a smaller scale limits.
    start : float, optional
        A first lambda (bits/J, >= 0); default: the reference's EE, else 0.
    max_iters : int
        Cap on the relaxed DP solves (>= 1) of each bound, its certificate included.
    progress : bool
        Print one line per DP.

    Returns
    -------
    EnergyBound
        ``upper_bound`` (bits/J), with U(upper_bound) <= 0 checked by the last DP.

    Raises
    ------
    ValueError
        A bad argument, K > 1 ground nodes, or tables above ``baselines.grid.MAX_TABLE_BYTES``.
    RuntimeError
        No certificate within ``max_iters`` DPs.
    """
    t0 = time.perf_counter()
    check_planner("energy-bound", config)
    if isinstance(max_iters, bool) or not isinstance(max_iters, (int, np.integer)) or max_iters < 1:
        raise ValueError(f"max_iters must be an integer >= 1, got {max_iters!r}")
    if start is not None and not (
        isinstance(start, (int, float))
        and not isinstance(start, bool)
        and math.isfinite(start)
        and start >= 0
    ):
        raise ValueError(f"start must be a finite number >= 0 (bits/J), got {start!r}")
    variants = tuple(variants) if reference is not None else ()
    tilts = {}
    for scale, window in variants:  # validates reference, scales and windows before any DP
        if not (isinstance(scale, (int, float)) and not isinstance(scale, bool) and 0 < scale <= 1):
            raise ValueError(f"a variant's scale must be a number in (0, 1], got {scale!r}")
        tilts[(float(scale), int(window))] = float(scale) * multipliers(config, reference, window)
    if reference is not None and not tilts:
        raise ValueError("variants must hold at least one (scale, window) pair when a reference is given")
    if start is None and reference is not None:
        start = float(ie.energy_efficiency(config, np.asarray(getattr(reference, "trajectory", reference))))
    lam0 = 0.0 if start is None else float(start)
    plain = EnergyRelaxation(config, resolution, margin)
    results: dict[Any, tuple[float, float, float, list[dict[str, Any]]]] = {
        None: plain.dinkelbach(lam0, max_iters, "0", progress)
    }
    skipped = []
    for variant, b in tilts.items():  # tightenings of the plain bound: one that breaks is left out
        relaxation = EnergyRelaxation(config, resolution, margin, b)
        try:
            results[variant] = relaxation.dinkelbach(
                lam0, max_iters, f"{variant[0]:g}x{variant[1]}", progress
            )
        except NonPositiveEnergy:
            skipped.append(variant)
    label = min(results, key=lambda name: results[name][0])
    lam, ratio, u, _ = results[label]
    return EnergyBound(
        upper_bound=lam,
        relaxed_ratio=ratio,
        certificate=u,
        resolution=float(resolution),
        margin=float(margin),
        variant=label,
        plain_bound=results[None][0],
        seconds=time.perf_counter() - t0,
        iterations=[r for name in results for r in results[name][3]],
        skipped=tuple(skipped),
    )
