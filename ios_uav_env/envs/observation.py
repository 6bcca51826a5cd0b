"""The env's observation: the instance features and the bounds of the space.

Pure functions (no Gymnasium): every env derives its observation space from a family of
scenarios with :func:`space_bounds` (``IOSUAVEnv`` from the family of its one construction
config, ``RandomIOSUAVEnv`` from its ranges) and checks with :func:`check_fits` that a
scenario pinned at reset (``options={"config": cfg}``) keeps every observation inside it.
The component names and reading features by name: :mod:`ios_uav_env.envs.observation_layout`
(re-exported here).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ios_uav_env.envs.observation_layout import (  # noqa: F401 (the layouts, re-exported)
    ENERGY_NAMES,
    HIDDEN_GROUND,
    INSTANCE_NAMES,
    MEASURED_RATE,
    OBS_NAMES,
    PEAK_NAMES,
    SINGLE_LAYOUTS,
    feature_source,
    node_block_names,
    observation_names,
    require_features,
)
from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model.channel import RateKernel, rate_kernel
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.hover_reference import flight_efficiency, hover_path
from ios_uav_env.model.motion import is_static
from ios_uav_env.model.peak import Peak, rate_peak
from ios_uav_env.model.propulsion import min_power_speed, propulsion_power
from ios_uav_env.model.scenarios import ScenarioRanges
from ios_uav_env.model.score import bits_per_joule, score_plan
from ios_uav_env.model.surface import _axes
from ios_uav_env.model.trajectory import average_rate, energy

#: The largest finite float32, the observation's dtype: every bound of a space must stay within it.
F32_MAX = float(np.finfo(np.float32).max)

#: Element count of the paper's surface (M = 6000): the ``elements`` feature is M / M_SCALE.
M_SCALE = 6000.0
#: Seconds (the longest horizon of the default ranges): ``horizon`` is T / T_SCALE and
#: ``seconds_left`` is (moves left) dt / T_SCALE.
T_SCALE = 200.0
_C = 3.0 * math.sqrt(3.0) / 16.0  # max over t > 0 of t^3 / (t^2 + c^2)^2, times c


def rate_upper_bound(kernel: RateKernel) -> float:
    """An upper bound of the expected-gain rate anywhere at the UAV altitude (bps/Hz).

    Uses d_UG >= z_U and, per node, |dx|^3 / (dx^2 + h^2)^2 <= 3 sqrt(3) / (16 h) with h the
    smallest vertical UAV-node gap; it bounds the observation's ``rate`` component. N_t antennas
    gain at most N_t zeta^2 (``channel.aligned_gain``: the array factor is at most N_t).
    """
    zeta = kernel.k_direct * kernel.z_u2**kernel.d_exp
    if kernel.has_surface:
        h = math.sqrt(float(np.min(kernel.dz2)))
        zeta += max(1.0, kernel.t_factor) * float(np.abs(kernel.jw).sum()) * _C / h
    return math.log2(1.0 + kernel.eta * kernel.antennas * zeta * zeta)


def ground_free_rate_bound(config: ScenarioConfig) -> float:
    """An upper bound of the expected-gain rate of ``config`` that holds wherever G is (bps/Hz).

    Element m at height z_m contributes J s |dx|^3 / d_Um^4 * |x_G - x_c|^3 / d_mG^4, and each
    factor is at most 3 sqrt(3) / (16 c) with c = z_U - z_m (the UAV side) or z_m (the G
    side), whatever the UAV and G positions: so one bound serves every ground position (the
    randomised env's ranges). O(M_z): the elements of a row share z_m. N_t antennas: at most
    N_t zeta^2, as :func:`rate_upper_bound`.
    """
    zeta = math.sqrt(config.g_tx * config.g_rx) * config.uav_altitude ** (-config.alpha / 2.0)
    if config.surface != "none":
        ys, zs = _axes(config)
        rows = float(np.sum(1.0 / (zs * (config.uav_altitude - zs))))
        zeta += max(1.0, config.transmit_factor) * config.J * _C * _C * ys.size * rows
    return math.log2(1.0 + config.eta * config.antennas * zeta * zeta)


def rate_bound(config: ScenarioConfig) -> float:
    """The tighter of :func:`rate_upper_bound` and :func:`ground_free_rate_bound` (bps/Hz)."""
    return min(rate_upper_bound(rate_kernel(config)), ground_free_rate_bound(config))


def instance_values(config: ScenarioConfig) -> tuple[float, float, float, float, float]:
    """The constant instance features of ``config``: (elements, is_ios, is_ris, transmit, horizon).

    elements = M / 6000 (0 without a surface); is_ios, is_ris in {0, 1}; transmit = t / (1 + t)
    with t the transmissive factor (epsilon for the IOS, 0 otherwise); horizon = T / 200 s.
    """
    elements = config.M / M_SCALE if config.surface != "none" else 0.0
    t = config.transmit_factor
    return (
        elements,
        float(config.surface == "ios"),
        float(config.surface == "ris"),
        t / (1.0 + t),
        config.T / T_SCALE,
    )


def hover_flight(config: ScenarioConfig, peak: Peak | None = None) -> np.ndarray:
    """The (N, 2) flight (m) of "fly to the reachable rate peak P at full speed and hover there"
    through the env's arrival guard (``guard.guarded_position``), which brings it to qF at slot
    N: the flight of ``policies.HoverAt("peak")`` in the env, feasible for every scenario
    (compiled: ``hover_reference.hover_path``). ``peak``: P if known, else ``rate_peak(config)``."""
    p = rate_peak(config) if peak is None else peak
    (x, y), (fx, fy) = config.q0, config.qF
    return hover_path(float(x), float(y), float(fx), float(fy), float(p.x), float(p.y), config.D, config.N)


def flight_ee(config: ScenarioConfig, flight: np.ndarray) -> float:
    """The EE (bits/J) of one node's ``flight`` (N, 2) on ``config``'s static node: ``score_plan``'s
    to rounding, ~1e-15 relative (with numba, the compiled ``hover_reference.flight_efficiency``;
    without, ``bits_per_joule`` of ``average_rate`` and the flight's ``energy``, as ``score_plan``
    computes it, without its checks). The reference flights' scorer: one function, so each
    lambda_ref below is the same number whichever of them computes it."""
    if not HAVE_NUMBA:
        return float(bits_per_joule(config, average_rate(config, flight), energy(config, flight)))
    kernel, m = rate_kernel(config), config.propulsion
    constants = np.array([m.P0, m.U_tip, m.P_i, m.v0, m.drag_coefficient])
    q = np.ascontiguousarray(flight, dtype=np.float64)
    dt, bandwidth = config.dt, config.bandwidth_hz
    return float(flight_efficiency(q, kernel.nodes, kernel.params, dt, bandwidth, config.T, constants))


def reference_efficiency(config: ScenarioConfig, peak: Peak | None = None) -> float:
    """lambda_ref (bits/J), the default reference energy efficiency of the energy reward: the EE
    (:func:`flight_ee`, ``score_plan``'s) of :func:`hover_flight`, the rate objective's "fly to the
    peak and hover" plan. A feasible plan, so lambda_ref <= EE* (the best EE), and a plan that
    maximises the energy reward's return has an EE of at least lambda_ref (``IOSUAVEnv``,
    "Energy"). ``peak``: the reachable rate peak if known, else ``rate_peak(config)``'s."""
    return flight_ee(config, hover_flight(config, peak))


def loiter_efficiency(config: ScenarioConfig, peak: Peak | None = None) -> float:
    """lambda_ref (bits/J) of ``energy_reference="loiter"``: the better EE (``score_plan``) of the
    loiter heuristic's flight around the reachable rate peak (``loiter_flight.best_loiter_path``,
    the one ``baselines.loiter`` flies) and the hover plan's (:func:`reference_efficiency`; on a
    tight horizon hovering can beat the loiter legs). Feasible plans, so lambda_ref <= EE*, and
    on most scenarios far closer to it than the hover plan's: a plan that maximises the return
    then has an EE of at least both heuristics' (``IOSUAVEnv``, "Energy"). ``peak``: the
    reachable rate peak if known."""
    from ios_uav_env.model.flights import best_loiter_path

    p = rate_peak(config) if peak is None else peak
    return max(best_loiter_path(config, peak=(p.x, p.y))[2], reference_efficiency(config, p))


def reference_flights(
    config: ScenarioConfig, peak: Peak | None = None, loiter: bool = False
) -> list[np.ndarray]:
    """The feasible (N, 2) flights whose best EE is the default lambda_ref: :func:`hover_flight`
    and, with ``loiter`` (``energy_reference="loiter"``), first the loiter heuristic's flight
    (``loiter_flight.best_loiter_path``, the one :func:`loiter_efficiency` scores). Planned on
    ``config`` as it is configured (its node at its configured position), so they are the same
    whatever the node does after; ``peak``: the reachable rate peak if known."""
    from ios_uav_env.model.flights import best_loiter_path

    p = rate_peak(config) if peak is None else peak
    hover = hover_flight(config, p)
    return [best_loiter_path(config, peak=(p.x, p.y))[0], hover] if loiter else [hover]


def flights_efficiency(
    config: ScenarioConfig, flights: Sequence[np.ndarray], paths: np.ndarray | None = None
) -> float:
    """The best EE (bits/J) of ``flights`` on ``config``, each scored by ``score_plan(config, flight,
    paths=paths)``: on the node's true path ``paths`` (N, 1, 2) of a moving node, the reference of
    the energy reward of a mobile env (``IOSUAVEnv``, "Energy"). Feasible flights, so at most the
    best EE on those paths. With ``paths`` None or static, each by :func:`flight_ee` (``score_plan``'s
    EE to rounding): with :func:`reference_flights`, the value of :func:`reference_efficiency` bit
    for bit (of :func:`loiter_efficiency` with ``loiter``, to rounding: it takes the loiter
    flight's ``score_plan`` EE, as ``baselines.loiter`` reports it)."""
    if paths is None or is_static(config, np.asarray(paths, dtype=float)):
        return max(flight_ee(config, flight) for flight in flights)
    return max(float(score_plan(config, flight, paths=paths).energy_efficiency) for flight in flights)


def optimistic_efficiency(config: ScenarioConfig, peak_rate: float | None = None) -> float:
    """B N r(P) / ((N - 1) P(V_mp)) (bits/J): the EE of a plan that would sit at the reachable
    rate peak P for all N slots while flying every one of its N - 1 moves at the minimum-power
    speed V_mp. Every feasible plan has r(q[n]) <= r(P) (its way-points are reachable points,
    where ``rate_peak`` searches; up to that search's grid) and E >= (N - 1) dt P(V_mp), so it
    bounds EE* from above. ``peak_rate``: r(P) if known (bps/Hz), else ``rate_peak(config)``'s.
    """
    rate = rate_peak(config).rate if peak_rate is None else float(peak_rate)
    p_min = float(propulsion_power(min_power_speed(config.propulsion), config.propulsion))
    return config.bandwidth_hz * config.N * rate / ((config.N - 1) * p_min)


def min_power_move(config: ScenarioConfig) -> float:
    """The minimum-power move V_mp dt / D = V_mp / v_max (the ``min_power_move`` feature)."""
    return min_power_speed(config.propulsion) / config.v_max


def pad(value: float) -> float:
    """``value`` with the bounds' margin: a relative 1e-6 and an absolute 1e-6."""
    return value * (1 + 1e-6) + 1e-6


Interval = tuple[float, float]


def length_bounds(
    q0: tuple[Interval, Interval], points: list[tuple[Interval, Interval]], reach: float
) -> list[float]:
    """Largest absolute values (m) of the UAV's x, y and of each point's offset (x, y) from the
    UAV, when q0 and the points range over the (x, y) intervals given: the largest value at q0
    plus ``reach`` ((N_max - 1) D: no position is farther from q0), 2 + 2 len(points) entries."""
    lengths = [max(abs(lo), abs(hi)) + reach for lo, hi in q0]
    for p in points:
        lengths += [max(abs(p[i][1] - q0[i][0]), abs(p[i][0] - q0[i][1])) + reach for i in range(2)]
    return lengths


def space_bounds(
    ranges: ScenarioRanges,
    length_scale: float,
    instance: bool,
    peak: bool = False,
    energy: bool = False,
    reference: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) float32 arrays that hold every observation of every episode of ``ranges``
    (a fixed scenario is the family ``ScenarioRanges.from_config(config)``).

    Lengths: the largest absolute value at q0 over the ranges plus (N_max - 1) D / L (no
    position is farther from q0, guard or not). Rate: :func:`rate_bound` where G is fixed,
    else :func:`ground_free_rate_bound`, over the family's surfaces and sizes. Instance
    features: their largest values (at least 1). Peak hint: the peak and the UAV are both
    within (N_max - 1) D of q0, so |P - q| / L <= 2 (N_max - 1) D / L. Energy features
    (``energy``; ``reference``: a fixed lambda_ref in bits/J, None: :func:`reference_efficiency`
    per scenario): a move is at most D; w = lambda_ref P(0) / B with lambda_ref <= EE* <=
    :func:`optimistic_efficiency`, so w <= 2 r_max P(0) / P(V_mp)
    with r_max the rate bound (r(P) <= r_max), or the fixed reference's value;
    V_mp dt / D of the family's base (propulsion and v_max are not drawn). Margins of 1e-6.
    """
    r, base = ranges, ranges.base
    reach = r.max_moves * base.D
    q0 = (r.start_x, r.start_y)
    points = [
        (r.end_x, r.end_y),
        (r.ground_x, r.ground_y),
        ((base.ios_center[0],) * 2, (base.ios_center[1],) * 2),
    ]
    lengths = length_bounds(q0, points, reach)
    bound = rate_bound if r.fixed_ground else ground_free_rate_bound
    rate_high = max(bound(c) for c in r.configs_per_surface())
    high = [pad(v / length_scale) for v in lengths] + [1.0, 1.0, pad(rate_high)]
    low = [-h for h in high[:8]] + [0.0, -1.0, 0.0]
    if instance:
        has_surface = set(r.surfaces) != {"none"}
        elements = r.ios_columns * r.ios_rows[1] / M_SCALE if has_surface else 0.0
        elements, horizon = (pad(max(1.0, v)) for v in (elements, r.slot_range[1] * base.dt / T_SCALE))
        high += [elements, 1.0, 1.0, 1.0, horizon, horizon]
        low += [0.0] * len(INSTANCE_NAMES)
    if energy:
        model = base.propulsion
        hover = model.hover_power
        if reference is None:  # N / (N - 1) <= 2
            p_min = float(propulsion_power(min_power_speed(model), model))
            weight = 2.0 * rate_high * hover / p_min
        else:
            weight = reference * hover / base.bandwidth_hz
        high += [pad(1.0), pad(1.0), pad(weight), pad(min_power_move(base))]
        low += [-pad(1.0), -pad(1.0), 0.0, 0.0]
    if peak:
        offset = pad(2.0 * reach / length_scale)
        high += [offset, offset, pad(rate_high)]
        low += [-offset, -offset, 0.0]
    names = observation_names(instance, peak, energy)

    def why(name: str, value: float) -> str:
        return overflow_hint(name, value, length_scale, base, reference)

    return float32_bounds(low, names, why), float32_bounds(high, names, why)


def float32_bounds(
    values: Sequence[float], names: Sequence[str], why: Callable[[str, float], str]
) -> np.ndarray:
    """``values`` (bounds of the observation's components ``names``) as float32; ``ValueError``
    naming the first one that float32 cannot hold (not finite, or beyond :data:`F32_MAX`) and
    ``why(name, value)``: the field that sends it there and its allowed range."""
    for name, value in zip(names, values, strict=True):
        if not abs(value) <= F32_MAX:
            raise ValueError(
                f"the observation's {name!r} can reach {value:.4g}, beyond float32 (|x| <= {F32_MAX:.4g}): "
                f"{why(name, value)}"
            )
    return np.array(values, dtype=np.float32)


def overflow_hint(
    name: str, value: float, length_scale: float, base: ScenarioConfig, reference: float | None = None
) -> str:
    """Why the bound ``value`` of the feature ``name`` overflows, naming the field and its allowed
    range on the scenario (family) of ``base``: the :func:`float32_bounds` message of every env."""
    feature, value = re.sub(r"_\d+$", "", name), abs(value)
    limit = F32_MAX / (1.0 + 1e-3)
    if feature == "elements":
        return f"ios_shape gives M = {value * M_SCALE:.4g} elements: M must be <= {limit * M_SCALE:.4g}"
    if feature in ("horizon", "seconds_left"):
        return f"T / {T_SCALE:g} s: T must be <= {limit * T_SCALE:.4g} s"
    if feature == "min_power_move":
        speed = min_power_speed(base.propulsion)
        return f"V_mp / v_max with V_mp = {speed:.4g} m/s: v_max must be >= {speed / limit:.4g} m/s"
    if feature == "energy_weight" and reference is not None:
        top = limit * base.bandwidth_hz / base.propulsion.hover_power
        return f"energy_reference P(0) / B: energy_reference must be <= {top:.4g} bits/J on this scenario"
    if feature in ("energy_weight", "rate", MEASURED_RATE, "rate_peak", "served", "served_measured"):
        return (
            "the scenario's expected-gain rate bound log2(1 + eta zeta^2) is not finite (eta zeta^2 "
            "overflows: lower power_w, g_tx, g_rx, g_element, gamma or alpha, or raise noise_dbm or "
            "uav_altitude)"
        )
    metres = value * length_scale
    return (
        f"lengths are divided by length_scale = {length_scale:.4g} m and this one reaches {metres:.4g} m: "
        f"length_scale must be >= {metres / limit:.4g} m (or the scene and its reach (N - 1) v_max dt "
        "smaller)"
    )


def check_fits(
    config: ScenarioConfig,
    length_scale: float,
    instance: bool,
    space: Any,
    peak: bool = False,
    energy: bool = False,
    reference: float | None = None,
) -> None:
    """Raise ``ValueError`` if an episode on ``config`` could leave the Box ``space``."""
    ranges = ScenarioRanges.from_config(config)
    low, high = space_bounds(ranges, length_scale, instance, peak, energy, reference)
    names = observation_names(instance, peak, energy)
    for i in np.flatnonzero((high > space.high) | (low < space.low))[:1]:
        raise ValueError(
            f"the scenario {config} does not fit this env's observation space: component {i} "
            f"({names[i]}) can reach [{low[i]:.6g}, {high[i]:.6g}], outside the space's "
            f"[{space.low[i]:.6g}, {space.high[i]:.6g}]; make an env on it instead "
            "(gym.make(id, config=cfg))"
        )
