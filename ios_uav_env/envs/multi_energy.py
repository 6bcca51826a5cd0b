"""The energy objective and the Rician channel of ``MultiNodeEnv``: the reference efficiency, the
options they take, and their per-episode pieces.

**Energy** (``objective="energy_efficiency"``). The reward gains -(lambda_ref / B) P(V_n) per
step, as the single env's (``IOSUAVEnv``, "Energy"), so the return is (bits - lambda_ref E) / (B dt)
with bits = B T min_k R_k of the agent's own shares. lambda_ref is ``energy_reference`` when
given (bits/J), else :func:`reference_efficiency` of the episode: the better EE (``score_plan``)
of two flights, each with its best schedule (:func:`reference_shares`):

- :func:`least_energy_flight`: N - 1 equal moves at c* = clip(V_mp, |qF - q0| / ((N - 1) dt),
  v_max), the speed of ``config.least_energy()`` (a detour when c* exceeds the straight
  flight's speed), so its energy is that least energy, within every budget the config admits;
- :func:`straight_flight`: q0 to qF along the segment at one constant speed (nearer the nodes;
  below V_mp it costs more power than the detour), unless it exceeds ``energy_budget_j``.

Both meet eq. (10) on every valid scenario, so lambda_ref is a feasible plan's EE: lambda_ref
<= EE*, the best EE of the scenario (under its budget), and a plan of the largest return has an
EE of at least lambda_ref (the bound of ``IOSUAVEnv``'s "Energy": the return is an increasing
affine function of G = bits - lambda_ref E). (With N = 2 and qF nearer than V_mp dt the one move
cannot detour: the straight flight is then the only flight.)

With moving nodes (``motion``, ``knowledge``) the reward's lambda_ref is that of the same two
flights, scheduled and scored on the episode's true paths, drawn at reset (the truth the score is
taken on; ``score_plan(..., paths=env.paths)``), so lambda_ref <= EE* of that episode still
holds. The agent never sees the truth: the observation's energy weight stays the scenario's,
the flights' EE on the configured nodes (the static env's value), as the single env's mobile
energy id does. A
number given as ``energy_reference`` is used as it is, in the reward and the observation alike.

**Rician** (``channel="rician"``): each slot draws two standard normals per node from the
env's ``np_random`` (:func:`draw_fading`: (K, 2), the real then the imaginary part of h_SS, node
by node), and the kernel serves node k its faded rate ``channel.faded_point`` of that slot, as
the single env does with its one node.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from ios_uav_env.envs.observation import pad
from ios_uav_env.envs.observation_layout import ENERGY_NAMES
from ios_uav_env.envs.options import EnvOptions
from ios_uav_env.model.channel import rates_of_rows
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.maxmin import MAX_NODES, fast_schedule
from ios_uav_env.model.propulsion import min_power_speed, propulsion_power
from ios_uav_env.model.schedule import node_rates
from ios_uav_env.model.score import bits_per_joule, score_plan
from ios_uav_env.model.trajectory import check_trajectory

__all__ = [
    "ENERGY_NAMES", "EnergyChannel", "check_options", "draw_fading", "energy_bounds", "fixed_reference",
    "least_energy_flight", "reference_efficiency", "reference_shares", "straight_flight",
]  # fmt: skip


def straight_flight(config: ScenarioConfig) -> np.ndarray:
    """The (N, 2) flight (m) from q0 to qF along the segment, every move the same,
    (qF - q0) / (N - 1): one constant speed |qF - q0| / ((N - 1) dt) <= v_max (a valid scenario
    reaches qF in N - 1 moves), so it meets eq. (10)."""
    q0, qf = np.asarray(config.q0, dtype=np.float64), np.asarray(config.qF, dtype=np.float64)
    fraction = np.arange(config.N, dtype=np.float64)[:, None] / (config.N - 1)
    path = q0 + fraction * (qf - q0)
    path[-1] = qf
    return path


def least_energy_flight(config: ScenarioConfig) -> np.ndarray:
    """The (N, 2) flight (m) of ``config.least_energy()``: N - 1 moves of one length s = c* dt at
    c* = ``config.least_energy_speed()``, from q0 to qF. The straight flight when c* is its speed;
    else a detour: two straight legs of m1 and m2 moves (m1 + m2 the moves, m1 - m2 in {0, 1})
    meeting at an apex on the left of q0 -> qF, after, when the moves are odd and qF is nearer
    than s, one first move of length s straight away from qF. N = 2 with qF nearer than s: the
    straight flight (no other flight exists)."""
    q0, qf = np.asarray(config.q0, dtype=np.float64), np.asarray(config.qF, dtype=np.float64)
    moves, s = config.N - 1, config.least_energy_speed() * config.dt
    length = float(np.hypot(*(qf - q0)))
    if s * moves <= length * (1.0 + 1e-12) or moves == 1:
        return straight_flight(config)
    points, start = [q0], q0
    if moves % 2 == 1 and length < s:  # (moves >= 3) one move away from qF, then an even V
        away = (q0 - qf) / length if length > 0 else np.array([1.0, 0.0])
        start = q0 + s * away
        points.append(start)
        moves -= 1
    m1 = (moves + 1) // 2
    m2 = moves - m1
    d = float(np.hypot(*(qf - start)))
    u = (qf - start) / d if d > 0 else np.array([1.0, 0.0])
    r1, r2 = m1 * s, m2 * s
    a = (d * d + r1 * r1 - r2 * r2) / (2.0 * d) if d > 0 else 0.0
    apex = start + a * u + np.sqrt(max(r1 * r1 - a * a, 0.0)) * np.array([-u[1], u[0]])
    points += [start + (apex - start) * j / m1 for j in range(1, m1 + 1)]
    points += [apex + (qf - apex) * j / m2 for j in range(1, m2 + 1)]
    path = np.array(points)
    path[-1] = qf
    return path


def reference_shares(rates: np.ndarray) -> np.ndarray:
    """The shares (K, N) of the reference plan on its (K, N) expected-gain ``rates``: the certified
    best schedule of ``maxmin.fast_schedule`` (2 <= K <= ``MAX_NODES``, every node served somewhere),
    else the best constant shares, alpha_k proportional to 1 / mean_n r_k[n] (each node then gets
    1 / sum_j 1 / mean_n r_j[n]; equal shares if a node is never served). Both without scipy, so
    the reference is the same on every install."""
    r = np.asarray(rates, dtype=np.float64)
    k_n, n_slots = r.shape
    if k_n == 1:
        return np.ones((1, n_slots))
    means = r.mean(axis=1)
    if np.all(means > 0):
        if k_n <= MAX_NODES:
            found = fast_schedule(r)
            if found is not None:
                return found[0]
        inverse = 1.0 / means
        return np.repeat((inverse / inverse.sum())[:, None], n_slots, axis=1)
    return np.full((k_n, n_slots), 1.0 / k_n)


Kernels = tuple[np.ndarray, np.ndarray]


def _flight_efficiency(
    config: ScenarioConfig, q: np.ndarray, paths: np.ndarray | None, kernels: Kernels | None
) -> tuple[float, bool]:
    """(EE in bits/J, feasible) of the flight ``q`` with :func:`reference_shares`: ``score_plan``'s;
    with the ``kernels`` of the ``paths`` (each node's per slot, (K, N, 3, Q) and (K, N, P)) its
    rates are taken on them (``rates_of_rows``, as ``schedule.node_rates`` does on the same
    kernels, without building them again) and its EE is ``score_plan``'s formula,
    ``bits_per_joule`` of min_k R_k and the flight's energy."""
    if kernels is None:
        shares = reference_shares(node_rates(config, q, paths))
        score = score_plan(config, q, None if config.K == 1 else shares, paths, best_schedule=False)
        return float(score.energy_efficiency), score.feasible
    points = np.ascontiguousarray(q)
    rates = np.stack([rates_of_rows(points, kernels[0][k], kernels[1][k]) for k in range(config.K)])
    own = float(np.mean(reference_shares(rates) * rates, axis=1).min())  # (scheduled_rates')
    report = check_trajectory(config, q)
    return float(bits_per_joule(config, own, report.energy)), bool(report.feasible)


def _reference(config: ScenarioConfig, paths: np.ndarray | None, kernels: Kernels | None = None) -> float:
    least, _ = _flight_efficiency(config, least_energy_flight(config), paths, kernels)  # (any budget)
    straight, feasible = _flight_efficiency(config, straight_flight(config), paths, kernels)
    return max(least, straight) if feasible else least


@functools.lru_cache(maxsize=256)
def _static_reference(config: ScenarioConfig) -> float:
    return _reference(config, None)


def reference_efficiency(
    config: ScenarioConfig, paths: np.ndarray | None = None, kernels: Kernels | None = None
) -> float:
    """lambda_ref (bits/J) of the energy reward: the better EE (``score_plan``) of
    :func:`least_energy_flight` and, unless it exceeds the energy budget, :func:`straight_flight`,
    each with :func:`reference_shares` on its rates, on the true node ``paths`` (N, K, 2) when
    given (moving nodes), else on the static nodes (cached per scenario). Feasible plans: module
    docstring for what it guarantees. ``kernels``: the paths' per-slot node kernels, if built
    already (``knowledge.NodesTrack``'s ``nodes`` and ``params``; the same rates, faster)."""
    if paths is None:
        return _static_reference(config)
    return _reference(config, paths, kernels)


def check_options(options: EnvOptions, energy: bool) -> None:
    """Refuse the options ``MultiNodeEnv`` does not take, naming the field: ``instance_features``;
    ``energy_reference`` without the energy objective (``energy``) or as ``"loiter"`` (a single-node
    flight). (Channel ``"rician"`` with measured rates is a combination of components that
    ``settings.check_world`` refuses.)"""
    if options.instance_features:
        raise ValueError(
            "MultiNodeEnv takes no instance_features (its node blocks and base features describe it)"
        )
    ref = options.energy_reference
    if ref is not None and not energy:
        raise ValueError(
            "energy_reference is lambda_ref of the energy reward: it needs objective='energy_efficiency', "
            f"got energy_reference={ref!r}"
        )
    if ref == "loiter":
        raise ValueError(
            "energy_reference='loiter' is the single-node loiter flight around one node's rate peak; "
            "MultiNodeEnv takes None (its straight flight's EE) or a number of bits/J"
        )


def draw_fading(rng: np.random.Generator, normals: np.ndarray, k_n: int) -> None:
    """Draw the slot's fading of ``k_n`` nodes into ``normals`` (K_max, 2): (k_n, 2) standard normals."""
    normals[:k_n] = rng.standard_normal((k_n, 2))


def energy_bounds(base: ScenarioConfig, rate: float, reference: float | None) -> tuple[list, list]:
    """(low, high) of the energy features (``ENERGY_NAMES``) over a family whose propulsion, bandwidth
    and v_max are ``base``'s and whose expected-gain rates are at most ``rate``: the last move / D
    in [-1, 1]; the energy weight lambda_ref P(0) / B with lambda_ref <= EE* <= B N rate / ((N - 1)
    P(V_mp)) (every flight's E >= (N - 1) dt P(V_mp), min_k R_k <= rate), N / (N - 1) <= 2, or the
    fixed ``reference``'s; V_mp dt / D."""
    model = base.propulsion
    if reference is None:
        weight = 2.0 * rate * model.hover_power / float(propulsion_power(min_power_speed(model), model))
    else:
        weight = reference * model.hover_power / base.bandwidth_hz
    move = min_power_speed(model) / base.v_max
    return [-pad(1.0), -pad(1.0), 0.0, 0.0], [pad(1.0), pad(1.0), pad(weight), pad(move)]


def fixed_reference(options: EnvOptions) -> float | None:
    """lambda_ref (bits/J) when ``energy_reference`` fixes it, else None (each episode's own)."""
    ref: Any = options.energy_reference
    return None if ref is None or isinstance(ref, str) else float(ref)


class EnergyChannel:
    """The per-episode part of the energy objective and the Rician channel in ``MultiNodeEnv``
    (a mixin; the batched env calls its methods on each row's template env)."""

    config: ScenarioConfig
    options: EnvOptions
    np_random: np.random.Generator
    energy_objective: bool
    _track: Any
    reference_efficiency: float

    @property
    def _rician(self) -> bool:
        return self.options.channel == "rician"

    def _prepare(self, rows: Any, i: int) -> None:
        """Row ``i`` of ``rows`` (``multi_kernels.NodeRows``) at reset, after the scenario's and the
        paths' draws: the episode's lambda_ref (the energy objective: ``energy_reference`` or
        :func:`reference_efficiency` on the true paths) and the first slot's fading (Rician)."""
        if self.energy_objective:
            reference = seen = fixed_reference(self.options)
            if reference is None:  # the configured nodes' (observed), the true paths' (rewarded)
                seen = reference = reference_efficiency(self.config)
                track = self._track
                if track is not None:  # (the track's kernels are the paths')
                    reference = reference_efficiency(self.config, track.paths, (track.nodes, track.params))
            self.reference_efficiency = reference
            rows.set_reference(i, reference, seen)
        self._fade(rows, i)

    def _fade(self, rows: Any, i: int) -> None:
        """The fading of row ``i``'s next slot (channel "rician"; nothing otherwise)."""
        if self._rician:
            draw_fading(self.np_random, rows.normals[i], self.config.K)
