"""The env's info at the end of an episode is ``score_plan``'s verdict on the flown trajectory:
for every registered id, single and batched, its feasibility (eq. (10) and the energy budget) and
the value of the scenario's objective, with and without an energy budget (one exceeded)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env
from ios_uav_env import ScenarioConfig, score_plan
from ios_uav_env.envs.multi import DEFAULT_NODES, MultiNodeEnv
from ios_uav_env.envs.single import IOSUAVEnv

#: Every registered id of the package that flies a plan (the surface control ids' UAV flies a given
#: line: their info is scored against the per-slot optimum, ``test_star_control.py``,
#: ``test_miso_control.py``; the NOMA STAR and SDMA ids' ``score`` is ``score_plan``'s,
#: ``test_star_noma.py``, ``test_miso_sdma_env.py``).
CONTROL_IDS = {
    *ios_uav_env.STAR_CONTROL_IDS, *ios_uav_env.MISO_CONTROL_IDS, *ios_uav_env.STAR_NOMA_IDS,
    *ios_uav_env.MISO_SDMA_IDS,
}  # fmt: skip
IDS = sorted(i for i in gym.registry if i.startswith("ios_uav_env/") and i not in CONTROL_IDS)
RTOL = 1e-9  # the kernels' float64 sums against the model's, in another order
#: Budget factors on the scenario's least energy: just above it (any flight of random moves
#: exceeds it) and three times it (no flight reaches it), and no budget.
BUDGETS = {"none": None, "exceeded": 1.0 + 1e-6, "met": 3.0}


def test_the_ids_here_are_every_registered_id():
    families = (
        ios_uav_env.ENV_IDS, ios_uav_env.ENERGY_IDS, ios_uav_env.MOBILE_IDS, ios_uav_env.MULTINODE_IDS,
        ios_uav_env.MULTINODE_MOBILE_IDS, ios_uav_env.RANDOM_IDS, ios_uav_env.MISO_IDS,
    )  # fmt: skip
    assert set(IDS) == {i for family in families for i in family} and len(IDS) == 13


def _objective_value(info: dict, config: ScenarioConfig) -> float:
    """The info's value of the scenario's objective: the energy efficiency, else the rate
    (multi-node: ``min_rate``, or with channel "rician" the expected-gain ``expected_min_rate``)."""
    if config.objective == "energy_efficiency":
        return float(info["energy_efficiency"])
    if "min_rate" in info:
        return float(info.get("expected_min_rate", info["min_rate"]))
    return float(info["average_rate"])


def _final(env: gym.Env, seed: int) -> dict:
    """The last info of an episode of seeded random moves (and node scores)."""
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    done = False
    while not done:
        _, _, terminated, truncated, info = env.step(rng.uniform(-1.0, 1.0, env.action_space.shape))
        done = terminated or truncated
    return info


def _assert_agrees(info: dict, config: ScenarioConfig, trajectory, shares, paths) -> object:
    score = score_plan(config, trajectory, shares, paths)
    assert bool(info["feasible"]) == score.feasible
    assert _objective_value(info, config) == pytest.approx(score.objective_value, rel=RTOL)
    if "energy" in info:
        assert float(info["energy"]) == pytest.approx(score.energy, rel=RTOL)
    if "best_schedule_rate" in info:
        best = score.best_schedule_rate  # (an LP's optimum: to its solver's tolerance)
        assert float(info["best_schedule_rate"]) == pytest.approx(best, rel=1e-6, abs=1e-9)
    return score


def _budgeted(env_id: str, factor: float | None, make=gym.make, **kwargs) -> tuple[object, int]:
    """(the env of ``env_id`` made with a budget of ``factor`` times the least energy of its
    episode of seed s, s) for the first s whose scenario admits that budget: a randomised id's
    family must admit it too (its base, the paper's T = 150 s)."""
    for seed in range(20):
        probe = gym.make(env_id)
        probe.reset(seed=seed)
        budget = None if factor is None else factor * probe.unwrapped.config.least_energy()
        try:
            return make(env_id, **kwargs, **({} if budget is None else {"energy_budget_j": budget})), seed
        except ValueError:
            continue
    raise AssertionError(f"no seed of {env_id} admits a budget of {factor} x its least energy")


@pytest.mark.parametrize("budget", sorted(BUDGETS))
@pytest.mark.parametrize("env_id", IDS)
def test_the_final_info_is_score_plans_verdict_on_every_id(env_id, budget):
    env, seed = _budgeted(env_id, BUDGETS[budget])
    info = _final(env, seed)
    base = env.unwrapped
    shares = base.shares if base.config.K > 1 else None
    assert (base.config.energy_budget_j is None) == (budget == "none")
    score = _assert_agrees(info, base.config, base.trajectory, shares, base.paths)
    if budget == "exceeded":  # the case where the env used to report a feasible flight
        assert score.report.energy_excess > 0 and not info["feasible"]
    else:
        assert info["feasible"]  # (the guard: eq. (10) holds; the budget is met)


@pytest.mark.parametrize("env_id", IDS)
def test_the_batched_form_agrees_too(env_id):
    """The row's last info in the id's natively batched env (an exceeded budget)."""
    vec, seed = _budgeted(env_id, 1.0, gym.make_vec, num_envs=1, vectorization_mode="vector_entry_point")
    base = vec.unwrapped
    base.reset(seed=seed)
    rng = np.random.default_rng(0)
    finals: dict[int, tuple] = {}
    while len(finals) < base.num_envs:
        _, _, terminated, _, info = base.step(rng.uniform(-1.0, 1.0, base.action_space.shape))
        for i in np.flatnonzero(terminated):
            if int(i) not in finals:
                row = {key: value[i] for key, value in info.items() if not key.startswith("_")}
                env = base.envs[i]
                shares = base.schedules[i] if env.config.K > 1 else None
                finals[int(i)] = (row, env.config, base.trajectories[i], shares, env.paths)
    for row, config, trajectory, shares, paths in finals.values():
        assert config.energy_budget_j is not None
        assert not _assert_agrees(row, config, trajectory, shares, paths).feasible


@pytest.mark.parametrize(
    "changes",
    [{"objective": "energy_efficiency"}, {"bandwidth_hz": 2.5e6, "objective": "energy_efficiency"},
     {"propulsion": {"P0": 60.0, "v0": 5.0}}, {"v_max": 30.0, "dt": 0.5}, {"surface": "ris"}],
    ids=["objective", "bandwidth", "propulsion", "slots", "surface"],
)  # fmt: skip
@pytest.mark.parametrize(
    "options", [{}, {"arrival_guard": False}, {"channel": "rician"}], ids=["guard", "noguard", "rician"]
)
@pytest.mark.parametrize("budget", [1.0, 3.0])
def test_every_scoring_field_and_option_agrees(changes, options, budget):
    """The scenario fields that enter the score or the check, and the options that change the
    flight (no guard: eq. (10) breached) or the reward's rate (fading), under a budget that the
    random flight exceeds and one that it meets: the info still agrees."""
    config = ScenarioConfig(T=40.0, ios_shape=(100, 20)).replace(**changes)
    config = config.replace(energy_budget_j=budget * config.least_energy())
    env = IOSUAVEnv(config, **options)
    info = _final(env, 1)
    _assert_agrees(info, config, env.trajectory, None, None)


@pytest.mark.parametrize("budget", sorted(BUDGETS))
@pytest.mark.parametrize("knowledge", ["exact", "reports", "rates"])
def test_a_moving_node_with_the_energy_objective_agrees_single_and_batched(knowledge, budget):
    """The mobile id given the energy objective: its EE at slot N is ``score_plan``'s on the true
    path (not on the configured node), and the energy budget books feasibility, single and batched
    (two rows, each to the end of its first episode)."""
    kwargs = {"objective": "energy_efficiency", "knowledge": knowledge}
    env, seed = _budgeted(ios_uav_env.MOBILE_ID, BUDGETS[budget], **kwargs)
    info = _final(env, seed)
    base = env.unwrapped
    score = _assert_agrees(info, base.config, base.trajectory, None, base.paths)
    assert score.objective_value == score.energy_efficiency
    assert score.feasible == (budget != "exceeded") == bool(info["feasible"])
    static = score_plan(base.config, base.trajectory)  # (the configured node scores otherwise)
    assert static.energy_efficiency != pytest.approx(score.energy_efficiency, rel=1e-6)
    vec, seed = _budgeted(ios_uav_env.MOBILE_ID, BUDGETS[budget], gym.make_vec, num_envs=2,
                          vectorization_mode="vector_entry_point", **kwargs)  # fmt: skip
    batch = vec.unwrapped
    batch.reset(seed=seed)
    rng = np.random.default_rng(seed)
    finals: dict[int, tuple] = {}
    while len(finals) < batch.num_envs:
        _, _, terminated, _, info = batch.step(rng.uniform(-1.0, 1.0, batch.action_space.shape))
        for i in np.flatnonzero(terminated):
            if int(i) not in finals:
                row = {key: value[i] for key, value in info.items() if not key.startswith("_")}
                finals[int(i)] = (row, batch.envs[i].config, batch.trajectories[i], None, batch.envs[i].paths)
    for row, config, trajectory, shares, paths in finals.values():
        score = _assert_agrees(row, config, trajectory, shares, paths)
        assert score.feasible == (budget != "exceeded")


@pytest.mark.parametrize(
    "changes",
    [{"objective": "energy_efficiency"}, {"bandwidth_hz": 2.5e6, "objective": "energy_efficiency"},
     {"propulsion": {"P0": 60.0, "v0": 5.0}, "objective": "energy_efficiency"}, {}],
    ids=["objective", "bandwidth", "propulsion", "rate"],
)  # fmt: skip
@pytest.mark.parametrize(
    "options", [{}, {"arrival_guard": False}, {"channel": "rician"}], ids=["guard", "noguard", "rician"]
)
@pytest.mark.parametrize("budget", [1.0, 3.0])
def test_the_multi_node_objectives_and_channels_agree(changes, options, budget):
    """Several nodes with the energy objective or the max-min rate, with the guard, without it, and
    with faded rates (the score keeps the expected-gain rates), under a budget exceeded and one met."""
    config = ScenarioConfig(T=40.0, ios_shape=(100, 20), ground_nodes=DEFAULT_NODES).replace(**changes)
    config = config.replace(energy_budget_j=budget * config.least_energy())
    env = MultiNodeEnv(config, **options)
    info = _final(env, 1)
    score = _assert_agrees(info, config, env.trajectory, env.shares, None)
    assert ("energy_efficiency" in info) == (config.objective == "energy_efficiency")
    if budget == 1.0 and options.get("arrival_guard", True):  # (a flight that reaches qF exceeds it)
        assert score.report.energy_excess > 0 and not info["feasible"]
