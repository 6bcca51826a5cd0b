r"""Several UAVs: the pieces of one UAV's SCA step in ``baselines.fleet_sca`` (derivations there).

:class:`Pieces` are node k's surrogate terms at UAV u's interior way-points, :func:`coefficients`
the tangent coefficients of every node's flight rate in u's slacks with the schedule's shares,
:func:`separation_rows` the separation's half-planes against the other UAVs' flights and
:func:`chords` the linear rows below (17)'s log z on the trust region.

**Horizons** (``model.fleet_horizons``): UAV u's variables are its way-points 1 .. N_u - 2 (its
start and its final point at slot N_u - 1 fixed, held after), so every piece is taken over those
m = N_u - 2 slots; the rates are still averaged over the scenario's N slots (the schedule's); a
pair's separation rows are only for the slots both UAVs fly.
"""

from __future__ import annotations

import math
from typing import Any

import cvxpy as cp
import numpy as np

from baselines.fleet_schedule import FleetSchedule
from baselines.sca_problem import Surrogate
from ios_uav_env import ScenarioConfig
from ios_uav_env.model import channel as ch

__all__ = ["SEPARATION_MARGIN", "Pieces", "chords", "coefficients", "separation_rows"]

#: m, added to the separation in a step where the iterate allows (the solver's tolerance).
SEPARATION_MARGIN = 1e-3


class Pieces:
    """Node k's surrogate pieces at UAV u's interior way-points 1 .. m (``Surrogate.linearise`` of
    its (N, 2) ``flight``, held after its horizon, restricted to its first m interior slots): the
    direct amplitude a_d (m,), the anchored tile terms (m, tiles) and their sum s_sum."""

    def __init__(self, surrogate: Surrogate, flight: np.ndarray, m: int):
        lin = surrogate.linearise(flight)
        inner = flight[1 : m + 1]
        self.values = {key: lin.values[key][:m] for key in ("gl2", "dl2") if key in lin.values}
        self.a_d = ch.direct_amplitude(surrogate.config, inner)
        terms = ch.surface_terms(surrogate.tiled, inner) if surrogate.has_surface else np.zeros((m, 0))
        self.terms = np.where(lin.active[:m, None], terms * lin.anchor[:m, None], 0.0)
        self.s_sum = self.terms.sum(axis=1)


def _slope(eta: np.ndarray, amplitude: np.ndarray) -> np.ndarray:
    """d log2(1 + eta z^2) / d ln z, divided by z: the tangent's coefficient per unit amplitude."""
    return 2.0 * eta * amplitude / ((1.0 + eta * amplitude**2) * math.log(2.0))


def coefficients(
    config: ScenarioConfig, sched: FleetSchedule, u: int, pieces: list[Pieces], access: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(cd (m, K), cb (m, K), cc (m, K, tiles)): the tangent coefficients of node k's flight rate
    (averaged over the schedule's N slots) in UAV u's slacks v, s, u_j at its m interior
    way-points (``pieces``' m) with the schedule's shares (``fleet_sca``'s module docstring)."""
    k_n, n_n, m = config.K, sched.gains.shape[0], len(pieces[0].a_d)
    inner = np.arange(1, m + 1)
    aligned, direct = np.zeros((m, k_n)), np.zeros((m, k_n))
    for j, lam in enumerate(sched.mix):
        if lam <= 0:
            continue
        align, nodes = sched.align[j, inner], sched.nodes[j, inner]
        node = nodes[:, u]
        serving = node >= 0
        eta = np.full(m, config.eta)
        if access == "shared":  # the other transmitting UAVs at u's node: a constant in u's block
            g = sched.gains[inner, align // k_n, align % k_n]  # (m, U, K)
            heard = g[np.arange(m)[:, None], np.arange(g.shape[1]), np.maximum(node, 0)[:, None]]
            others = (nodes >= 0) & (np.arange(nodes.shape[1]) != u)  # (a UAV gone is -1: silent)
            eta = config.eta / (1.0 + config.eta * (heard * others).sum(axis=1))
        own = align == u * k_n + node
        for k in range(k_n):
            p = pieces[k]
            zeta = p.a_d + p.s_sum
            here = serving & (node == k)
            aligned[:, k] += np.where(here & own, lam * _slope(eta, zeta), 0.0)
            direct[:, k] += np.where(here & ~own, lam * _slope(eta, p.a_d), 0.0)
    cd = np.column_stack([(aligned[:, k] + direct[:, k]) * pieces[k].a_d for k in range(k_n)]) / n_n
    cb = np.column_stack([aligned[:, k] * pieces[k].s_sum for k in range(k_n)]) / n_n
    cc = np.stack([-aligned[:, k, None] * pieces[k].terms for k in range(k_n)], axis=1) / n_n
    return cd, cb, cc


def separation_rows(
    q: np.ndarray, others: np.ndarray, d_min: float, slots: Any = None
) -> list[tuple[int, np.ndarray, float]]:
    """(slot, e, rhs): e . q_u[slot] >= rhs, the half-planes of the separation's restriction to the
    others' flights ``others`` (V, N, 2) at UAV u's iterate ``q`` (N_u, 2) over its own N_u slots
    (``fleet_sca``'s module docstring), for its interior slots 1 .. N_u - 2 only. ``slots``: the
    others' slot counts (V,) (default N each): a pair has rows on the segments both UAVs fly,
    up to the earlier of their last slots (as ``flights_separated``)."""
    rows = []
    last = len(q) - 1
    counts = np.full(len(others), others.shape[1]) if slots is None else np.asarray(slots)
    for other, n_v in zip(others, counts, strict=True):
        rel = q - other[: len(q)]
        for n in range(min(last, int(n_v) - 1)):
            a, b = rel[n], rel[n + 1]
            w = b - a
            s = 0.0 if not w @ w else float(np.clip(-(a @ w) / (w @ w), 0.0, 1.0))
            p = a + s * w
            dist = float(np.hypot(*p))
            if dist == 0.0:
                continue
            e = p / dist
            need = min(d_min + SEPARATION_MARGIN, dist)
            for slot in (n, n + 1):
                if 0 < slot < last:
                    rows.append((slot, e, need + float(e @ other[slot])))
    return rows


def chords(s: cp.Variable, z: Any, span: np.ndarray) -> list[Any]:
    """s <= log z for z in [1 - span, 1 + span] (z = 1 at q^l; (17)), restricted to s below the
    interpolation of log through five points of that range (a concave function's chords lie below
    it): linear rows instead of an exponential cone; z stays >= its lowest point (> 0)."""
    low = np.maximum(1.0 - span, 1e-2)
    points = np.stack([low, (low + 1.0) / 2, np.ones_like(low), 1.0 + span / 2, 1.0 + span], axis=1)
    logs = np.log(points)
    slope = np.diff(logs, axis=1) / np.diff(points, axis=1)
    rows = [s <= cp.multiply(slope[:, i], z) + (logs[:, i] - slope[:, i] * points[:, i]) for i in range(4)]
    return [*rows, z >= low]
