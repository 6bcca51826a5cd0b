"""The grid machinery of the DP planners: the grid, the per-cell rates, the disk maximum and
the best grid path for a per-slot reward (``baselines.dp`` for one node, ``baselines.dp_bound``
for several).

The grid is anchored at q0 (so q[1] is a grid cell) with spacing ``resolution`` over
:func:`grid_box`: the scene's box (q0, qF, the nodes, the IOS centre) clipped to the region the
UAV can reach (:func:`reach_box`), so a far-away node never blows the grid up, and every grid
of a planner is checked against ``MAX_TABLE_BYTES`` (:func:`check_grid_bytes`) before it is
allocated. Moves are the grid offsets inside the Euclidean disk of radius D. The disk
maximum is computed, per layer and vectorised, as the maximum over the disk's rows of 1-D
running maxima (``scipy.ndimage.maximum_filter1d``), which equals ``maximum_filter`` with
the disk footprint (tested). Ties are broken in the forward pass towards the shortest move,
then the smallest (dy, dx) offset: when indifferent the UAV stays put. :func:`corridor_path` is
the local form: the best path through small grids centred on a flight's way-points.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy.ndimage import maximum_filter1d

from ios_uav_env import ScenarioConfig, scene_box, slot_rates

#: Default widening (m) of the grid box around q0, qF, G and the IOS centre.
DEFAULT_MARGIN = 100.0
#: Largest value table (bytes) the solver will allocate: N x cells float64.
MAX_TABLE_BYTES = 2 * 1024**3
_RATE_CHUNK = 65536  # cells per slot_rates call (bounds the (cells, nodes) temporaries)


def reach_box(config: ScenarioConfig) -> tuple[float, float, float, float]:
    """Box (x_min, x_max, y_min, y_max) in m holding every point a feasible trajectory visits.

    Slot n's way-point is within (n - 1) D of q0 and (N - n) D of qF, so every way-point lies
    in the ellipse |q - q0| + |qF - q| <= (N - 1) D; this is its bounding box widened by one
    move D (rounding slack).
    """
    q0, qf = np.asarray(config.q0, float), np.asarray(config.qF, float)
    a = 0.5 * (config.N - 1) * config.D  # semi-major axis
    c = 0.5 * float(np.linalg.norm(qf - q0))  # half the focal distance (<= a: config validated)
    b = math.sqrt(max(a * a - c * c, 0.0))
    u = (qf - q0) / (2.0 * c) if c > 0 else np.array([1.0, 0.0])
    half = np.sqrt((a * u) ** 2 + (b * u[::-1]) ** 2) + config.D
    centre = 0.5 * (q0 + qf)
    lo, hi = centre - half, centre + half
    return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])


def grid_box(config: ScenarioConfig, margin: float = DEFAULT_MARGIN) -> tuple[float, float, float, float]:
    """Box (x_min, x_max, y_min, y_max) in m: ``ios_uav_env.scene_box`` (q0, qF, the nodes, IOS
    centre) widened by ``margin``, clipped to :func:`reach_box` widened by ``margin`` (no
    feasible trajectory leaves that box, so the clip removes no point a plan can visit)."""
    x_lo, x_hi, y_lo, y_hi = scene_box(config, margin)
    r_x_lo, r_x_hi, r_y_lo, r_y_hi = reach_box(config)
    return (
        max(x_lo, r_x_lo - margin),
        min(x_hi, r_x_hi + margin),
        max(y_lo, r_y_lo - margin),
        min(y_hi, r_y_hi + margin),
    )


def _index_range(lo: float, hi: float, origin: float, resolution: float) -> tuple[int, int]:
    """First and last grid index k (coordinate origin + k resolution) covering [lo, hi]."""
    return math.floor((lo - origin) / resolution), math.ceil((hi - origin) / resolution)


def grid_shape(config: ScenarioConfig, resolution: float, margin: float = DEFAULT_MARGIN) -> tuple[int, int]:
    """(ny, nx) of :func:`grid_axes`, computed without building the axes."""
    x_min, x_max, y_min, y_max = grid_box(config, margin)
    kx0, kx1 = _index_range(x_min, x_max, config.q0[0], resolution)
    ky0, ky1 = _index_range(y_min, y_max, config.q0[1], resolution)
    return ky1 - ky0 + 1, kx1 - kx0 + 1


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def validate_grid_args(config: ScenarioConfig, resolution: float, margin: float) -> None:
    """``TypeError``/``ValueError`` naming the argument unless ``config`` is a ScenarioConfig,
    ``resolution`` a finite number in (0, D] m and ``margin`` a finite number >= 0 m."""
    if not isinstance(config, ScenarioConfig):
        raise TypeError(f"config must be a ScenarioConfig, got {type(config).__name__}")
    if not (_is_number(resolution) and 0 < resolution <= config.D):
        raise ValueError(f"resolution must be a finite number in (0, D={config.D:g}] m, got {resolution!r}")
    if not (_is_number(margin) and margin >= 0):
        raise ValueError(f"margin must be a finite number >= 0 (m), got {margin!r}")


def check_grid_bytes(
    config: ScenarioConfig,
    resolution: float,
    margin: float,
    per_cell: float,
    what: str,
    argument: str = "resolution",
    largest: float | None = None,
) -> None:
    """``ValueError`` when the arrays ``what``, ``per_cell`` bytes for each cell of the
    ``resolution`` grid, would exceed ``MAX_TABLE_BYTES``; nothing is allocated. The message
    names ``argument``, the limit and about the smallest spacing that fits (or says that none
    up to ``largest`` m, the argument's own upper limit, does)."""
    ny, nx = grid_shape(config, resolution, margin)
    needed = per_cell * ny * nx
    if needed <= MAX_TABLE_BYTES:
        return
    coarser = resolution * math.sqrt(needed / MAX_TABLE_BYTES)
    if largest is not None and coarser > largest:
        fix = f"no {argument} in its range (0, {largest:g}] m fits: use a shorter T"
    else:
        fix = (
            f"{argument} must be at least about {coarser:.3g} m here (or use a smaller margin or a shorter T)"
        )
    raise ValueError(
        f"{argument}={resolution:g} m with margin={margin:g} m gives a {ny} x {nx} grid whose {what} "
        f"needs {needed / 2**30:.1f} GiB, above MAX_TABLE_BYTES={MAX_TABLE_BYTES / 2**30:g} GiB: {fix}"
    )


def grid_axes(
    config: ScenarioConfig, resolution: float, margin: float = DEFAULT_MARGIN
) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
    """Grid coordinates ``xs``, ``ys`` (m) anchored at q0, and q0's (iy, ix) index.

    The grid covers :func:`grid_box` (rounded outwards to whole cells).
    """
    x_min, x_max, y_min, y_max = grid_box(config, margin)
    x0, y0 = config.q0
    kx0, kx1 = _index_range(x_min, x_max, x0, resolution)
    ky0, ky1 = _index_range(y_min, y_max, y0, resolution)
    kx, ky = np.arange(kx0, kx1 + 1), np.arange(ky0, ky1 + 1)
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


def grid_path(
    config: ScenarioConfig,
    rates: np.ndarray,
    r_f: float,
    resolution: float,
    margin: float = DEFAULT_MARGIN,
    progress: bool = False,
) -> tuple[np.ndarray, float]:
    """The best grid path for a per-slot reward: (trajectory (N, 2), objective).

    ``rates`` (ny, nx) is the reward of each cell of :func:`grid_axes` (q0's cell gives slot
    1's reward), ``r_f`` that of qF (slot N); the objective is the path's mean reward, the
    optimum over grid paths (module docstring). ``ValueError`` when no grid path reaches qF.
    """
    n_slots, d_max = config.N, config.D
    q_f = np.asarray(config.qF, dtype=float)
    check_grid_bytes(
        config, resolution, margin, 8 * (n_slots - 2), "value table (N - 2 float64 layers)", largest=d_max
    )
    xs, ys, (iy0, ix0) = grid_axes(config, resolution, margin)
    offsets = disk_offsets(resolution, d_max)
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
    return traj, total / n_slots


def corridor_path(
    config: ScenarioConfig,
    trajectory: np.ndarray,
    spacing: float,
    rewards_of: Callable[[np.ndarray], np.ndarray],
    ends: np.ndarray,
    cells: int = 2,
) -> tuple[np.ndarray, float]:
    """One corridor DP: the best path whose way-point n (slots 2..N-1) is one of the (2 ``cells`` +
    1)^2 points q[n] + ``spacing`` (i, j), |i|, |j| <= ``cells``, around the feasible ``trajectory``
    q (N, 2) m, moves <= D, q0 and qF fixed: (trajectory (N, 2) m, its mean reward).
    ``rewards_of(cand)`` gives the rewards (N - 2, P) of the candidate points ``cand`` (N - 2, P, 2)
    (row m: slot m + 2), ``ends`` the rewards of slots 1 and N. q itself is a candidate (offset 0
    first in the ties), so the value never decreases and an unimproved path is returned unchanged."""
    q = np.asarray(trajectory, dtype=float)
    n_slots, reach = config.N, config.D * (1.0 + 1e-12)
    if n_slots == 2:
        return q.copy(), float(ends.sum()) / 2
    i, j = np.meshgrid(np.arange(-cells, cells + 1), np.arange(-cells, cells + 1))
    off = np.column_stack([i.ravel(), j.ravel()])
    off = spacing * off[np.lexsort((off[:, 1], off[:, 0], (off * off).sum(axis=1)))]  # (0, 0) first
    cand = q[1:-1, None, :] + off[None]  # (N - 2, P, 2): slots 1..N-2
    rewards = rewards_of(cand)
    value = np.where(np.hypot(*(cand[-1] - q[-1]).T) <= reach, rewards[-1] + ends[1], -np.inf)
    choice = np.empty((n_slots - 3, len(off)), dtype=int)
    for m in range(n_slots - 4, -1, -1):  # value of slot m + 1 from slot m + 2's
        gap = np.linalg.norm(cand[m][:, None] - cand[m + 1][None], axis=2)
        nxt = np.where(gap <= reach, value[None], -np.inf)
        choice[m] = np.argmax(nxt, axis=1)
        value = rewards[m] + nxt[np.arange(len(off)), choice[m]]
    value = np.where(np.hypot(*(cand[0] - q[0]).T) <= reach, value, -np.inf)
    at = int(np.argmax(value))
    if not np.isfinite(value[at]):
        raise ValueError(f"trajectory must be a feasible flight (q0 to qF, moves <= D={config.D:g} m)")
    out, idx = q.copy(), [at]
    for m in range(n_slots - 3):
        idx.append(int(choice[m, idx[-1]]))
    out[1:-1] = cand[np.arange(n_slots - 2), idx]
    return out, float(ends[0] + value[at]) / n_slots


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
