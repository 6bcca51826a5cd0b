"""The energy reward's default lambda_ref in compiled kernels (ios_uav_env/model/hover_reference.py):
the hover flight and its EE equal ``hover_flight`` and ``score_plan``'s to rounding, with and
without numba."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from ios_uav_env.envs.observation import hover_flight, reference_efficiency
from ios_uav_env.model.channel import rate_kernel
from ios_uav_env.model.hover_reference import flight_efficiency, hover_path, move_power
from ios_uav_env.model.peak import Peak, rate_peak
from ios_uav_env.model.propulsion import PropulsionModel, propulsion_power
from ios_uav_env.model.scenarios import DEFAULT_RANGES, ScenarioRanges, sample_scenario
from ios_uav_env.model.score import score_plan
from tests.processes import run_without_numba

#: EE of the compiled kernels against ``score_plan``'s: the sums' order (numpy's are pairwise) and
#: the rates' kernel (compiled against numpy's) differ by rounding, ~1e-15 relative; a changed
#: formula (a missing slot, dt, the bandwidth) moves it by 1e-3 or more.
EE_REL = 1e-12

ENERGY = dataclasses.replace(DEFAULT_RANGES, base=DEFAULT_RANGES.base.replace(objective="energy_efficiency"))
TIGHT = ScenarioRanges(T=(34.0, 90.0), base=ENERGY.base)  # horizons down to no spare move


def _constants(model: PropulsionModel) -> np.ndarray:
    return np.array([model.P0, model.U_tip, model.P_i, model.v0, model.drag_coefficient])


def test_move_power_is_propulsion_power_bit_for_bit():
    model = PropulsionModel(P0=70.0, d0=0.9)
    for v in [0.0, 1e-9, 3.3, 10.0, 18.7, 25.0, 40.0, 119.0]:
        assert move_power(v, *_constants(model)) == propulsion_power(v, model)


def test_the_compiled_flight_is_the_hover_flight_to_rounding():
    rng = np.random.default_rng(0)
    for i in range(60):
        config = sample_scenario(rng, TIGHT if i % 2 else ENERGY)
        p = rate_peak(config, compiled=True)
        if i % 3 == 0:
            p = Peak(float(rng.uniform(-500.0, 500.0)), float(rng.uniform(-300.0, 300.0)), 0.0)
        (x, y), (fx, fy) = config.q0, config.qF
        ours = hover_path(x, y, fx, fy, p.x, p.y, config.D, config.N)
        np.testing.assert_allclose(ours, hover_flight(config, p), rtol=0, atol=1e-9)
        assert tuple(ours[-1]) == config.qF  # the guard lands it on qF exactly


def test_lambda_ref_is_score_plans_ee_of_the_hover_flight():
    rng = np.random.default_rng(1)
    for i in range(60):
        config = sample_scenario(rng, TIGHT if i % 2 else ENERGY)
        p = rate_peak(config, compiled=True)
        expected = score_plan(config, hover_flight(config, p)).energy_efficiency
        assert reference_efficiency(config, p) == pytest.approx(expected, rel=EE_REL)
        assert reference_efficiency(config) == reference_efficiency(config, p)


def test_flight_efficiency_scores_any_flight_as_score_plan():
    rng = np.random.default_rng(2)
    for _ in range(20):
        config = sample_scenario(rng, ENERGY).replace(bandwidth_hz=2e6, propulsion={"P0": 60.0})
        q = np.linspace(config.q0, config.qF, config.N) + rng.normal(0.0, 3.0, (config.N, 2))
        k = rate_kernel(config)
        ours = flight_efficiency(q, k.nodes, k.params, config.dt, config.bandwidth_hz, config.T,
                                 _constants(config.propulsion))  # fmt: skip
        assert ours == pytest.approx(score_plan(config, q).energy_efficiency, rel=EE_REL)


def test_the_plain_python_kernels_agree():
    code = """
import json, sys
import numpy as np
from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model.channel import rate_kernel
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.hover_reference import flight_efficiency, hover_path
from ios_uav_env.model.peak import rate_peak
from ios_uav_env.envs.observation import hover_flight, reference_efficiency
assert not HAVE_NUMBA
out = []
for c in json.load(sys.stdin):
    config = ScenarioConfig.from_dict(c)
    p = rate_peak(config, resolution=40.0, refine=0.0)
    (x, y), (fx, fy) = config.q0, config.qF
    path = hover_path(x, y, fx, fy, p.x, p.y, config.D, config.N)
    m, k = config.propulsion, rate_kernel(config)
    ee = flight_efficiency(path, k.nodes, k.params, config.dt, config.bandwidth_hz, config.T,
                           np.array([m.P0, m.U_tip, m.P_i, m.v0, m.drag_coefficient]))
    out.append([bool(np.array_equal(path, hover_flight(config, p))), ee, reference_efficiency(config, p)])
print(json.dumps(out))
"""
    rng = np.random.default_rng(3)
    configs = [sample_scenario(rng, ENERGY).to_dict() for _ in range(3)]
    for same_path, ee, expected in json.loads(run_without_numba(code, stdin=json.dumps(configs))):
        assert same_path  # in Python, hypot is Python's: the hover flight bit for bit
        assert ee == pytest.approx(expected, rel=EE_REL)
