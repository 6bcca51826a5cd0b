"""The env's observation: component names, the instance features and the bounds of the space.

Pure functions of a ``ScenarioConfig`` (no Gymnasium): ``IOSUAVEnv`` derives its observation
space from its construction config, ``RandomIOSUAVEnv`` from its ranges, and both check with
:func:`observation_bounds` that a scenario pinned at reset (``options={"config": cfg}``) keeps
every observation inside the space.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ios_uav_env.channel import RateKernel, rate_kernel
from ios_uav_env.config import ScenarioConfig
from ios_uav_env.surface import _axes

#: Names of the observation components, in order (see ``IOSUAVEnv``'s docstring for the units).
OBS_NAMES: tuple[str, ...] = (
    "x", "y", "dx_final", "dy_final", "dx_ground", "dy_ground", "dx_ios", "dy_ios",
    "time_left", "slack", "rate",
)  # fmt: skip

#: Names of the instance features appended with ``instance_features=True``, in order.
INSTANCE_NAMES: tuple[str, ...] = ("elements", "is_ios", "is_ris", "transmit", "horizon", "seconds_left")

#: Names of the peak hint appended (after the instance features, if any) with ``peak_hint=True``:
#: the reachable rate peak P relative to the UAV, (P - q) / L, and its rate (bps/Hz).
PEAK_NAMES: tuple[str, ...] = ("dx_peak", "dy_peak", "rate_peak")

#: Element count of the paper's surface (M = 6000): the ``elements`` feature is M / M_SCALE.
M_SCALE = 6000.0
#: Seconds (the longest horizon of the default ranges): ``horizon`` is T / T_SCALE and
#: ``seconds_left`` is (moves left) dt / T_SCALE.
T_SCALE = 200.0
_C = 3.0 * math.sqrt(3.0) / 16.0  # max over t > 0 of t^3 / (t^2 + c^2)^2, times c


def rate_upper_bound(kernel: RateKernel) -> float:
    """An upper bound of the expected-gain rate anywhere at the UAV altitude (bps/Hz).

    Uses d_UG >= z_U and, per node, |dx|^3 / (dx^2 + h^2)^2 <= 3 sqrt(3) / (16 h) with h the
    smallest vertical UAV-node gap; it bounds the observation's ``rate`` component.
    """
    zeta = kernel.k_direct * kernel.z_u2**kernel.d_exp
    if kernel.has_surface:
        h = math.sqrt(float(np.min(kernel.dz2)))
        zeta += max(1.0, kernel.t_factor) * float(np.abs(kernel.jw).sum()) * _C / h
    return math.log2(1.0 + kernel.eta * zeta * zeta)


def ground_free_rate_bound(config: ScenarioConfig) -> float:
    """An upper bound of the expected-gain rate of ``config`` that holds wherever G is (bps/Hz).

    Element m at height z_m contributes J s |dx|^3 / d_Um^4 * |x_G - x_c|^3 / d_mG^4, and each
    factor is at most 3 sqrt(3) / (16 c) with c = z_U - z_m (the UAV side) or z_m (the G
    side), whatever the UAV and G positions: so one bound serves every ground position (the
    randomised env's ranges). O(M_z): the elements of a row share z_m.
    """
    zeta = math.sqrt(config.g_tx * config.g_rx) * config.uav_altitude ** (-config.alpha / 2.0)
    if config.surface != "none":
        ys, zs = _axes(config)
        rows = float(np.sum(1.0 / (zs * (config.uav_altitude - zs))))
        zeta += max(1.0, config.transmit_factor) * config.J * _C * _C * ys.size * rows
    return math.log2(1.0 + config.eta * zeta * zeta)


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


def _pad(value: float) -> float:
    return value * (1 + 1e-6) + 1e-6


Interval = tuple[float, float]


def length_bounds(
    q0: tuple[Interval, Interval], points: list[tuple[Interval, Interval]], reach: float, length_scale: float
) -> list[float]:
    """Bounds (in units of L) of the 8 length components when q0 and the points (qF, G, IOS
    centre) range over the (x, y) intervals given: the largest value at q0 plus ``reach``
    ((N - 1) D: no position is farther from q0), in absolute terms."""
    bound = [max(abs(lo), abs(hi)) + reach for lo, hi in q0]
    for p in points:
        bound += [max(abs(p[i][1] - q0[i][0]), abs(p[i][0] - q0[i][1])) + reach for i in range(2)]
    inv_l = 1.0 / length_scale
    return [b * inv_l * (1 + 1e-6) + 1e-6 for b in bound]


def assemble_bounds(
    lengths: list[float],
    rate_high: float,
    instance: tuple[float, float] | None,
    peak_reach: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) float32 arrays from the length bounds, the rate bound and, for the instance
    features, the largest (elements, horizon) values (their upper bounds are at least 1); for
    the peak hint, ``peak_reach``: the largest (N - 1) D / L (the peak and the UAV are both
    within it of q0, so |P - q| / L <= 2 ``peak_reach``)."""
    high = [*lengths, 1.0, 1.0, _pad(rate_high)]
    low = [-h for h in high[:8]] + [0.0, -1.0, 0.0]
    if instance is not None:
        elements, horizon = (_pad(max(1.0, v)) for v in instance)
        high += [elements, 1.0, 1.0, 1.0, horizon, horizon]
        low += [0.0] * len(INSTANCE_NAMES)
    if peak_reach is not None:
        high += [_pad(2.0 * peak_reach)] * 2 + [_pad(rate_high)]
        low += [-_pad(2.0 * peak_reach)] * 2 + [0.0]
    return np.array(low, dtype=np.float32), np.array(high, dtype=np.float32)


def observation_bounds(
    config: ScenarioConfig,
    length_scale: float,
    instance: bool,
    rate_high: float | None = None,
    peak: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) float32 arrays that hold every observation of an episode on ``config``.

    ``rate_high``: the rate bound (default :func:`rate_bound`). With ``instance`` the 6
    instance features follow the 11 base ones; with ``peak`` the 3 of the peak hint follow.
    """
    q0 = ((config.q0[0],) * 2, (config.q0[1],) * 2)
    points = [((p[0],) * 2, (p[1],) * 2) for p in (config.qF, config.ground_node, config.ios_center)]
    lengths = length_bounds(q0, points, (config.N - 1) * config.D, length_scale)
    elements, *_, horizon = instance_values(config)
    rate_high = rate_bound(config) if rate_high is None else rate_high
    reach = (config.N - 1) * config.D / length_scale if peak else None
    return assemble_bounds(lengths, rate_high, (elements, horizon) if instance else None, reach)


def observation_names(instance: bool, peak: bool = False) -> tuple[str, ...]:
    """The names of the observation's components, in order."""
    return OBS_NAMES + (INSTANCE_NAMES if instance else ()) + (PEAK_NAMES if peak else ())


def check_fits(
    config: ScenarioConfig, length_scale: float, instance: bool, space: Any, peak: bool = False
) -> None:
    """Raise ``ValueError`` if an episode on ``config`` could leave the Box ``space``."""
    low, high = observation_bounds(config, length_scale, instance, peak=peak)
    names = observation_names(instance, peak)
    for i in np.flatnonzero((high > space.high) | (low < space.low))[:1]:
        raise ValueError(
            f"the scenario {config} does not fit this env's observation space: component {i} "
            f"({names[i]}) can reach [{low[i]:.6g}, {high[i]:.6g}], outside the space's "
            f"[{space.low[i]:.6g}, {space.high[i]:.6g}]; make an env on it instead "
            f"(gym.make(id, config=cfg, max_episode_steps={config.N - 1}))"
        )
