"""``observation.hover_flight`` skips the arrival guard while it hovers on P far inside the
guard's reach disk: the flight is still the guard-every-slot flight, bit for bit."""

from __future__ import annotations

import math

import numpy as np

from ios_uav_env.envs.observation import hover_flight
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.guard import guarded_position
from ios_uav_env.model.peak import Peak, rate_peak
from ios_uav_env.model.scenarios import DEFAULT_RANGES, ScenarioRanges, sample_scenario


def _guarded_every_slot(config: ScenarioConfig, p: Peak) -> np.ndarray:
    d, final = config.D, (float(config.qF[0]), float(config.qF[1]))
    x, y = float(config.q0[0]), float(config.q0[1])
    path = np.empty((config.N, 2))
    path[0] = x, y
    for n in range(1, config.N):
        dx, dy = p.x - x, p.y - y
        norm = math.sqrt(dx * dx + dy * dy)  # (hover_flight's length, the same compiled or not)
        if norm > d:
            dx, dy = dx * d / norm, dy * d / norm
        x, y = guarded_position((x, y), (x + dx, y + dy), final, d, config.N - 1 - n)
        path[n] = x, y
    return path


def test_hover_flight_is_the_guarded_flight_bit_for_bit():
    rng = np.random.default_rng(0)
    tight = ScenarioRanges(T=(34.0, 120.0))  # horizons down to no spare move
    hovered = 0
    for i in range(120):
        config = sample_scenario(rng, tight if i % 2 else DEFAULT_RANGES)
        p = rate_peak(config)
        if i % 3 == 0:  # any hover point, reachable or not
            p = Peak(float(rng.uniform(-500.0, 500.0)), float(rng.uniform(-300.0, 300.0)), 0.0)
        ours, theirs = hover_flight(config, p), _guarded_every_slot(config, p)
        assert np.array_equal(ours, theirs) and np.array_equal(np.signbit(ours), np.signbit(theirs))
        hovered += int(np.any(np.all(np.diff(ours, axis=0) == 0.0, axis=1)))
    assert hovered > 20  # the skipped slots are covered
