"""agents.evaluate / agents.rollout: the shipped agents reproduce their records; the comparison
with the planners (table, CSV, figure, Rician statistics) is consistent."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from agents.evaluate import MODELS_DIR, SHIPPED, Row, compare, faded_replay, main  # noqa: E402
from agents.loading import load_agent  # noqa: E402
from agents.rollout import rollout, run_seeds  # noqa: E402
from ios_uav_env import ScenarioConfig, average_rate, check_trajectory, scheduled_rates  # noqa: E402
from tests.tolerances import MISS_ABS, NORMALISATION_CHANGE, RATE_REL  # noqa: E402

DEFAULT = ScenarioConfig()


@pytest.fixture(scope="module")
def agents():
    return {name: load_agent(MODELS_DIR / name) for name in SHIPPED}


@pytest.fixture(scope="module")
def dp_rate():
    from baselines.dp import solve

    return solve(DEFAULT).mean_rate  # 2.404068 on the 2.5 m grid


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_agent_reproduces_its_recorded_rate(agents, name, dp_rate):
    agent = agents[name]
    summary = json.loads((MODELS_DIR / name / "summary.json").read_text())
    episode = rollout(agent)
    # to the tolerance any CPU meets (tests/tolerances.py)
    assert _matches_record(episode, summary["final_eval"])
    # the episode is scored by the model itself, not by the env's reward
    assert episode.average_rate == average_rate(DEFAULT, episode.trajectory)
    report = check_trajectory(DEFAULT, episode.trajectory)
    assert report.max_step <= DEFAULT.D + 1e-6
    config = json.loads((MODELS_DIR / name / "config.json").read_text())
    if config["arrival_guard"]:  # the bars: feasible, >= 99.5% of DP
        assert report.feasible and episode.feasible
        assert episode.average_rate >= 0.995 * dp_rate
    else:  # the unguarded agent lands by itself (the bar: within 1 m of qF, >= 99% of DP)
        assert episode.terminal_miss < 1.0 and episode.average_rate >= 0.99 * dp_rate
    assert (MODELS_DIR / name / "model.zip").stat().st_size < 400_000  # no replay buffer shipped


def _matches_record(episode, record) -> bool:
    return episode.average_rate == pytest.approx(record["average_rate"], rel=RATE_REL) and (
        episode.terminal_miss == pytest.approx(record["terminal_miss"], abs=MISS_ABS)
    )


class _ScaledObservations:
    """``agent`` with every observation multiplied by ``1 + change``: a changed normalisation."""

    def __init__(self, agent, change: float) -> None:
        self.agent, self.change = agent, change
        self.env_id, self.env_kwargs = agent.env_id, agent.env_kwargs

    def act(self, obs):
        return self.agent.act(obs * (1.0 + self.change))


@pytest.mark.parametrize("name", [*SHIPPED, "ppo_IOSUAV-MultiNode-v0"])
def test_the_record_tolerance_catches_a_changed_normalisation(agents, name):
    # the tolerances that let another CPU's float32 kernels pass must not let a real regression pass
    agent = agents[name] if name in agents else load_agent(MODELS_DIR / name)
    record = json.loads((MODELS_DIR / name / "summary.json").read_text())["final_eval"]
    assert _matches_record(rollout(agent), record)
    assert not _matches_record(rollout(_ScaledObservations(agent, NORMALISATION_CHANGE)), record)


def test_agents_rician_rate_equals_its_trajectory_replayed(agents):
    # common random numbers: the agent in the Rician env and its trajectory replayed get the same draws
    # (the replay runs its seeds at once in the batched env, the agent here in single envs)
    agent = agents[SHIPPED[0]]
    episode = rollout(agent)
    replayed = faded_replay(DEFAULT, episode.trajectory, 2)
    rician = {**agent.env_kwargs, "channel": "rician"}
    batched = run_seeds(agent, DEFAULT, agent.env_id, rician, 2)  # add_rician's agent episodes
    for seed in (0, 1):
        faded = rollout(agent, env_kwargs=rician, seed=seed)
        np.testing.assert_allclose(faded.trajectory, episode.trajectory, atol=1e-9)
        assert faded.mean_faded_rate == pytest.approx(replayed[seed], rel=1e-12)
        # the same episode, up to torch's float32 arithmetic on a batch of 2 instead of 1: the
        # tolerance allows for rounding differences of the actions (float32, ~1e-7 relative) that
        # accumulate over the episode; the rate follows (the LoS phase moves by 2 pi x dq / lambda)
        np.testing.assert_allclose(batched[seed].trajectory, faded.trajectory, atol=1e-4)
        assert batched[seed].mean_faded_rate == pytest.approx(faded.mean_faded_rate, rel=1e-4)
    assert replayed[0] != replayed[1]


def test_faded_replay_uses_the_trajectorys_own_surface():
    hover = np.linspace(DEFAULT.q0, (100.0, 0.0), 22)
    trajectory = np.vstack(
        [
            hover,
            np.repeat(hover[-1:], DEFAULT.N - 22 - 13, axis=0),
            np.linspace((100.0, 0.0), DEFAULT.qF, 14)[1:],
        ]
    )
    assert check_trajectory(DEFAULT, trajectory).feasible
    ios = faded_replay(DEFAULT, trajectory, 1)[0]
    none = faded_replay(DEFAULT.replace(surface="none"), trajectory, 1)[0]
    assert none < 0.5 * ios  # the direct link alone is far weaker at the IOS's transmissive side


def test_compare_scores_agents_and_planners_alike(agents):
    rows = compare([agents[SHIPPED[0]]], DEFAULT, schemes=("dp", "ia-ft"), rician_seeds=3)
    assert [r.kind for r in rows] == ["planner", "planner", "agent"]
    dp, ft, agent = rows
    assert dp.pct_dp == pytest.approx(100.0) and dp.feasible and ft.feasible
    assert agent.pct_dp == pytest.approx(100.0 * agent.average_rate / dp.average_rate)
    assert ft.average_rate < agent.average_rate <= dp.average_rate * 1.01
    for row in rows:
        assert row.average_rate == pytest.approx(average_rate(row.config, row.trajectory), abs=1e-12)
        assert 0.7 * row.average_rate < row.faded_mean < row.average_rate and row.faded_std > 0


def test_cli_writes_table_csv_and_figure(tmp_path, capsys):
    code = main(
        [str(MODELS_DIR / SHIPPED[0]), "--schemes", "ia-ft", "--rician-seeds", "2", "--out", str(tmp_path)]
    )
    assert code == 0
    out = capsys.readouterr().out
    assert "| IA-FT |" in out and f"| {SHIPPED[0]} |" in out
    rows = list(csv.DictReader((tmp_path / "comparison.csv").open()))
    assert [r["scheme"] for r in rows] == ["IA-FT", SHIPPED[0]]
    assert float(rows[1]["average_rate"]) > float(rows[0]["average_rate"]) > 0
    assert (tmp_path / "comparison.md").read_text().startswith("| scheme |")
    assert (tmp_path / "comparison.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_refuses_an_out_holding_a_comparison_and_overwrite_replaces_it(tmp_path, capsys, monkeypatch):
    import agents.evaluate as evaluate

    loaded = []
    monkeypatch.setattr(evaluate, "load_agent", lambda path: loaded.append(path) or load_agent(path))
    (tmp_path / "comparison.md").write_text("a previous comparison\n")
    argv = [str(MODELS_DIR / SHIPPED[0]), "--schemes", "--rician-seeds", "0", "--out", str(tmp_path)]
    with pytest.raises(SystemExit) as exc:
        main(argv)
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert exc.value.code == 2 and "argument --out: " in line and "comparison.md" in line
    assert "--overwrite" in line
    assert not loaded and (tmp_path / "comparison.md").read_text() == "a previous comparison\n"
    assert main([*argv, "--overwrite"]) == 0
    assert (tmp_path / "comparison.md").read_text().startswith("| scheme |") and loaded
    assert {p.name for p in tmp_path.iterdir()} == {"comparison.md", "comparison.csv", "comparison.png"}


@pytest.mark.parametrize(
    "argv, message",
    [
        ([], "give model folders or --shipped"),
        (["--shipped", "--scenario", "T:-1"], "argument --scenario"),
        (["/nonexistent"], "no model at"),
    ],
)
def test_cli_rejects_bad_input(capsys, argv, message):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2 and message in capsys.readouterr().err


def test_row_defaults_are_missing_values():
    row = Row("x", "agent", 1.0, True, 0.1, np.zeros((2, 2)), DEFAULT)
    assert np.isnan(row.pct_dp) and np.isnan(row.faded_mean) and np.isnan(row.terminal_miss)
    assert np.isnan(row.pct_sca) and np.isnan(row.best_schedule_rate) and row.average_rate == row.rate == 1.0


# --- multi-node agents (agents.evaluate_multi) ------------------------------------------------
MULTI_ID = "ios_uav_env/IOSUAV-MultiNode-v0"
#: A short 3-node scenario with a small surface: its planners (SCA, tour, bound) run in seconds.
SMALL_MULTI = ["T:40", "ios_shape:(10,6)"]


@pytest.fixture(scope="module")
def multi_model(tmp_path_factory):
    """An untrained PPO of the fixed 3-node id, saved as a model folder (model.zip + config.json)."""
    import gymnasium as gym
    from stable_baselines3 import PPO

    folder = tmp_path_factory.mktemp("models") / "ppo_tiny_MultiNode-v0"
    folder.mkdir()
    PPO("MlpPolicy", gym.make(MULTI_ID), seed=0, device="cpu").save(folder / "model.zip")
    config = {"algo": "ppo", "env_id": MULTI_ID, "env_kwargs": {}}
    (folder / "config.json").write_text(json.dumps(config))
    return folder


def test_a_multinode_agent_is_compared_with_sca_tour_and_the_bound(
    tmp_path, multi_model, capsys, monkeypatch
):
    import gymnasium as gym

    from agents.evaluate_multi import DEFAULT_MULTI, REFERENCE_CACHE, compare_multi, fast_act
    from ios_uav_env.model.schedule import maxmin_rate, scheduled_rates

    monkeypatch.chdir(tmp_path)  # the reference cache is out/multinode-references under the cwd
    assert main([str(multi_model), "--scenario", *SMALL_MULTI, "--out", "cmp"]) == 0
    out = capsys.readouterr().out
    for scheme in (
        "| SCA (BCD) |",
        "| tour heuristic |",
        "| upper bound (2.5 m) |",
        "| ppo_tiny_MultiNode-v0 |",
    ):
        assert scheme in out, scheme
    rows = {r["scheme"]: r for r in csv.DictReader((tmp_path / "cmp" / "comparison.csv").open())}
    sca, tour, bound = rows["SCA (BCD)"], rows["tour heuristic"], rows["upper bound (2.5 m)"]
    agent = rows["ppo_tiny_MultiNode-v0"]
    assert float(sca["pct_sca"]) == 100.0 and float(bound["pct_bound"]) == 100.0
    assert float(tour["rate"]) <= float(sca["rate"]) <= float(bound["rate"])
    assert float(agent["rate"]) <= float(agent["best_schedule_rate"]) <= float(bound["rate"])
    assert agent["feasible"] == "True"
    assert (tmp_path / "cmp" / "comparison.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(list(REFERENCE_CACHE.glob("*.json"))) == 1  # cached: the next call reads it
    # the agent's own score is the env's min rate at the last step, and the scorer's
    agent_obj = load_agent(multi_model)
    config = DEFAULT_MULTI.replace(T=40.0, ios_shape=(10, 6))
    (*_, row) = compare_multi([agent_obj], config)
    env = gym.make(MULTI_ID, config=config)
    obs, _ = env.reset(seed=0)
    done, act = False, fast_act(agent_obj)  # the numpy export the comparison plans with
    while not done:
        obs, _, done, _, info = env.step(act(obs))
    q, shares = env.unwrapped.trajectory, env.unwrapped.shares
    np.testing.assert_array_equal(row.trajectory, q)
    assert row.rate == pytest.approx(info["min_rate"], rel=1e-12)
    assert row.rate == scheduled_rates(config, q, shares).min()
    assert row.best_schedule_rate == maxmin_rate(config, q) == info["best_schedule_rate"]


def test_multinode_and_single_node_agents_do_not_share_a_table(multi_model, capsys):
    with pytest.raises(SystemExit):
        main([str(multi_model), str(MODELS_DIR / SHIPPED[0])])
    assert "cannot share a table" in capsys.readouterr().err


def test_an_infeasible_planner_plan_scores_zero_in_the_multinode_table():
    """Planner rows are scored as every multi-node plan: an infeasible one gets 0 % (its rate kept)."""
    from agents.evaluate_multi import planner_rows
    from ios_uav_env.benchmark import load_suite

    scenario = load_suite("multi-node-v1")[0]
    cfg = scenario.config
    stay = np.tile(cfg.q0, (cfg.N, 1)).tolist()  # never reaches qF
    equal = np.full((cfg.K, cfg.N), 1.0 / cfg.K).tolist()
    record = {
        "sca": {"trajectory": stay, "shares": equal, "seconds": 1.0},
        "tour": {"trajectory": None, "shares": None, "seconds": 2.0},
        "bound": {"resolution": 2.5, "seconds": 3.0},
    }
    sca, tour, bound = planner_rows(scenario, record)
    assert not sca.feasible and sca.rate > 0 and (sca.pct_sca, sca.pct_bound) == (0.0, 0.0)
    assert not tour.feasible and tour.rate == 0.0
    assert bound.pct_bound == 100.0 and bound.pct_sca == pytest.approx(
        100 * scenario.rate("bound") / scenario.rate("sca")
    )


def test_shipped_multinode_agent_reproduces_its_score_feasibly():
    # agents/models/ppo_IOSUAV-MultiNode-v0: 97.13% of SCA, 97.57% of the tour as recorded (the
    # bar: >= 97% of SCA); this guards the model, its VecNormalize statistics, the env arguments
    # and the score
    import gymnasium as gym

    from baselines.tour import solve
    from ios_uav_env.envs.rollout import run_episode

    folder = MODELS_DIR / "ppo_IOSUAV-MultiNode-v0"
    agent = load_agent(folder)
    summary = json.loads((folder / "summary.json").read_text())
    env = gym.make(agent.env_id, **agent.env_kwargs)
    episode = run_episode(env, agent, seed=0)
    cfg = env.unwrapped.config
    own = scheduled_rates(cfg, episode.trajectory, env.unwrapped.shares).min()  # the one scorer
    assert episode.average_rate == pytest.approx(own, rel=1e-12)
    assert episode.average_rate == pytest.approx(summary["final_eval"]["average_rate"], rel=RATE_REL)
    assert episode.feasible and check_trajectory(cfg, episode.trajectory).feasible
    assert episode.average_rate >= 0.975 * solve(cfg).mean_rate  # the tour: 0.468872
    assert episode.average_rate >= 0.97 * 0.471001  # SCA's value (python -m agents.evaluate <model>)
