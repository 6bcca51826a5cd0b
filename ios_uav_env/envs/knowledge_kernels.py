"""Compiled observation of the moving-node rows of the batched single-node env.

``IOSUAVVectorEnv`` with a moving or roughly known node tells every row what its UAV learns of
the node after each slot (``ios_uav_env.envs.knowledge.observe_slot``, the single env's per-row
path) in one compiled call over the rows: :func:`observe_rows`. The draws stay each row's own:
per row, the batched env draws the slot's normals in ONE ``standard_normal(k)`` call of the row's
generator (:data:`DRAWS`: the report's two, then the measured rate's two; numpy's Generator
gives one call of four the stream of two calls of two), and the kernel does the per-row
arithmetic as the per-row path does (the report ``w + s e`` and its clip and the position
features in IEEE arithmetic, the faded rate with ``channel.faded_row``'s own flags), so the
rows equal the single env's bit for bit (tested, with and without numba). The Kalman filter of
``filter_estimate`` stays Python per row (``knowledge.filter_report`` on the raw reports the
kernel leaves in ``raw``). ``slot_weights.put_slot_kernels`` puts each row's rate kernel of the
slot it flies to in the row.

The rows' tracks are held as lists of their arrays (:func:`row_list`: a numba typed list, or a
plain list without numba), set once per episode and row; the kernels write the track records
(``reports``, ``measured``) in place.

:class:`EpisodeDraws` draws a row's normals of every slot of its episode in ONE call of its
generator when the episode begins (both batched envs, channel "expected": nothing else draws
from a row's generator between its slots), then hands them out slot by slot, and rewinds the
generator to where the slots so far leave it when an episode is cut short (a reset or restart
without a seed): a Python call per row and episode instead of one per row and slot, the same
stream (``standard_normal`` of n x d is the stream of n calls of d).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ios_uav_env.jit import HAVE_NUMBA, jit
from ios_uav_env.model.channel import faded_row

__all__ = [
    "DRAWS",
    "MODES",
    "EpisodeDraws",
    "measure_rates",
    "observe_rows",
    "row_list",
    "tell_positions",
]

#: knowledge -> the kernel's mode code
MODES = {"exact": 0, "reports": 1, "rates": 2}
#: knowledge -> normals drawn per slot (the report's two, then the measured rate's two)
DRAWS = {"exact": 0, "reports": 4, "rates": 2}


def row_list(template: np.ndarray, size: int) -> Any:
    """A list of ``size`` arrays, each ``template`` until set, that the kernels take: a numba typed
    list of ``template``'s array type (the compiled kernels), or a plain list."""
    if not HAVE_NUMBA:
        return [template] * size
    from numba.typed import List

    out = List()
    for _ in range(size):
        out.append(template)
    return out


class EpisodeDraws:
    """Each row's standard normals for every slot of its episode, drawn when the episode begins
    (module docstring). ``normals`` (B, S, W): row i's slot n in ``normals[i, n, :width[i]]``."""

    def __init__(self, rows: int, slots: int, width: int) -> None:
        self.normals = np.zeros((rows, max(slots, 1), width))
        self.width = np.zeros(rows, dtype=np.int64)  # normals per slot of the row's episode (0: none drawn)
        self.slots = np.zeros(rows, dtype=np.int64)  # N of the row's episode
        self.taken = np.zeros(rows, dtype=np.int64)  # slots handed out so far
        self._before: list[Any] = [None] * rows  # each row's generator and its state before the draw

    def draw(self, i: int, generator: np.random.Generator, slots: int, width: int) -> None:
        """Draw row ``i``'s episode of ``slots`` slots, ``width`` normals each, from ``generator``
        (one call: the stream of ``slots`` calls of ``width``), after what it drew so far."""
        if slots > self.normals.shape[1]:
            grown = np.zeros((self.normals.shape[0], slots, self.normals.shape[2]))
            grown[:, : self.normals.shape[1]] = self.normals
            self.normals = grown
        self._before[i] = (generator, generator.bit_generator.state)
        self.normals[i, :slots, :width] = generator.standard_normal(slots * width).reshape(slots, width)
        self.width[i], self.slots[i], self.taken[i] = width, slots, 0

    def take(self, rows: np.ndarray, slots: np.ndarray, out: np.ndarray) -> None:
        """``out[i] = normals[i, slot]`` for each row ``i`` of ``rows`` at its ``slots`` entry (the
        slot it observes), in one gather; each row has taken one slot more."""
        out[rows] = self.normals[rows, slots]
        self.taken[rows] += 1

    def rewind(self, rows: np.ndarray, seeds: Any) -> None:
        """Before ``rows`` begin new episodes (``seeds``: each row's seed, None for none): a row whose
        episode was cut short and keeps its generator (no seed) gets the generator as the slots it
        took leave it (its state before the draw, then those slots' normals drawn again); every
        row forgets its draw."""
        for i, seed in zip(rows.tolist(), seeds, strict=True):
            if seed is None and self.width[i] and self.taken[i] < self.slots[i]:
                generator, state = self._before[i]
                generator.bit_generator.state = state
                generator.standard_normal(int(self.taken[i] * self.width[i]))
            self.width[i], self._before[i] = 0, None


def observe_rows(
    rows: np.ndarray,
    state: np.ndarray,
    paths: Any,
    reports: Any,
    measured: Any,
    nodes: Any,
    params: Any,
    lo: np.ndarray,
    hi: np.ndarray,
    row_nodes: np.ndarray,
    row_params: np.ndarray,
    normals: np.ndarray,
    mode: int,
    sigma: float,
    rate_high: float,
    scale: float,
    positions: bool,
    obs: np.ndarray,
    raw: np.ndarray,
) -> None:
    """What the UAV of each row in ``rows`` (int64) is told of its node in its current slot
    (``state[i, 2]``, 0-based), as ``knowledge.observe_slot`` tells it (module docstring).

    Row i's track: ``paths[i]`` (N, 1, 2), ``reports[i]`` (N, 1, 2) and ``measured[i]`` (N,) (the
    records, written in place), ``nodes[i]`` / ``params[i]`` its kernels per slot, ``lo[i]`` /
    ``hi[i]`` its report clip; ``row_nodes[i]`` / ``row_params[i]`` the row's kernel of the slot
    (the step's, ``slot_weights.put_slot_kernels``), which the measured rate reads where it has the
    track's width (the row's, in cache, instead of the track's slot far in memory); ``normals[i]``
    the slot's draws (``DRAWS``). ``mode``: ``MODES``; ``sigma`` the report std, ``rate_high``
    the measured rate's clip, ``scale`` the observation's length scale. Writes the node features
    (4-5; unless ``positions`` is False: the filter's, written after) and, unless knowledge is
    exact, the rate feature (10) of ``obs[i]``, and the raw report in ``raw[i]`` (``"reports"``).

    Two compiled calls, neither inlined into the other: :func:`tell_positions` in IEEE
    arithmetic (as numpy computes a report and a feature) and :func:`measure_rates` with the
    kernels' fast-math flags (those ``channel.faded_row`` has when called from Python; inlined
    into an IEEE function it rounds differently)."""
    if mode != 2 or positions:
        tell_positions(rows, state, paths, reports, lo, hi, normals, mode, sigma, scale, positions, obs, raw)
    if mode != 0:
        kernels = (nodes, params, row_nodes, row_params)
        measure_rates(rows, state, measured, *kernels, normals, 2 if mode == 1 else 0, rate_high, obs)


@jit(fastmath=False)
def tell_positions(
    rows: np.ndarray,
    state: np.ndarray,
    paths: Any,
    reports: Any,
    lo: np.ndarray,
    hi: np.ndarray,
    normals: np.ndarray,
    mode: int,
    sigma: float,
    scale: float,
    positions: bool,
    obs: np.ndarray,
    raw: np.ndarray,
) -> None:
    """The node features of :func:`observe_rows` (and the reports), in IEEE arithmetic."""
    for j in range(rows.size):
        i = rows[j]
        if mode == 2:
            obs[i, 4] = 0.0
            obs[i, 5] = 0.0
            continue
        slot = int(state[i, 2])
        path = paths[i]
        px, py = path[slot, 0, 0], path[slot, 0, 1]
        if mode == 1:
            rx = px + sigma * normals[i, 0]
            ry = py + sigma * normals[i, 1]
            raw[i, 0], raw[i, 1] = rx, ry
            px = min(max(rx, lo[i, 0]), hi[i, 0])
            py = min(max(ry, lo[i, 1]), hi[i, 1])
            report = reports[i]
            report[slot, 0, 0], report[slot, 0, 1] = px, py
        if positions:
            obs[i, 4] = (px - state[i, 0]) / scale
            obs[i, 5] = (py - state[i, 1]) / scale


@jit
def measure_rates(
    rows: np.ndarray,
    state: np.ndarray,
    measured: Any,
    nodes: Any,
    params: Any,
    row_nodes: np.ndarray,
    row_params: np.ndarray,
    normals: np.ndarray,
    first: int,
    rate_high: float,
    obs: np.ndarray,
) -> None:
    """The measured rates of :func:`observe_rows` (``normals[i, first:first + 2]``), recorded
    unclipped and told clipped to ``rate_high``: on the row's kernel of the slot (``row_nodes[i]``,
    ``row_params[i]``: the track's slot copied, the same numbers) where it has the track's width
    (the same sum), else on the track's."""
    for j in range(rows.size):
        i = rows[j]
        slot = int(state[i, 2])
        x, y, n_re, n_im = state[i, 0], state[i, 1], normals[i, first], normals[i, first + 1]
        kernel, scalars, at = row_nodes, row_params, i
        if nodes[i].shape[2] != row_nodes.shape[2]:
            kernel, scalars, at = nodes[i], params[i], slot
        rate = faded_row(x, y, n_re, n_im, kernel, scalars, at)
        measured[i][slot] = rate
        obs[i, 10] = rate_high if rate_high < rate else rate
