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
``margin`` (m, default 100) on every side. Rate peaks lie near G and near the IOS, so the
box holds them with room; paths that leave the box are not considered (raise ``margin``
to check). As ``resolution`` -> 0 and ``margin`` grows the value converges to the optimum
of problem (10).

**Ties** (equal values, e.g. cells of equal rate) are broken in the forward pass towards
the shortest move, then the smallest (dy, dx) offset: when indifferent the UAV stays put.

**Parity.** The plan's ``mean_rate`` is ``ios_uav_env.average_rate`` of the trajectory; the
DP's own optimum is in ``plan.info["dp_objective"]`` and is checked equal to it (1e-9).
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy.ndimage import maximum_filter1d

from baselines.plan import Plan
from ios_uav_env import ScenarioConfig, scene_box, slot_rates

#: Default widening (m) of the grid box around q0, qF, G and the IOS centre.
DEFAULT_MARGIN = 100.0
#: Largest value table (bytes) the solver will allocate: N x cells float64.
MAX_TABLE_BYTES = 2 * 1024**3
_RATE_CHUNK = 65536  # cells per slot_rates call (bounds the (cells, nodes) temporaries)


def grid_box(config: ScenarioConfig, margin: float = DEFAULT_MARGIN) -> tuple[float, float, float, float]:
    """Box (x_min, x_max, y_min, y_max) in m: ``ios_uav_env.scene_box`` (q0, qF, G, IOS centre)
    widened by ``margin``."""
    return scene_box(config, margin)


def grid_axes(
    config: ScenarioConfig, resolution: float, margin: float = DEFAULT_MARGIN
) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
    """Grid coordinates ``xs``, ``ys`` (m) anchored at q0, and q0's (iy, ix) index.

    The grid covers :func:`grid_box` (rounded outwards to whole cells).
    """
    x_min, x_max, y_min, y_max = grid_box(config, margin)
    x0, y0 = config.q0
    kx = np.arange(math.floor((x_min - x0) / resolution), math.ceil((x_max - x0) / resolution) + 1)
    ky = np.arange(math.floor((y_min - y0) / resolution), math.ceil((y_max - y0) / resolution) + 1)
    return x0 + resolution * kx, y0 + resolution * ky, (int(-ky[0]), int(-kx[0]))


def rate_map(
    config: ScenarioConfig, resolution: float = 2.5, margin: float = DEFAULT_MARGIN
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Slot rate r(q) (bps/Hz) on the DP grid: ``xs`` (nx,), ``ys`` (ny,), ``rates`` (ny, nx)."""
    xs, ys, _ = grid_axes(config, resolution, margin)
    xx, yy = np.meshgrid(xs, ys)
    cells = np.column_stack([xx.ravel(), yy.ravel()])
    rates = np.concatenate(
        [slot_rates(config, cells[i : i + _RATE_CHUNK]) for i in range(0, len(cells), _RATE_CHUNK)]
    )
    return xs, ys, rates.reshape(len(ys), len(xs))


def disk_offsets(resolution: float, radius: float) -> np.ndarray:
    """Grid offsets (dy, dx) with resolution * |(dy, dx)| <= radius, shape (K, 2).

    Sorted by length, then dy, then dx: the forward pass's tie-breaking order.
    """
    r = math.floor(radius / resolution + 1e-9)
    dy, dx = np.mgrid[-r : r + 1, -r : r + 1]
    inside = (dy * dy + dx * dx) * resolution**2 <= radius**2 * (1 + 1e-12)
    off = np.column_stack([dy[inside], dx[inside]])
    order = np.lexsort((off[:, 1], off[:, 0], off[:, 0] ** 2 + off[:, 1] ** 2))
    return off[order]


def disk_max(values: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """out[y, x] = max over (dy, dx) in ``offsets`` of values[y + dy, x + dx] (-inf outside).

    ``offsets`` must be a disk (symmetric rows, as from :func:`disk_offsets`); computed as the
    maximum over rows dy of a 1-D running maximum of half-width w(dy) along x.
    """
    ny = values.shape[0]
    half = {}
    for dy, dx in offsets:
        half[int(dy)] = max(half.get(int(dy), 0), abs(int(dx)))
    out = np.full_like(values, -np.inf)
    rows: dict[int, np.ndarray] = {}
    for dy, w in half.items():
        if abs(dy) >= ny:
            continue
        if w not in rows:
            rows[w] = maximum_filter1d(values, size=2 * w + 1, axis=1, mode="constant", cval=-np.inf)
        m = rows[w]
        if dy >= 0:
            np.maximum(out[: ny - dy], m[dy:], out=out[: ny - dy])
        else:
            np.maximum(out[-dy:], m[: ny + dy], out=out[-dy:])
    return out


def _validate(config: ScenarioConfig, resolution: float, margin: float) -> None:
    if not isinstance(config, ScenarioConfig):
        raise TypeError(f"config must be a ScenarioConfig, got {type(config).__name__}")
    if not (isinstance(resolution, (int, float)) and math.isfinite(resolution)):
        raise ValueError(f"resolution must be a finite number in (0, D={config.D:g}] m, got {resolution!r}")
    if not 0 < resolution <= config.D:
        raise ValueError(f"resolution must be in (0, D={config.D:g}] m, got {resolution!r}")
    if not (isinstance(margin, (int, float)) and math.isfinite(margin) and margin >= 0):
        raise ValueError(f"margin must be a finite number >= 0 (m), got {margin!r}")


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

    Raises
    ------
    ValueError
        Bad ``resolution``/``margin``; a value table above ``MAX_TABLE_BYTES``; or no grid
        path reaches qF in N - 1 moves (horizon too tight for this grid: refine it).
    """
    t0 = time.perf_counter()
    _validate(config, resolution, margin)
    n_slots, d_max = config.N, config.D
    q0, q_f = np.asarray(config.q0), np.asarray(config.qF)
    info = {"resolution": float(resolution), "margin": float(margin), "box": list(grid_box(config, margin))}
    if n_slots == 2:  # no free way-point: q = [q0, qF] (feasible by ScenarioConfig's check)
        traj = np.array([q0, q_f])
        info.update(dp_objective=float(slot_rates(config, traj).sum() / n_slots), grid_shape=[0, 0])
        return _finish(config, traj, info, t0)

    xs, ys, (iy0, ix0) = grid_axes(config, resolution, margin)
    table_bytes = (n_slots - 2) * len(xs) * len(ys) * 8
    if table_bytes > MAX_TABLE_BYTES:
        raise ValueError(
            f"resolution={resolution} m with margin={margin} m needs a {table_bytes / 2**30:.1f} GiB value "
            f"table (N x cells), above MAX_TABLE_BYTES={MAX_TABLE_BYTES / 2**30:.0f} GiB: use a coarser "
            "resolution or a smaller margin"
        )
    _, _, rates = rate_map(config, resolution, margin)
    offsets = disk_offsets(resolution, d_max)
    r_f = float(slot_rates(config, q_f)[0])
    info.update(grid_shape=[len(ys), len(xs)], n_offsets=len(offsets))

    # values[k] is V at layer k + 1 (0-based slots; layer 0 is q0, layer N-1 is qF)
    values = np.empty((n_slots - 2, len(ys), len(xs)))
    near_f = np.hypot(xs[None, :] - q_f[0], ys[:, None] - q_f[1]) <= d_max
    values[-1] = np.where(near_f, rates + r_f, -np.inf)
    layers = range(n_slots - 4, -1, -1)
    bar = _progress(len(layers), progress)
    for k in layers:
        values[k] = rates + disk_max(values[k + 1], offsets)
        bar.update(1)
    bar.close()

    path = [(iy0, ix0)]
    best_first = _best_move(values[0], (iy0, ix0), offsets)
    if best_first is None:
        axial = math.floor(d_max / resolution + 1e-9) * resolution
        raise ValueError(
            f"no grid path reaches qF={config.qF} from q0={config.q0} in N - 1 = {n_slots - 1} moves at "
            f"resolution={resolution:g} m: grid moves are at most {axial:g} m along an axis (D={d_max:g} m) "
            f"and shorter than D in most directions, so the horizon T={config.T:g} s (minimum "
            f"{config.min_horizon():g} s) is too tight for this grid; use a finer resolution (one that "
            f"divides D, e.g. {d_max / math.ceil(d_max / resolution):g} m) or a larger T"
        )
    total = float(rates[iy0, ix0] + values[0][best_first])
    path.append(best_first)
    for k in range(1, n_slots - 2):
        path.append(_best_move(values[k], path[-1], offsets))
    idx = np.array(path)
    traj = np.vstack([np.column_stack([xs[idx[:, 1]], ys[idx[:, 0]]]), q_f])
    info["dp_objective"] = total / n_slots
    return _finish(config, traj, info, t0)


def _best_move(layer: np.ndarray, cell: tuple[int, int], offsets: np.ndarray) -> tuple[int, int] | None:
    """First (in ``offsets`` order) argmax of ``layer`` over the disk around ``cell``."""
    cand = offsets + np.asarray(cell)
    ok = (cand[:, 0] >= 0) & (cand[:, 0] < layer.shape[0]) & (cand[:, 1] >= 0) & (cand[:, 1] < layer.shape[1])
    cand = cand[ok]
    vals = layer[cand[:, 0], cand[:, 1]]
    i = int(np.argmax(vals))
    if not np.isfinite(vals[i]):
        return None
    return int(cand[i, 0]), int(cand[i, 1])


def _finish(config: ScenarioConfig, traj: np.ndarray, info: dict, t0: float) -> Plan:
    plan = Plan.from_trajectory("dp", config, traj, time.perf_counter() - t0, info=info)
    gap = abs(plan.mean_rate - info["dp_objective"])
    if gap > 1e-9 * max(1.0, abs(plan.mean_rate)):
        raise RuntimeError(
            f"DP objective {info['dp_objective']!r} != average_rate {plan.mean_rate!r} (gap {gap:.3g})"
        )
    return plan


class _NoBar:
    def update(self, n: int) -> None:
        pass

    def close(self) -> None:
        pass


def _progress(total: int, enabled: bool):
    if not enabled:
        return _NoBar()
    from tqdm.auto import tqdm

    return tqdm(total=total, desc="DP backward pass", unit="slot")
