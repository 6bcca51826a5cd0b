"""The planner registry: every planner and bound honours the config's problem or refuses it.

Each registered entry point is called, for real, on a scenario of every problem class (rate with
one and two nodes, energy efficiency, a rate within an energy budget, energy efficiency with a
budget, moving nodes): where the registry says it does not handle the problem the call must
raise :class:`PlannerMismatch` before any work, naming the planners that do; where it does, the
cheap planners run and their plan is scored on the config as given. Removing the check from any
planner's ``solve`` makes it run on a problem it does not solve, and a test here fails.
"""

from __future__ import annotations

import numpy as np
import pytest

from baselines import registry
from baselines.mpc import MPC
from baselines.registry import PLANNERS, PlannerMismatch, check, handlers
from ios_uav_env import ScenarioConfig
from ios_uav_env.model.mobility import GaussMarkov
from ios_uav_env.model.motion import node_paths

RATE = ScenarioConfig(T=40.0, q0=(-200.0, 20.0), qF=(200.0, 20.0), ios_shape=(10, 6))
TWO = ((-100.0, -20.0), (120.0, 40.0))
PROBLEMS: dict[str, ScenarioConfig] = {
    "rate": RATE,
    "maxmin": RATE.replace(ground_nodes=TWO),
    "ee": RATE.replace(objective="energy_efficiency"),
    "budget": RATE.replace(energy_budget_j=20_000.0),
    "ee-budget": RATE.replace(objective="energy_efficiency", energy_budget_j=20_000.0),
    "moving": RATE.replace(motion=GaussMarkov(speed=3.0, sigma=1.0)),
    "moving-maxmin": RATE.replace(ground_nodes=TWO, motion=GaussMarkov(speed=3.0, sigma=1.0)),
    "moving-ee": RATE.replace(objective="energy_efficiency", motion=GaussMarkov(speed=3.0, sigma=1.0)),
    "noma": RATE.replace(surface="star", star_access="noma", ground_nodes=TWO),
    "miso": RATE.replace(antennas=4),
    "sdma": RATE.replace(antennas=4, ground_nodes=TWO),
}
#: The arguments each entry point takes after the config.
EXTRA = {"mpc": (MPC(k=None), 0), "dp-bound": (None,), "dp-clairvoyant": (None, 10.0)}
#: The entries cheap enough to run here on every problem they accept (the others, SCA and the
#: energy bound, are run on their problems by their own tests).
CHEAP = (
    "dp", "dp-ee", "dp-budget", "dp-clairvoyant", "dp-star", "dp-miso", "tour", "fixed", "loiter", "hover",
    "mpc",
)  # fmt: skip


def _call(name: str, config: ScenarioConfig, **kwargs):
    spec = PLANNERS[name]
    grid = {"resolution": 10.0} if name in ("dp", "dp-ee", "dp-budget", "dp-star", "dp-miso") else {}
    return spec.load()(config, *EXTRA.get(name, ()), **grid, **kwargs)


#: Every planner on every problem it refuses, and the cheap ones on those they accept too.
CASES = [(n, p) for n in PLANNERS for p in PROBLEMS if n in CHEAP or PLANNERS[n].problem(PROBLEMS[p])]


@pytest.mark.parametrize(("name", "problem"), CASES, ids=[f"{n}-{p}" for n, p in CASES])
def test_every_planner_honours_or_refuses_every_problem(name, problem):
    config = PROBLEMS[problem]
    why = PLANNERS[name].problem(config)
    if why is not None:
        with pytest.raises(PlannerMismatch, match=f"planner '{name}' does not handle this config") as err:
            _call(name, config)
        others = [p.name for p in handlers(config) + handlers(config, paths=True)]
        named = [n for n in others if f"{n} (" in str(err.value)]
        assert (
            named or "no registered planner handles it" in str(err.value) or "pass paths=" in str(err.value)
        )
        assert name not in named
        return
    result = _call(name, config)
    plan = getattr(result, "score", result)  # run_online returns an OnlineResult with its PlanScore
    if name != "mpc":
        assert plan.config == config  # scored on the config as given: its objective and budget
        assert plan.objective_value == (
            plan.energy_efficiency if config.objective != "rate" else plan.mean_rate
        )
    if PLANNERS[name].kind == "optimum" and config.energy_budget_j is not None:
        assert plan.feasible  # an optimiser that honours the budget meets it


def test_the_named_examples_are_refused_with_the_planner_that_handles_them():
    with pytest.raises(PlannerMismatch, match=r"objective='energy_efficiency'.*dp-ee \(baselines\.dp_energy"):
        _call("dp", PROBLEMS["ee"])
    with pytest.raises(PlannerMismatch, match=r"objective='rate'.*use dp \(baselines\.dp:solve\)"):
        _call("dp-ee", PROBLEMS["rate"])
    with pytest.raises(PlannerMismatch, match=r"energy_budget_j=20000 J.*dp-budget"):
        _call("dp", PROBLEMS["budget"])
    with pytest.raises(PlannerMismatch, match=r"motion.*dp-clairvoyant \(baselines\.dp_moving:solve\)"):
        _call("dp", PROBLEMS["moving"])
    with pytest.raises(PlannerMismatch, match=r"motion without paths=.*; pass paths=.*, or use mpc"):
        _call("tour", PROBLEMS["moving"])
    with pytest.raises(PlannerMismatch, match="no registered planner handles it"):
        _call("dp-ee", PROBLEMS["moving-ee"])
    with pytest.raises(PlannerMismatch, match=r"planner 'mpc'.*objective='energy_efficiency'"):
        _call("mpc", PROBLEMS["ee"])
    with pytest.raises(PlannerMismatch, match=r"planner 'energy-bound'.*motion"):
        _call("energy-bound", PROBLEMS["moving-ee"])
    with pytest.raises(PlannerMismatch, match="no registered planner handles it|use fixed"):
        registry.solve("dp-budget", PROBLEMS["ee-budget"])
    with pytest.raises(
        PlannerMismatch, match=r"star_access='noma'.*use dp-star \(baselines\.dp_star:solve\)"
    ):
        _call("dp", PROBLEMS["noma"])
    with pytest.raises(
        PlannerMismatch, match=r"planner 'dp-star'.*surface='ios'.*use dp \(baselines\.dp:solve\)"
    ):
        _call("dp-star", PROBLEMS["maxmin"])
    with pytest.raises(
        PlannerMismatch, match=r"planner 'sca'.*antennas=4.*use .*dp-miso \(baselines\.dp:solve_miso\)"
    ):
        _call("sca", PROBLEMS["miso"])


def test_dp_energy_dispatches_on_the_config():
    from baselines import dp_energy

    assert dp_energy.solve(PROBLEMS["ee"], resolution=10.0).scheme == "dp-ee"
    assert dp_energy.solve(PROBLEMS["budget"], resolution=10.0).scheme == "dp-budget"
    with pytest.raises(PlannerMismatch, match="use dp"):
        dp_energy.solve(PROBLEMS["rate"], resolution=10.0)


def test_a_moving_config_is_planned_on_the_paths_when_they_are_given():
    config = PROBLEMS["moving"]
    paths = node_paths(config, np.random.default_rng(0))
    check("tour", config, paths)
    plan = registry.solve("tour", config, paths=paths)
    assert plan.info["clairvoyant"]  # scored on the paths, not on the configured positions
    assert registry.solve("dp-bound", config, paths=paths) >= plan.mean_rate * (1 - 1e-9)


def test_a_plan_for_one_problem_is_scored_on_another_only_explicitly():
    from baselines import dp

    rate_plan = dp.solve(PROBLEMS["rate"], resolution=10.0)
    as_ee = rate_plan.scored_on(PROBLEMS["ee"], scheme="rate-dp")
    assert as_ee.scheme == "rate-dp" and as_ee.config == PROBLEMS["ee"]
    assert as_ee.objective_value == as_ee.energy_efficiency == rate_plan.energy_efficiency
    assert np.array_equal(as_ee.trajectory, rate_plan.trajectory)


def test_the_registry_is_well_formed():
    assert list(PLANNERS) == [p.name for p in PLANNERS.values()]
    for spec in PLANNERS.values():
        assert callable(spec.load()), spec.name
    with pytest.raises(ValueError, match="unknown planner 'nope'; registered planners: dp, "):
        registry.get("nope")
    with pytest.raises(ValueError, match="objectives must be among"):
        registry.PlannerSpec("x", "m:f", ("speed",), False, 1, None, "static", "optimum", "")
    with pytest.raises(ValueError, match="motion must be one of"):
        registry.PlannerSpec("x", "m:f", ("rate",), False, 1, None, "walking", "optimum", "")
    with pytest.raises(TypeError, match="config must be a ScenarioConfig"):
        check("dp", {"T": 40})
    # every problem class but one has a registered planner (with the paths, if the nodes move)
    for name, config in PROBLEMS.items():
        assert bool(handlers(config) or handlers(config, paths=True)) == (name != "moving-ee"), name
