"""The drawn episodes of the batched moving multi-node env, made for all resetting rows at once.

``ios_uav_env/IOSUAV-MultiNode-Mobile-v0`` draws a scenario of K nodes
(``scenarios.sample_multinode``) and the nodes' paths (``motion.node_paths``) at every reset. Its
batched env (``node_rows.NodeBlockRows``) used to make both per row through the row env
(``begin_episode``, ``load_row_bare``): a validated ``ScenarioConfig``, the paths, the track, the
ground points of ``node_weights.NodeWeights.load``, the row's scenario arrays, all Python per row.
:class:`DrawnNodeEpisodes` makes the same episode for every resetting row at once, as
``mobile_draws.DrawnEpisodes`` does for one node:

1. per row, the row's generator draws the numbers the single env's reset draws, in its order and
   with the same calls' streams (``uniform(lo, hi)`` is ``lo + (hi - lo) * random()``, bit for bit;
   the integers with the very calls of ``sample_multinode`` and ``scenarios._draw``; the nodes'
   headings, then their velocities' and the slots' normals in one ``standard_normal`` call: the
   stream of ``node_paths``' calls), then the episode's observation normals
   (``knowledge_kernels.EpisodeDraws``, by the batched env);
2. one compiled call (``node_draw_kernels.draw_node_episodes``) turns them into the scenario's
   drawn fields (the nodes moved off the IOS plane's strip as ``scenarios._off_plane`` does),
   checks what the config's validation checks of them (every node in its motion rectangle, off
   the IOS plane, T long enough: a row that fails is built as a ``ScenarioConfig``, whose
   validation raises its own error), walks the paths (``motion._walk``'s arithmetic), writes the
   track's records (the batch's buffers), the ground points of every slot and node (their scale's
   power 1.5 then by numpy, as ``NodeWeights.load`` takes it: numpy's power is not libm's), the rows'
   node points, the episode row's drawn columns and the UAV's start;
3. one compiled call (``node_draw_kernels.start_node_rows``) puts each row's kernel geometry (one
   per surface kind and IOS rows, from the row's config at its first row: ``NodeWeights``'
   projection, J and kernel scalars, the kernels' node coordinates, the episode row's other
   columns) in the rows; each slot's node kernels are then ``node_weights.put_node_weights``'.

Everything is IEEE arithmetic in the order of the Python code it replaces: the same episode bit
for bit (tested against the single env). No ``ScenarioConfig`` is made per reset: a row's config
and track are built when someone asks for them (:meth:`DrawnNodeEpisodes.config`; the row env
defers its episode to it, ``multi_mobile.MobileNodes.defer_episode``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ios_uav_env.envs.mobile_draw_kernels import C_CX
from ios_uav_env.envs.mobile_draws import draw_constants
from ios_uav_env.envs.multi_table import episode_row
from ios_uav_env.envs.node_draw_kernels import draw_node_episodes, start_node_rows
from ios_uav_env.envs.node_weights import PT_SCALE, BareNodesTrack
from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.mobility import GaussMarkov
from ios_uav_env.model.scenarios import ScenarioRanges, drawn_changes, multinode_changes

__all__ = ["DrawnNodeEpisodes", "takes_drawn_nodes"]


def takes_drawn_nodes(template: Any) -> bool:
    """Whether the batched rows of ``template`` (a ``UAVEnv`` of the node-block view) can make their
    episodes with :class:`DrawnNodeEpisodes`: moving nodes of a Gauss-Markov motion drawn at every
    reset (``random_nodes``), the rate objective without an energy budget, the expected channel, no
    filter and no peak hint, compiled (numba)."""
    row = template.stepper
    if not (HAVE_NUMBA and row.mobile and row.random_nodes):
        return False
    options, ranges = row.options, row.ranges
    return (
        isinstance(ranges, ScenarioRanges)
        and isinstance(ranges.base.motion, GaussMarkov)
        and ranges.base.energy_budget_j is None
        and not row.energy_objective
        and options.channel == "expected"
        and not options.filter_estimate
        and not options.peak_hint
    )


class DrawnNodeEpisodes:
    """The drawn episodes of ``rows`` rows (module docstring): their draws, scenario fields and the
    nodes' tracks (``paths`` and ``reports`` (B, S, K_max, 2), ``measured`` (B, K_max, S),
    ``tally`` (B, K_max): the batch's records, ``S`` the most slots), for ``template``'s ranges and
    options; ``kernel_rows`` and ``weights``: the batch's ``NodeRows`` and ``NodeWeights``."""

    def __init__(self, template: Any, rows: int, kernel_rows: Any, weights: Any) -> None:
        row = template.stepper
        self.ranges: ScenarioRanges = row.ranges
        self.node_range: tuple[int, int] = row.random_nodes
        self.kernel_rows, self.weights = kernel_rows, weights
        base, motion = self.ranges.base, self.ranges.base.motion
        self.slot_range: tuple[int, int] = self.ranges.slot_range  # (N's range: a property computing it)
        k, slots = row.max_nodes, self.slot_range[1]
        self.slots = np.zeros(rows, dtype=np.int64)
        self.counts = np.zeros(rows, dtype=np.int64)
        self.ios_rows = np.zeros(rows, dtype=np.int64)
        self.surface = np.zeros(rows, dtype=np.int64)
        self.uniform = np.zeros((rows, 2 * k + 2))  # the nodes' x, y, G's (draw)
        self.late = np.zeros((rows, 4 + k))  # q0's x, y, qF's x, y, the nodes' headings (draw)
        self.headings = np.zeros((rows, k, 2))
        self.normals = np.zeros((rows, 2 * k * slots))
        self.ends = np.zeros((rows, 4))  # q0's x, y, qF's x, y
        self.bad = np.zeros(rows, dtype=np.int64)
        self.width = np.zeros(rows, dtype=np.int64)  # the rows' kernel width at the draw (the track's)
        self.paths = np.zeros((rows, slots, k, 2))
        self.reports = np.full((rows, slots, k, 2), np.nan)
        self.measured = np.full((rows, k, slots), np.nan)
        self.tally = np.zeros((rows, k))
        if weights.points.shape[1] < slots:  # (every slot's ground points, NodeWeights.load's)
            weights.points = np.zeros((rows, slots, k, weights.points.shape[3]))
        r = self.ranges
        self.intervals = np.array(
            [r.ground_x, r.ground_y, r.start_x, r.start_y, r.end_x, r.end_y], dtype=np.float64
        )
        self.cuts = np.array([s != "none" for s in r.surfaces], dtype=np.bool_)
        self.constants = draw_constants(base, row.options)  # (the scalars the kernel reads)
        self.heading: float | None = motion.heading
        # each (surface, IOS rows)'s geometry: its index in the tables, -1 none, -2 not met yet
        self.lookup = np.full((len(r.surfaces), r.ios_rows[1] + 1), -2, dtype=np.int64)
        self.table: list[tuple[Any, ...]] = []  # each geometry's entries (geometry), in index order
        self.tables: tuple[np.ndarray, ...] = ()  # the same as start_node_rows takes them (_stack)
        self.clip: tuple[np.ndarray, np.ndarray] = (np.zeros((rows, k, 2)), np.zeros((rows, k, 2)))

    # --- per row: the draws --------------------------------------------------------------
    def draw(self, i: int, rng: np.random.Generator) -> tuple[int, int]:
        """Row ``i``'s scenario and paths draws from ``rng`` (module docstring, step 1); its (N, K)."""
        r = self.ranges
        k = int(rng.integers(self.node_range[0], self.node_range[1], endpoint=True))
        if k > self.late.shape[1] - 4:
            raise RuntimeError(f"a drawn episode of K = {k} nodes exceeds the rows' {self.late.shape[1] - 4}")
        # the nodes' x, y (uniform(lo, hi) calls, node after node), then the scenario's own G (replaced)
        rng.random(out=self.uniform[i, : 2 * k + 2])
        n = int(rng.integers(*self.slot_range, endpoint=True))
        self.ios_rows[i] = int(rng.integers(r.ios_rows[0], r.ios_rows[1], endpoint=True))
        self.surface[i] = int(rng.integers(len(r.surfaces)))
        # q0, qF, then node_paths' uniform(0, 2 pi, K) headings (when drawn)
        rng.random(out=self.late[i, : 4 + k if self.heading is None else 4])
        if 2 * k * n > self.normals.shape[1]:
            raise RuntimeError(f"a drawn episode of N = {n} slots exceeds the space's")
        rng.standard_normal(out=self.normals[i, : 2 * k * n])  # v[0], then the slots' (node_paths)
        self.slots[i], self.counts[i] = n, k
        return n, k

    # --- per batch: the compiled episode ---------------------------------------------------
    def make(self, rows: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Steps 2 and 3 for ``rows`` (int64; drawn): their fields, checks, tracks, ground points,
        the rows' scenario arrays, ``lo`` / ``hi`` (B, K_max, 2) their report clips. A row the
        checks flag is built as its ``ScenarioConfig`` (which raises the validation's error); one
        that passes it after all goes on. Rows whose geometry the compiled weights do not take are
        left with ``weights.slots`` 0 (their envs' tracks put their kernels: the returned rows)."""
        kr, w = self.kernel_rows, self.weights
        self.clip = (lo, hi)
        k_max = self.late.shape[1] - 4
        theta = self.late[rows, 4:] * (2.0 * math.pi) + 0.0  # uniform(0, 2 pi): 0 + 2 pi u
        if self.heading is not None:
            theta = np.full((rows.size, k_max), self.heading)
        self.headings[rows, :, 0], self.headings[rows, :, 1] = np.cos(theta), np.sin(theta)  # (numpy's)
        kr.fit(0, int(self.slots[rows].max()))  # (the rows' arrays as long as the longest episode)
        draw_node_episodes(rows, self.uniform, self.late, self.counts, self.slots, self.surface, self.normals,
                           self.headings, self.intervals, self.cuts, self.constants, self.ends, self.paths,
                           self.reports, self.measured, self.tally, lo, hi, self.bad, w.points, kr.points,
                           kr.sizes, kr.state, kr.path, kr.episode)  # fmt: skip
        for i in np.flatnonzero(self.bad[rows]).tolist():
            self.config(int(rows[i]))  # (raises the config's own error)
        k, n = int(self.counts[rows].max()), int(self.slots[rows].max())
        # the ground points' scale dx2 ** 1.5: numpy's, as NodeWeights.load takes it (not libm's, numba's)
        w.points[rows, :n, :k, PT_SCALE] = w.points[rows, :n, :k, PT_SCALE] ** 1.5
        w.cx[rows] = self.constants[C_CX]
        geometry = self.geometries_of(rows)
        for i in rows.tolist():
            kr.loaded[i], kr.bare[i] = None, True
        fits = geometry >= 0
        w.slots[rows[~fits]] = 0
        if fits.any():
            kr.fit(int(self.tables[1][geometry[fits]].max()), 0)  # (the widest surface's nodes)
            start_node_rows(rows[fits], geometry[fits], self.counts, self.slots, *self.tables, w.slots,
                            w.counts, w.which, w.factors, w.base, kr.nodes, kr.episode)  # fmt: skip
        self.width[rows] = kr.nodes.shape[3]
        return rows[~fits]

    def geometries_of(self, rows: np.ndarray) -> np.ndarray:
        """Each of ``rows``' kernel geometry (its index in the tables, :meth:`geometry`; -1: none),
        the tables restacked once if geometries were added."""
        ids = self.lookup[self.surface[rows], self.ios_rows[rows]]
        met = len(self.table)
        for j in np.flatnonzero(ids == -2).tolist():  # (a geometry not met yet: from its first row)
            ids[j] = self.geometry(int(rows[j]))
        if len(self.table) > met:
            self.tables = _stack(self.table)
        return ids

    def geometry(self, i: int) -> int:
        """The index of row ``i``'s kernel geometry in the tables (``NodeWeights``' projection, Q,
        node coordinates, kernel scalars and J, the episode row of ``multi_table.episode_row``),
        added from the row's config at its first row (``tables`` restacked by :meth:`geometries_of`);
        -1 where the compiled weights do not apply (``NodeWeights.width`` None)."""
        key = (int(self.surface[i]), int(self.ios_rows[i]))
        found = int(self.lookup[key])
        if found != -2:
            return found
        cfg = self.config(i)
        held = self.weights.geometry(cfg)
        if held is None:
            self.lookup[key] = -1
            return -1
        _, projection, q, coords, params, factor, _ = held
        length_scale, sharpness, softmin_beta, _, clip = self.kernel_rows.settings
        row = episode_row(cfg, length_scale, sharpness, softmin_beta, False, 0.0, clip)
        self.table.append((projection, q, factor, coords, params, row))
        self.lookup[key] = len(self.table) - 1
        return len(self.table) - 1

    def config(self, i: int) -> ScenarioConfig:
        """Row ``i``'s scenario as ``sample_multinode`` makes it (validated: a ``ValueError`` of the
        config for a draw it refuses)."""
        r, k, e = self.ranges, int(self.counts[i]), self.ends[i].tolist()
        nodes = tuple((float(x), float(y)) for x, y in self.paths[i, 0, :k].tolist())
        changes = drawn_changes(
            r, nodes[0], int(self.slots[i]), int(self.ios_rows[i]), r.surfaces[int(self.surface[i])],
            (e[0], e[1]), (e[2], e[3]),
        )  # fmt: skip
        return r.base.replace(**multinode_changes(changes, nodes))

    def track(self, i: int, cfg: ScenarioConfig) -> BareNodesTrack:
        """Row ``i``'s track on its scenario ``cfg`` (``node_weights.start_bare_track``'s): views of
        the batch's paths and records (the batched env records the slots in them), its report clip
        (a copy of the rows'), kernels built when read."""
        n, k = int(self.slots[i]), int(self.counts[i])
        lo, hi = self.clip
        track = BareNodesTrack(self.paths[i, :n, :k], lo[i, :k].copy(), hi[i, :k].copy(), cfg,
                               int(self.width[i]))  # fmt: skip
        track.reports, track.measured = self.reports[i, :n, :k], self.measured[i, :k, :n]
        track.tally = self.tally[i, :k]
        return track


def _stack(table: list[tuple[Any, ...]]) -> tuple[np.ndarray, ...]:
    """The geometries of ``table`` as the padded arrays ``start_node_rows`` takes: projection (G,),
    Q (G,), J (G,), node coordinates (G, 2, Q_max), kernel scalars (G, P), episode rows (G, E)."""
    g = len(table)
    q_max = max(entry[1] for entry in table)
    which, widths = np.zeros(g, dtype=np.int64), np.zeros(g, dtype=np.int64)
    factors, coords = np.zeros(g), np.zeros((g, 2, q_max))
    params, rows = np.zeros((g, table[0][4].size)), np.zeros((g, table[0][5].size))
    for j, (projection, q, factor, xy, scalars, row) in enumerate(table):
        which[j], widths[j], factors[j] = projection, q, factor
        coords[j, :, :q], params[j], rows[j] = xy, scalars, row
    return which, widths, factors, coords, params, rows
