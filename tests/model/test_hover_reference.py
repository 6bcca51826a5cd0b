"""The hover plan's flight and its EE, compiled (ios_uav_env/model/hover_reference.py): the same
flight with and without numba (to the guard's rounding), and lambda_ref the EE ``score_plan``
gives it, to rounding."""

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

ENERGY = dataclasses.replace(DEFAULT_RANGES, base=DEFAULT_RANGES.base.replace(objective="energy_efficiency"))
TIGHT = ScenarioRanges(T=(34.0, 90.0), base=ENERGY.base)  # horizons down to no spare move


def _cases(count: int, seed: int) -> list[tuple[dict, list[float]]]:
    """(scenario, hover point) pairs: reachable peaks and arbitrary points, tight horizons too."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        config = sample_scenario(rng, TIGHT if i % 2 else ENERGY)
        p = rate_peak(config, compiled=True)
        if i % 3 == 0:  # any hover point, reachable or not
            p = Peak(float(rng.uniform(-500.0, 500.0)), float(rng.uniform(-300.0, 300.0)), 0.0)
        out.append((config.to_dict(), [p.x, p.y]))
    return out


#: EE of the compiled kernels against ``score_plan``'s: the sums' order (numpy's are pairwise) and
#: the rates' kernel (compiled against numpy's) differ by rounding, ~1e-15 relative (measured 5e-15);
#: a changed formula (a missing slot, dt, the bandwidth, a power term) moves it by 1e-3 or more.
EE_REL = 1e-12


def _constants(model: PropulsionModel) -> np.ndarray:
    return np.array([model.P0, model.U_tip, model.P_i, model.v0, model.drag_coefficient])


@pytest.mark.slow_without_numba
def test_lambda_ref_is_score_plans_ee_of_the_hover_flight():
    rng = np.random.default_rng(1)
    for i in range(40):
        config = sample_scenario(rng, TIGHT if i % 2 else ENERGY)
        p = rate_peak(config, compiled=True)
        expected = score_plan(config, hover_flight(config, p)).energy_efficiency
        assert reference_efficiency(config, p) == pytest.approx(expected, rel=EE_REL)
        assert reference_efficiency(config) == reference_efficiency(config, rate_peak(config, compiled=True))


def test_move_power_is_propulsion_power():
    model = PropulsionModel(P0=70.0, d0=0.9)
    for v in [0.0, 1e-9, 3.3, 10.0, 18.7, 25.0, 40.0, 119.0]:
        assert move_power(v, *_constants(model)) == pytest.approx(propulsion_power(v, model), rel=1e-15)


def test_flight_efficiency_scores_any_flight_as_score_plan():
    rng = np.random.default_rng(2)
    for _ in range(20):
        config = sample_scenario(rng, ENERGY).replace(bandwidth_hz=2e6, propulsion={"P0": 60.0})
        q = np.linspace(config.q0, config.qF, config.N) + rng.normal(0.0, 3.0, (config.N, 2))
        k = rate_kernel(config)
        ours = flight_efficiency(q, k.nodes, k.params, config.dt, config.bandwidth_hz, config.T,
                                 _constants(config.propulsion))  # fmt: skip
        assert ours == pytest.approx(score_plan(config, q).energy_efficiency, rel=EE_REL)


@pytest.mark.slow_without_numba
def test_the_flight_reaches_qf_within_d_per_move():
    from ios_uav_env.model.config import ScenarioConfig
    from ios_uav_env.model.trajectory import check_trajectory

    for config_dict, (px, py) in _cases(30, seed=2):
        config = ScenarioConfig.from_dict(config_dict)
        (x, y), (fx, fy) = config.q0, config.qF
        q = hover_path(x, y, fx, fy, px, py, config.D, config.N)
        assert tuple(q[-1]) == config.qF and check_trajectory(config, q).feasible


@pytest.mark.slow_without_numba
def test_the_compiled_flight_is_the_plain_python_flight():
    code = """
import json, sys
from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.channel import rate_kernel
from ios_uav_env.model.hover_reference import flight_efficiency, hover_path, move_power
assert not HAVE_NUMBA
out = []
for c, (px, py) in json.load(sys.stdin):
    config = ScenarioConfig.from_dict(c)
    (x, y), (fx, fy) = config.q0, config.qF
    out.append(hover_path(x, y, fx, fy, px, py, config.D, config.N).tolist())
print(json.dumps(out))
"""
    cases = _cases(24, seed=3)
    plain = json.loads(run_without_numba(code, stdin=json.dumps(cases)))
    from ios_uav_env.model.config import ScenarioConfig

    for (config_dict, (px, py)), theirs in zip(cases, plain, strict=True):
        config = ScenarioConfig.from_dict(config_dict)
        (x, y), (fx, fy) = config.q0, config.qF
        ours = hover_path(x, y, fx, fy, px, py, config.D, config.N)
        # the guard is compiled on one side only (fused multiply-adds, the C library's hypot): eps-level
        # rounding, which the guard's square root turns into sqrt(eps) D ~ 1e-7 m on a horizon with
        # no spare move (tests/tolerances.py, GOLDEN_REL); a wrong way-point is metres off
        np.testing.assert_allclose(ours, np.array(theirs), rtol=0, atol=1e-6)
