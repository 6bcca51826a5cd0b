"""The drawn episodes of the batched moving-node env, made for all resetting rows at once.

``ios_uav_env/IOSUAV-Mobile-v0`` draws a scenario (``scenarios.sample_scenario``) and the node's
path (``motion.node_paths``) at every reset. Its batched env (``single_rows.SingleNodeRows``)
used to make both per row through the row env (``begin_episode``, ``start_track``): a validated
``ScenarioConfig``, its rate kernel, the episode row, the path and its slot weights, all Python
per row. :class:`DrawnEpisodes` makes the same episode for every resetting row at once:

1. per row, the row's generator draws the numbers the single env's reset draws, in its order and
   with the same calls' streams (``uniform(lo, hi)`` is ``lo + (hi - lo) * random()``, bit for bit;
   the integers with the very calls of ``scenarios._draw``; the velocity's and the slots' normals in
   one ``standard_normal`` call, the stream of ``node_paths``' calls), then the episode's
   observation normals (``knowledge_kernels.EpisodeDraws``);
2. one compiled call (:func:`draw_episodes`) turns them into the scenario's drawn fields (G moved
   off the IOS plane's strip as ``scenarios._off_plane`` does), checks what the config's
   validation checks of them (the node in its motion rectangle, off the IOS plane, T long enough:
   a row that fails is built as a ``ScenarioConfig``, whose validation raises its own error), walks
   the node path (``motion._walk``'s arithmetic) and writes the episode row's drawn columns, the
   report clip, the records and the UAV's start;
3. one compiled call (:func:`start_rows`) writes each row's first kernel (its kernel geometry's,
   surface and IOS rows, from padded tables of the geometries met so far, with G's weights and
   scalars) and the surface weights of its first :data:`WINDOW` slots into a small per-row window;
   at each step :func:`put_rows` puts the slot's kernel in the row, computing the next window when
   the slot leaves the last (``surface.path_weights_into``'s numbers: a point's weights are its own
   arithmetic, whatever points they are computed with). No (B, N_max, n) buffer of every slot's
   weights: nothing large to fault in at the first reset, nothing far in memory to read per step.

Everything is IEEE arithmetic in the order of the Python code it replaces: the same episode bit
for bit (tested against the single env). No ``ScenarioConfig`` is made per reset: a row's config
(and its row env's rate kernel, episode row and track) is built when someone asks for it
(:meth:`DrawnEpisodes.config`; the row env defers its episode to it,
``single_mobile.MobileNode.defer_episode``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ios_uav_env.envs.knowledge import REPORT_CLIP, NodeTrack
from ios_uav_env.envs.mobile_draw_kernels import (
    C_BOX,
    C_BOX_MARGIN,
    C_CX,
    C_CY,
    C_D,
    C_DT,
    C_GAIN,
    C_GAP,
    C_HAS_BOX,
    C_HEADING,
    C_INV_L,
    C_MARGIN,
    C_MEMORY,
    C_SIGMA,
    C_SPEED,
    C_T_SCALE,
    N_CONSTANTS,
    WINDOW,
    draw_episodes,
    put_rows,
    start_rows,
    take_slot_normals,
)
from ios_uav_env.envs.observation import T_SCALE
from ios_uav_env.envs.single_kernels import episode_row
from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.mobility import BOX_MARGIN, GaussMarkov
from ios_uav_env.model.rate_kernels import rate_kernel
from ios_uav_env.model.scenarios import ScenarioRanges, drawn_changes
from ios_uav_env.model.surface import interpolation_terms

__all__ = [
    "WINDOW",
    "DrawnEpisodes",
    "draw_constants",
    "draw_episodes",
    "put_rows",
    "start_rows",
    "take_slot_normals",
    "takes_drawn_episodes",
]

#: The uniform draws of a row, in order: G's x and y, q0's x and y, qF's x and y, the heading.
N_UNIFORM = 7


def draw_constants(base: ScenarioConfig, options: Any) -> np.ndarray:
    """The scalars the compiled draws read, at their ``C_*`` indices (``mobile_draw_kernels``), of
    the scenarios on ``base`` (its motion, IOS centre, dt and D) and the env's ``options``
    (``EnvOptions``: the report clip's margin, the length scale)."""
    motion = base.motion
    c = np.zeros(N_CONSTANTS)
    c[C_CX], c[C_CY], c[C_GAP] = float(base.ios_center[0]), float(base.ios_center[1]), motion.plane_margin
    c[C_HAS_BOX] = float(motion.box is not None)
    if motion.box is not None:
        c[C_BOX : C_BOX + 4] = np.ravel(motion.box)
    c[C_HEADING] = 0.0 if motion.heading is None else motion.heading
    c[C_SPEED], c[C_SIGMA], c[C_MEMORY] = motion.speed, motion.sigma, motion.memory
    c[C_GAIN] = math.sqrt(1.0 - motion.memory * motion.memory) * motion.sigma  # (node_paths' gain)
    c[C_DT], c[C_D], c[C_MARGIN] = base.dt, base.D, REPORT_CLIP * float(options.report_sigma)
    c[C_INV_L], c[C_T_SCALE], c[C_BOX_MARGIN] = 1.0 / options.length_scale, T_SCALE, BOX_MARGIN
    return c


def takes_drawn_episodes(template: Any) -> bool:
    """Whether the batched rows of ``template`` (a ``UAVEnv`` of the v0 view) can make their
    episodes with :class:`DrawnEpisodes`: a randomised (``draws``) moving env of one node whose
    every reset draws from its ranges (no pinned config, no focus), with the rate objective, the
    expected channel, no filter and no peak hint, compiled (numba)."""
    row = template.stepper
    if not (HAVE_NUMBA and template.draws and row.mobile):
        return False
    options = row.options
    ranges = getattr(row, "ranges", None)
    return (
        isinstance(ranges, ScenarioRanges)
        and row.pinned is None
        and row.focus_prob == 0.0
        and isinstance(ranges.base.motion, GaussMarkov)
        and ranges.base.K == 1
        and not row.energy_objective
        and options.channel == "expected"
        and not options.filter_estimate
        and not options.peak_hint
    )


class DrawnEpisodes:
    """The drawn episodes of ``rows`` rows (module docstring): their draws, scenario fields and
    node paths (``paths`` (B, S, 1, 2), ``reports`` (B, S, 1, 2), ``measured`` (B, S): the tracks'
    arrays, ``S`` the most slots), for ``template``'s ranges and options."""

    def __init__(self, template: Any, rows: int) -> None:
        row = template.stepper
        self.ranges: ScenarioRanges = row.ranges
        options = row.options
        base, motion = self.ranges.base, self.ranges.base.motion
        slots = max(int(row.max_slots), 2)
        self.slot_range = self.ranges.slot_range
        self.paths = np.zeros((rows, slots, 1, 2))
        self.reports = np.full((rows, slots, 1, 2), np.nan)
        self.measured = np.full((rows, slots), np.nan)
        self.uniform = np.zeros((rows, N_UNIFORM))
        self.slots = np.zeros(rows, dtype=np.int64)
        self.ios_rows = np.zeros(rows, dtype=np.int64)
        self.surface = np.zeros(rows, dtype=np.int64)
        self.normals = np.zeros((rows, 2 * slots))
        self.ground = np.zeros((rows, 2))
        self.ends = np.zeros((rows, 4))  # q0's x, y, qF's x, y
        self.bad = np.zeros(rows, dtype=np.int64)
        self.dx2 = np.zeros((rows, slots))
        r = self.ranges
        self.intervals = np.array(
            [r.ground_x, r.ground_y, r.start_x, r.start_y, r.end_x, r.end_y], dtype=np.float64
        )
        self.cuts = np.array([s != "none" for s in r.surfaces], dtype=np.bool_)
        heading = motion.heading
        self.constants = draw_constants(base, options)  # (the scalars of the kernel)
        self.length_scale = options.length_scale
        self.heading_drawn = heading is None
        self.clip: tuple[np.ndarray, np.ndarray] = (np.zeros((rows, 2)), np.zeros((rows, 2)))
        self.geometries: dict[tuple[int, int, int], int] = {}  # (surface, rows, width) -> index or -1
        self.table: list[Any] = []  # the geometries (DrawnEpisodes.geometry), in index order
        self.tables: tuple[np.ndarray, ...] = ()  # the same as the kernels take them (_stack)
        # each windowed row's geometry, its weights of WINDOW slots from slot ``first``, its kernel
        # scalars (G's of slot 0) and the power 1.5 of its slots' dx2
        self.windowed = np.zeros(rows, dtype=np.bool_)
        self.geometry_of = np.zeros(rows, dtype=np.int64)
        self.weights = np.zeros((rows, WINDOW, 1))
        self.first = np.zeros(rows, dtype=np.int64)
        self.base = np.zeros((rows, template.kernel.params.size))
        self.scale = np.zeros((rows, slots))

    # --- per row: the draws --------------------------------------------------------------
    def draw(self, i: int, rng: np.random.Generator) -> int:
        """Row ``i``'s scenario and path draws from ``rng`` (module docstring, step 1); its N."""
        r = self.ranges
        u = self.uniform[i]
        rng.random(out=u[0:2])  # G (two uniform(lo, hi) calls)
        n = int(rng.integers(self.slot_range[0], self.slot_range[1], endpoint=True))
        self.ios_rows[i] = int(rng.integers(r.ios_rows[0], r.ios_rows[1], endpoint=True))
        self.surface[i] = int(rng.integers(len(r.surfaces)))
        rng.random(out=u[2 : 7 if self.heading_drawn else 6])  # q0, qF (and node_paths' heading)
        if 2 * n > self.normals.shape[1]:
            raise RuntimeError(
                f"a drawn episode of N = {n} slots exceeds the space's {self.normals.shape[1] // 2}"
            )
        rng.standard_normal(out=self.normals[i, : 2 * n])  # v[0], then the slots' (node_paths)
        self.slots[i] = n
        return n

    # --- per batch: the compiled episode ---------------------------------------------------
    def make(self, rows: np.ndarray, state: np.ndarray, path: np.ndarray, episode: np.ndarray,
             lo: np.ndarray, hi: np.ndarray) -> None:  # fmt: skip
        """Step 2 for ``rows`` (int64; drawn): their fields, checks, paths, records, the episode
        row's drawn columns (the rest: their geometry's, :meth:`geometry`) and the UAV's start.
        A row the checks flag is built as its ``ScenarioConfig`` (which raises the validation's
        error); one that passes it after all goes on."""
        self.clip = (lo, hi)
        theta = self.uniform[rows, 6] * (2.0 * math.pi) + 0.0  # uniform(0, 2 pi): 0 + 2 pi u
        headings = np.zeros((rows.size, 2))
        headings[:, 0], headings[:, 1] = np.cos(theta), np.sin(theta)  # (numpy's, as node_paths)
        if not self.heading_drawn:
            fixed = np.full(1, self.constants[C_HEADING])
            headings[:, 0], headings[:, 1] = np.cos(fixed)[0], np.sin(fixed)[0]
        draw_episodes(rows, self.uniform, self.slots, self.surface, self.normals, headings, self.intervals,
                      self.cuts, self.constants, self.ground, self.ends, self.paths, self.reports,
                      self.measured, lo, hi, self.dx2, self.bad, state, path, episode)  # fmt: skip
        for i in np.flatnonzero(self.bad[rows]).tolist():
            self.config(int(rows[i]))  # (raises the config's own error)

    def geometries_of(self, rows: np.ndarray, width: int) -> np.ndarray:
        """Each of ``rows``' kernel geometry (its index in the tables, :meth:`geometry`; -1: none)."""
        codes = self.surface[rows] * (1 << 32) + self.ios_rows[rows]
        keys, first, inverse = np.unique(codes, return_index=True, return_inverse=True)
        ids = np.array([self.geometry(int(rows[j]), width) for j in first.tolist()], dtype=np.int64)
        return ids[np.ravel(inverse)] if keys.size else ids

    def geometry(self, i: int, width: int) -> int:
        """The index of row ``i``'s kernel geometry in the tables (its base kernel's nodes and params,
        its episode row, the weights' terms of ``surface.interpolation_terms``), added from the
        row's config at its first row; -1 where the compiled weights do not apply (the row reads its
        track, as ``SlotWeights`` leaves it) or its surface has fewer nodes than ``width``."""
        key = (int(self.surface[i]), int(self.ios_rows[i]), int(width))
        found = self.geometries.get(key)
        if found is not None:
            return found
        cfg = self.config(i)
        kernel = rate_kernel(cfg)
        terms = interpolation_terms(cfg)
        fits = terms is not None and kernel.nodes.shape[1] == width == terms[4].shape[1] * terms[5].shape[1]
        if not fits:
            self.geometries[key] = -1
            return -1
        assert terms is not None
        self.table.append(
            (kernel.nodes, kernel.params, episode_row(cfg, self.length_scale, (0.0, 0.0, 0.0)), terms)
        )
        self.geometries[key] = len(self.table) - 1
        self.tables = _stack(self.table)
        return self.geometries[key]

    def config(self, i: int) -> ScenarioConfig:
        """Row ``i``'s scenario as ``sample_scenario`` makes it (validated: a ``ValueError`` of the
        config for a draw it refuses)."""
        r = self.ranges
        g, e = self.ground[i].tolist(), self.ends[i].tolist()
        changes = drawn_changes(
            r, (g[0], g[1]), int(self.slots[i]), int(self.ios_rows[i]), r.surfaces[int(self.surface[i])],
            (e[0], e[1]), (e[2], e[3]),
        )  # fmt: skip
        return r.base.replace(**changes)

    def track(self, i: int, cfg: ScenarioConfig) -> NodeTrack:
        """Row ``i``'s track on its scenario ``cfg`` (``knowledge.start_track``'s): views of the
        batch's path and records (the batched env records the slots in them) and the report clip."""
        n = int(self.slots[i])
        lo, hi = self.clip
        return NodeTrack(
            self.paths[i, :n], lo[i].copy(), hi[i].copy(), self.reports[i, :n], self.measured[i, :n], cfg
        )

    def start(self, rows: np.ndarray, geometry: np.ndarray, nodes: np.ndarray, params: np.ndarray,
              episode: np.ndarray) -> None:  # fmt: skip
        """Step 3 for ``rows`` (int64) of ``geometry`` (their indices, none -1): each row's first
        window of slot weights, its kernel scalars, the first slot's kernel into ``nodes`` /
        ``params`` and the geometry's columns of the episode row; the rows are ``windowed``."""
        width = nodes.shape[2]
        if self.weights.shape[2] != width:
            self.weights = np.zeros((self.weights.shape[0], WINDOW, width))
        self.scale[rows] = self.dx2[rows] ** 1.5  # (numpy's power, as path_weights_into takes it)
        self.geometry_of[rows] = geometry
        start_rows(rows, geometry, *self.tables, self.paths, self.slots, self.dx2, self.scale, self.weights,
                   self.first, self.base, nodes, params, episode)  # fmt: skip
        self.windowed[rows] = True

    def put(self, rows: np.ndarray, state: np.ndarray, nodes: np.ndarray, params: np.ndarray) -> None:
        """Each ``windowed`` row of ``rows``' kernel of the slot it flies to (``state[i, 2] + 1``)
        into ``nodes`` / ``params``, as ``slot_weights.put_slot_kernels`` puts a buffered row's;
        a row past its episode's end is left as it is."""
        put_rows(rows, state, self.windowed, *self.tables, self.paths, self.slots, self.dx2, self.scale,
                 self.weights, self.first, self.base, nodes, params, self.geometry_of)  # fmt: skip


def _stack(table: list[Any]) -> tuple[np.ndarray, ...]:
    """The geometries of ``table`` as the padded arrays the kernels take: factor (G,), x_c (G,),
    gy (G, PY), gz2 (G, PZ), ky_t (G, PY, NY), kz_t (G, PZ, NZ), their sizes (G, 4: py, pz, ny,
    nz), the base kernels' node coordinates (G, 2, n) and params (G, P), the episode rows (G, E)."""
    terms = [entry[3] for entry in table]
    g = len(table)
    py = max(t[2].size for t in terms)
    pz = max(t[3].size for t in terms)
    ny = max(t[4].shape[1] for t in terms)
    nz = max(t[5].shape[1] for t in terms)
    factor, cx = np.zeros(g), np.zeros(g)
    gy, gz2, ky, kz = np.zeros((g, py)), np.zeros((g, pz)), np.zeros((g, py, ny)), np.zeros((g, pz, nz))
    sizes = np.zeros((g, 4), dtype=np.int64)
    nodes = np.zeros((g, 2, table[0][0].shape[1]))
    params = np.zeros((g, table[0][1].size))
    rows = np.zeros((g, table[0][2].size))
    for j, (kernel_nodes, kernel_params, row, t) in enumerate(table):
        factor[j], cx[j] = t[0], t[1]
        a, b, c, d = t[2].size, t[3].size, t[4].shape[1], t[5].shape[1]
        gy[j, :a], gz2[j, :b], ky[j, :a, :c], kz[j, :b, :d] = t[2], t[3], t[4], t[5]
        sizes[j] = a, b, c, d
        nodes[j], params[j], rows[j] = kernel_nodes[:2], kernel_params, row
    return factor, cx, gy, gz2, ky, kz, sizes, nodes, params, rows
