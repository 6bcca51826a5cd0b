r"""Moving, roughly known nodes in the single-node env: the truth and what the UAV observes of it.

An env is *mobile* when its scenario has a motion model (``ScenarioConfig.motion``) or its
``knowledge`` option is not ``"exact"``. Per episode (:func:`start_track`, at reset, from the
env's ``np_random``) the node's path w[1..N] is drawn (``ios_uav_env.model.motion.node_paths``)
and its rate kernel per slot built (``ios_uav_env.model.channel.path_kernels``): slot n's rate
is r(q[n]; w[n]), the single-node model with G = w[n], the one the scorer uses
(``score_plan(config, q, paths=...)``). What the UAV is told of slot n (:func:`observe_slot`):

- ``"exact"``: the node's true position w[n] (the rate feature: r(q[n]; w[n]));
- ``"reports"``: a position report z[n] = w[n] + e[n], e[n] ~ N(0, s^2 I_2)
  (``ios_uav_env.model.reports.position_reports``, s = ``report_sigma``), and the rate it
  measures in the slot, one faded sample log2(1 + eta |h|^2) of the Rician channel at its true
  position (the draws of ``reports.measured_rates``);
- ``"rates"``: the measured rate only (the node features are 0).

With ``filter_estimate=True`` (``"reports"`` only; off by default, since estimating is part of the
task) the node features are the Kalman filter's estimate of the node's position after the
slot's report instead of the raw report: a memory-free summary of all the reports so far
(``ios_uav_env.model.kalman.NodeFilter``, the estimator MPC uses), clipped as a report is.

**Clipping.** So that every observation lies in the space, a report is clipped to the node's
motion rectangle (``motion.node_bounds``; the configured position for static nodes) widened by
``REPORT_CLIP`` s, and a measured rate to the space's rate bound (the expected-gain bound plus
``FADE_MARGIN``): a fix that far off is an outlier a receiver discards; under Rayleigh fading
the rate clip binds with probability below exp(-9) per slot, and only where the expected
rate is near the bound.

**Draws** (after the scenario's and the paths' at reset, after the channel's normals at every
slot): the report's two normals (``"reports"``), then the measured rate's two (``"reports"``
and ``"rates"``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ios_uav_env.envs.observation import (
    F32_MAX,
    float32_bounds,
    ground_free_rate_bound,
    length_bounds,
    overflow_hint,
    pad,
)
from ios_uav_env.envs.observation_layout import observation_names
from ios_uav_env.envs.options import KNOWLEDGE, EnvOptions
from ios_uav_env.model.channel import (
    PARAMS,
    HeldKernels,
    faded_of_rate,
    faded_row,
    hold_path_kernels,
    path_kernels,
)
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.kalman import NodeFilter
from ios_uav_env.model.mobility import BOX_MARGIN
from ios_uav_env.model.motion import node_bounds, node_paths
from ios_uav_env.model.node_kernels import kernel_config, kernel_width
from ios_uav_env.model.reports import SERVED_SHARE, position_reports
from ios_uav_env.model.scenarios import ScenarioRanges

#: Report clip: the motion rectangle widened by this many ``report_sigma``.
REPORT_CLIP = 4.0
#: bps/Hz above the expected-gain rate bound where a measured rate is clipped (a factor 16 in SNR).
FADE_MARGIN = 4.0
#: m, the filter's report std when the reports are exact (report_sigma = 0), as MPC's.
EXACT_SIGMA = 1e-6

__all__ = [
    "FADE_MARGIN",
    "KNOWLEDGE",
    "REPORT_CLIP",
    "NodeTrack",
    "NodesTrack",
    "filter_report",
    "mobile_bounds",
    "node_extent",
    "nodes_extent",
    "nodes_track_kernels",
    "observe_nodes",
    "observe_slot",
    "start_nodes_track",
    "start_track",
]


@dataclass(eq=False)
class NodeTrack:
    """One episode's node: its true path, its kernel per slot, and what was observed so far. The
    kernels per slot (``nodes``, ``params``) are built when first read, from the path (a batched
    env's rows compute each slot's weights into their own buffers instead,
    ``envs.slot_weights``): the same numbers whenever they are built."""

    paths: np.ndarray  # (N, 1, 2) m, the true positions w[n]
    lo: np.ndarray  # (2,) m, the report clip's lower corner
    hi: np.ndarray  # (2,) m, its upper corner
    reports: np.ndarray  # (N, 1, 2) m, the reports of the slots so far (NaN: not yet)
    measured: np.ndarray  # (N,) bps/Hz, the measured rates of the slots so far (NaN: not yet)
    config: ScenarioConfig  # the episode's scenario (the kernels' and the filter's model)
    filter: NodeFilter | None = None  # the Kalman filter of the reports so far (filter_estimate)
    _kernels: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False)

    def _built(self) -> tuple[np.ndarray, np.ndarray]:
        if self._kernels is None:
            self._kernels = path_kernels(self.config.node_config(0), self.paths[:, 0])
        return self._kernels

    @property
    def nodes(self) -> np.ndarray:
        """(N, 3, n): slot n's rate kernel (``channel.path_kernels`` of the path)."""
        return self._built()[0]

    @property
    def params(self) -> np.ndarray:
        """(N, P): slot n's kernel scalars (``channel.path_kernels`` of the path)."""
        return self._built()[1]


def _rectangles(config: ScenarioConfig) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi), (K, 2) m: where each node can be (its motion rectangle, or its position)."""
    if config.motion is None:
        w = np.asarray(config.nodes, dtype=float)
        return w, w
    return node_bounds(config)


def start_track(config: ScenarioConfig, rng: np.random.Generator, sigma: float) -> NodeTrack:
    """Draw the episode's node path from ``rng`` (module docstring); its kernels per slot are built
    when first read (:class:`NodeTrack`)."""
    paths = node_paths(config, rng)
    lo, hi = (corner[0] for corner in _rectangles(config))
    margin = REPORT_CLIP * sigma
    full = np.full((config.N, 1, 2), np.nan)
    return NodeTrack(paths, lo - margin, hi + margin, full, np.full(config.N, np.nan), config)


def observe_slot(
    track: NodeTrack,
    slot: int,
    q: np.ndarray,
    knowledge: str,
    sigma: float,
    rate_high: float,
    rng: np.random.Generator,
    estimate: bool = False,
) -> tuple[np.ndarray, float | None]:
    """What the UAV at ``q`` learns in ``slot`` (0-based), drawn from ``rng``: the node position
    it is told ((2,) m: the truth, the clipped report, or None for ``"rates"``) and the measured
    rate (None for ``"exact"``: the env's own expected rate stays). ``estimate`` (``"reports"``
    only): the position told is the Kalman filter's estimate after this slot's report
    (``ios_uav_env.model.kalman.NodeFilter`` on the raw reports, as MPC runs it), clipped alike."""
    position: np.ndarray | None = track.paths[slot, 0]
    if knowledge == "reports":
        position = _reported(track, slot, rng, sigma, estimate)[0]
    if knowledge == "exact":
        return position, None
    n_re, n_im = rng.standard_normal(2)
    rate = faded_row(float(q[0]), float(q[1]), float(n_re), float(n_im), track.nodes, track.params, slot)
    track.measured[slot] = rate
    return (None if knowledge == "rates" else position), min(rate, rate_high)


def _reported(
    track: NodeTrack | NodesTrack, slot: int, rng: np.random.Generator, sigma: float, estimate: bool
) -> np.ndarray:
    """(K, 2) m: every node's report of ``slot`` (K x 2 normals from ``rng``), clipped to the
    track's report box and recorded in ``track.reports``, or, with ``estimate``, the Kalman
    filter's estimate after the raw reports (as MPC runs it), clipped alike."""
    report = position_reports(track.paths[slot], rng, sigma)
    told = track.reports[slot] = np.clip(report, track.lo, track.hi)
    if estimate:
        told = filter_report(track, report, sigma)
    return told


def filter_report(track: NodeTrack | NodesTrack, report: np.ndarray, sigma: float) -> np.ndarray:
    """(K, 2) m: the Kalman filter's estimate after the raw ``report`` (K, 2) of the slot (the
    filter started on the episode's first report, as MPC runs it), clipped to the track's report
    box (``filter_estimate``)."""
    if track.filter is None:
        track.filter = NodeFilter.start(track.config, report, max(sigma, EXACT_SIGMA))
    else:
        track.filter.step(report)
    return np.clip(track.filter.position, track.lo, track.hi)


def node_extent(ranges: ScenarioRanges, sigma: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """((x_lo, x_hi), (y_lo, y_hi)) m: where a told node position can be over the family
    ``ranges``: the rectangles of every drawn node (the motion's box, or the scene box of the
    node's range and the IOS centre widened by ``BOX_MARGIN``) widened by the report clip."""
    base = ranges.base
    margin = REPORT_CLIP * sigma
    if base.motion is None:
        (x0, x1), (y0, y1) = ranges.ground_x, ranges.ground_y
    elif base.motion.box is not None:
        (x0, x1), (y0, y1) = base.motion.box
    else:
        xc, yc = base.ios_center[0], base.ios_center[1]
        x0, x1 = min(ranges.ground_x[0], xc) - BOX_MARGIN, max(ranges.ground_x[1], xc) + BOX_MARGIN
        y0, y1 = min(ranges.ground_y[0], yc) - BOX_MARGIN, max(ranges.ground_y[1], yc) + BOX_MARGIN
    return (x0 - margin, x1 + margin), (y0 - margin, y1 + margin)


def mobile_bounds(
    ranges: ScenarioRanges, options: EnvOptions, low: np.ndarray, high: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float]:
    """The space of a mobile env over the family ``ranges``: ``low`` and ``high`` (the static
    env's) with the node features (4-5) over :func:`node_extent` and the rate feature (10) over
    the ground-free rate bound, plus ``FADE_MARGIN`` where it is a measured rate; and that rate
    bound (bps/Hz, where a measured rate is clipped)."""
    sigma = options.report_sigma if options.knowledge == "reports" else 0.0
    reach = ranges.max_moves * ranges.base.D
    lengths = length_bounds((ranges.start_x, ranges.start_y), [node_extent(ranges, sigma)], reach)
    rate = max(ground_free_rate_bound(c) for c in ranges.configs_per_surface())
    rate += 0.0 if options.knowledge == "exact" else FADE_MARGIN
    low, high = low.copy(), high.copy()
    scale = options.length_scale

    def why(name: str, value: float) -> str:
        if sigma > 0.0 and name != "rate":  # a told position can be 4 report_sigma off the node's box
            without = length_bounds((ranges.start_x, ranges.start_y), [node_extent(ranges, 0.0)], reach)[2]
            top = (F32_MAX / (1.0 + 1e-3) * scale - without) / REPORT_CLIP
            clip = f"a report is clipped {REPORT_CLIP:g} report_sigma beyond the node's box"
            return f"{clip}: report_sigma must be <= {top:.4g} m"
        return overflow_hint(name, value, scale, ranges.base)

    node_names = observation_names(False, knowledge=options.knowledge)[4:6]
    high[4:6] = float32_bounds([pad(v / scale) for v in lengths[2:4]], node_names, why)
    high[10] = float32_bounds([pad(rate)], ("rate",), why)[0]
    low[4:6] = -high[4:6]
    return low, high, rate


def episode_reports(
    config: ScenarioConfig, seed: int, sigma: float, knowledge: str = "reports"
) -> tuple[np.ndarray, np.ndarray]:
    """(true path (N, 1, 2), clipped reports (N, 1, 2), NaN unless ``"reports"``) of the episode
    that the single-node env with channel "expected" and this ``knowledge`` draws when reset with
    ``seed`` on the pinned ``config``: the draws do not depend on where the UAV flies (each slot
    takes a report's two normals, then a measured rate's two), so they replay without the flight
    (for figures; tested against the env)."""
    rng = np.random.default_rng(seed)
    track = start_track(config, rng, sigma)
    for slot in range(config.N):
        observe_slot(track, slot, np.asarray(config.q0, dtype=float), knowledge, sigma, math.inf, rng)
    return track.paths, track.reports


# --- several nodes (MultiNodeEnv) --------------------------------------------------------------
@dataclass(eq=False)
class NodesTrack:
    """One episode's K nodes in the multi-node env: their true paths, each node's kernel per slot,
    what was observed so far and the UAV's own tally of what it served (measured rates)."""

    paths: np.ndarray  # (N, K, 2) m, the true positions w_k[n]
    nodes: np.ndarray  # (K, N, 3, Q), node k's rate kernel in slot n, padded (zero weight) to Q
    params: np.ndarray  # (K, N, P)
    lo: np.ndarray  # (K, 2) m, each node's report clip, lower corner
    hi: np.ndarray  # (K, 2) m, upper corner
    reports: np.ndarray  # (N, K, 2) m, the clipped reports of the slots so far (NaN: not yet)
    measured: np.ndarray  # (K, N) bps/Hz, unclipped measured rates (NaN: not yet, or not served)
    tally: np.ndarray  # (K,) bps/Hz x slots, sum over slots of share x told rate (the served feature)
    config: ScenarioConfig
    filter: NodeFilter | None = None  # the Kalman filter of the reports so far (filter_estimate)
    # the kernels held for the episode's score (channel.hold_path_kernels: its maxmin_rate on the
    # true paths finds them instead of building them again)
    held: tuple[HeldKernels, ...] = ()


def start_nodes_track(
    config: ScenarioConfig, rng: np.random.Generator, sigma: float, width: int
) -> NodesTrack:
    """Draw the episode's K node paths from ``rng`` and build every node's kernel per slot
    (``path_kernels`` of ``config.node_config(k)``), padded to ``width`` surface nodes (at least)."""
    paths = node_paths(config, rng)
    nodes, params, held = nodes_track_kernels(config, paths, width)
    lo, hi = _rectangles(config)
    margin = REPORT_CLIP * sigma
    return NodesTrack(
        paths, nodes, params, lo - margin, hi + margin, np.full((config.N, config.K, 2), np.nan),
        np.full((config.K, config.N), np.nan), np.zeros(config.K), config, held=held,
    )  # fmt: skip


def nodes_track_kernels(
    config: ScenarioConfig, paths: np.ndarray, width: int
) -> tuple[np.ndarray, np.ndarray, tuple[HeldKernels, ...]]:
    """(nodes (K, N, 3, Q), params (K, N, P), held): every node's kernel per slot of the (N, K, 2)
    ``paths`` (``path_kernels`` of ``config.node_config(k)``), padded to ``width`` surface nodes (at
    least), and the objects holding them for the episode's score (:func:`start_nodes_track`'s)."""
    own = kernel_width(config)  # (every node's kernel geometry is the scenario's)
    q, k_nodes, slots = max(width, own), config.K, config.N
    nodes = np.empty((k_nodes * slots, 3, q))
    nodes[:, 0, own:], nodes[:, 1, own:], nodes[:, 2, own:] = 0.0, 1.0, 0.0  # zero weight
    params = np.empty((k_nodes * slots, len(PARAMS)))
    # every node's kernels in one call, written into the track's arrays: the nodes share the kernel
    # geometry and each point's kernel is its own (path_kernels), so node k's rows are those of
    # path_kernels(config.node_config(k), paths[:, k])
    grounds = paths.transpose(1, 0, 2).reshape(k_nodes * slots, 2)
    path_kernels(kernel_config(config), grounds, out=(nodes[:, :, :own], params))
    nodes, params = nodes.reshape(k_nodes, slots, 3, q), params.reshape(k_nodes, slots, len(PARAMS))
    held = tuple(
        hold_path_kernels(config.node_config(k), paths[:, k], nodes[k, :, :, :own], params[k])
        for k in range(config.K)
    )  # (views of the track's arrays: no copy)
    return nodes, params, held


def observe_nodes(
    track: NodesTrack,
    slot: int,
    q: np.ndarray,
    shares: np.ndarray,
    knowledge: str,
    sigma: float,
    rate_high: float,
    rng: np.random.Generator,
    estimate: bool = False,
    *,
    expected: np.ndarray,
    params: np.ndarray,
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """What the UAV at ``q`` learns of the K nodes in ``slot`` (0-based) with the slot's ``shares``
    (K,), drawn from ``rng`` as ``baselines.mpc.run_online`` draws it: every node's report (K x 2
    normals, ``"reports"``), then two normals per node in node order (``"reports"`` and
    ``"rates"``), a measured rate for a served node (share > ``SERVED_SHARE``):
    ``channel.faded_of_rate`` of the node's expected-gain rate at ``q`` in the slot (``expected``
    (K,), the step's) and its kernel's scalars (``params`` (K, P), the slot's). Returns the told positions
    ((K, 2) m: the truth, the clipped reports or, with ``estimate``, the Kalman filter's clipped
    estimate; None for ``"rates"``) and the told rates ((K,) bps/Hz, clipped to ``rate_high``, NaN
    for a node not served; None for ``"exact"``). Adds share x told rate to ``track.tally``."""
    truth = track.paths[slot]
    told: np.ndarray | None = truth
    if knowledge == "reports":
        told = _reported(track, slot, rng, sigma, estimate)
    if knowledge == "exact":
        return told, None
    rates = np.full(len(truth), np.nan)
    x, y = float(q[0]), float(q[1])
    for k in range(len(truth)):
        n_re, n_im = rng.standard_normal(2)  # drawn for every node: the stream ignores the shares
        if shares[k] > SERVED_SHARE:
            rate = faded_of_rate(float(expected[k]), x, y, float(n_re), float(n_im), params, k)
            track.measured[k, slot] = rate
            rates[k] = min(rate, rate_high)
            track.tally[k] += shares[k] * rates[k]
    return (None if knowledge == "rates" else told), rates


def nodes_extent(config: ScenarioConfig, sigma: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """((x_lo, x_hi), (y_lo, y_hi)) m: where a told position of any node of ``config`` can be (the
    union of the nodes' rectangles widened by the report clip)."""
    lo, hi = _rectangles(config)
    margin = REPORT_CLIP * sigma
    return (
        (float(lo[:, 0].min()) - margin, float(hi[:, 0].max()) + margin),
        (float(lo[:, 1].min()) - margin, float(hi[:, 1].max()) + margin),
    )
