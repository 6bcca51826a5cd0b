"""The shipped energy and moving-node agents: each replays its record and holds its bar."""

from __future__ import annotations

import json

import gymnasium as gym
import pytest

pytest.importorskip("stable_baselines3")

from agents.evaluate import MODELS_DIR  # noqa: E402
from agents.loading import load_agent, load_numpy_agent  # noqa: E402
from ios_uav_env import ENERGY_ID, score_plan  # noqa: E402
from ios_uav_env.envs.rollout import run_episode  # noqa: E402
from tests.tolerances import MOBILE_REPLAY_REL, NORMALISATION_CHANGE, RATE_REL  # noqa: E402

#: bits/J, DP-EE's energy efficiency on the energy id's scenario (2.5 m grid; printed by
#: ``python benchmarks/energy.py``): the agent's bar is 99 % of it.
DP_EE = 17155.06


def test_the_energy_agent_replays_its_record_above_99_percent_of_dp():
    agent = load_agent(MODELS_DIR / "ppo_IOSUAV-Energy-v0")
    assert agent.env_id == ENERGY_ID and agent.env_kwargs == {"energy_reference": DP_EE}
    record = json.loads((MODELS_DIR / "ppo_IOSUAV-Energy-v0" / "summary.json").read_text())["final_eval"]
    env = gym.make(ENERGY_ID, **agent.env_kwargs)
    episode = run_episode(env, agent.act, seed=0)
    # the record is the episode's average rate; to the tolerance any CPU meets (tests/tolerances.py)
    assert episode.average_rate == pytest.approx(record["average_rate"], rel=RATE_REL)
    score = score_plan(env.unwrapped.config, episode.trajectory)
    assert score.report.feasible and score.energy_efficiency >= 0.99 * DP_EE
    assert episode.energy_efficiency == pytest.approx(score.energy_efficiency, rel=1e-9)
    # the numpy export flies the same plan; a changed normalisation would not
    fast = run_episode(env, load_numpy_agent(MODELS_DIR / "ppo_IOSUAV-Energy-v0"), seed=0)
    assert fast.average_rate == pytest.approx(record["average_rate"], rel=RATE_REL)
    scaled = run_episode(env, lambda o: agent.act(o * (1.0 + NORMALISATION_CHANGE)), seed=0)
    assert scaled.average_rate != pytest.approx(record["average_rate"], rel=RATE_REL)


def test_the_energy_generalist_replays_its_record_with_the_loiter_reference():
    """Its deterministic episode of the randomised energy id (seed 0) replays to the tolerance any
    CPU meets; the loiter reference and the peak hint are what it was trained with (and its suite
    row, in docs/leaderboard.md, reruns in test_leaderboard, above the loiter heuristic's)."""
    from ios_uav_env import ENERGY_RANDOM_ID

    path = MODELS_DIR / "ppo_IOSUAV-Energy-Random-v0"
    agent = load_agent(path)
    assert agent.env_id == ENERGY_RANDOM_ID
    assert agent.env_kwargs == {"energy_reference": "loiter", "peak_hint": True}
    record = json.loads((path / "summary.json").read_text())["final_eval"]
    env = gym.make(ENERGY_RANDOM_ID, **agent.env_kwargs)
    episode = run_episode(env, agent.act, seed=0)
    assert episode.average_rate == pytest.approx(record["average_rate"], rel=RATE_REL) and episode.feasible
    scaled = run_episode(env, lambda o: agent.act(o * (1.0 + NORMALISATION_CHANGE)), seed=0)
    assert scaled.average_rate != pytest.approx(record["average_rate"], rel=RATE_REL)


def test_the_mobile_agent_replays_its_record_and_follows_the_node():
    """The deterministic episode of its training env (seed 0) replays; on suite scenarios it ends
    above MPC(k=1) on average, feasible, and below the clairvoyant bound on every one."""
    from ios_uav_env import MOBILE_ID
    from ios_uav_env.benchmark import evaluate

    path = MODELS_DIR / "ppo_IOSUAV-Mobile-v0"
    agent = load_agent(path)
    assert agent.env_id == MOBILE_ID and agent.env_kwargs == {}  # the id's own observation: raw reports
    clone = json.loads((path / "clone.json").read_text())  # its warm start, recorded
    assert clone["settings"]["expert"] == "ios_uav_env.envs.policies:HoverAt('ground')"
    record = json.loads((path / "summary.json").read_text())["final_eval"]
    env = gym.make(MOBILE_ID, **agent.env_kwargs)
    episode = run_episode(env, agent.act, seed=0)
    # its closed loop turns an ulp of an action into another flight: the record holds to
    # MOBILE_REPLAY_REL on another CPU, and two replays on this machine are equal bit for bit
    assert episode.average_rate == pytest.approx(record["average_rate"], rel=MOBILE_REPLAY_REL)
    assert run_episode(env, agent.act, seed=0).average_rate == episode.average_rate
    results = evaluate(load_numpy_agent(path), "mobile-v1", n=8)
    a = results.aggregate
    assert a.feasible == 8 and a.mean_pct_mpc_k1 > 100.0
    assert all(0.0 < r.pct["bound"] < 100.0 for r in results.scenarios)  # the clairvoyant bound holds


def test_the_energy_benchmark_flies_an_agent_on_the_benchmarks_own_scenario():
    """benchmarks/energy.py --agents: the agent's row is its episode on the table's scenario (the
    id's registered surface does not override it), scored by the one scorer."""
    import importlib.util
    from pathlib import Path

    from ios_uav_env import ScenarioConfig

    spec = importlib.util.spec_from_file_location(
        "energy_bench", Path(__file__).parents[2] / "benchmarks" / "energy.py"
    )
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    for surface in ("ios", "none"):
        config = ScenarioConfig(surface=surface, objective="energy_efficiency")
        plan = bench.agent_plan(str(MODELS_DIR / "ppo_IOSUAV-Energy-v0"), config)
        assert plan.config == config and plan.feasible
        assert plan.energy_efficiency == score_plan(config, plan.trajectory).energy_efficiency
        if surface == "ios":
            assert plan.energy_efficiency >= 0.99 * DP_EE
