"""STAR-control suites (kind "star-control", star-v1): frozen by the references CLI, checked at load
(keywords, seed, the seed's line), every episode scored by the env's own reward sum, any policy
bound to each scenario, the stored references ordered as the optimum and its bound require."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

from baselines.references.__main__ import main as references_main
from baselines.references.star import SETTINGS, STAR_SIZE, check_star_record, solve_star, star_tasks
from ios_uav_env.benchmark import SUITES, evaluate, load_suite, score_trajectories
from ios_uav_env.benchmark.cli import main as benchmark_main
from ios_uav_env.benchmark.policy_errors import PolicyError
from ios_uav_env.benchmark.star_policies import ChannelPhases
from ios_uav_env.benchmark.star_suite import StarTask, star_episode, star_kwargs
from ios_uav_env.benchmark.suite_registry import suite_path
from tests.benchmark.quick_suites import shipped_copy, tampered
from tests.tolerances import PLANNER_REL, RATE_REL

#: The shipped suite's first scenarios: M = 16 with continuous phases under TDMA, ES-NOMA, MS-NOMA.
FIRST = 3


@pytest.fixture(scope="module")
def frozen(tmp_path_factory):
    """The quick STAR-control suite's first scenario (TDMA, 16 elements), frozen by the CLI."""
    out = tmp_path_factory.mktemp("star")
    argv = ["star", "--quick", "--n", "1", "--cache", str(out / "cache"), "--dir", str(out)]
    assert references_main(argv) == 0
    return out / "star-quick-v1.json"


@pytest.fixture(scope="module")
def shipped():
    return load_suite("star-v1")


@pytest.fixture
def copy(tmp_path):
    """A copy of the shipped suite's first scenarios under a new name (it loads with its own hash)."""
    return shipped_copy(tmp_path, "star-v1", "star-dev-v1", FIRST)


def test_the_draws_are_a_stream_of_their_own_and_cover_every_setting_alike():
    from baselines.references.draws import ENERGY_SPAWN_KEY, SPAWN_KEY
    from baselines.references.fleet import FLEET_SPAWN_KEY
    from baselines.references.mobile import MOBILE_SPAWN_KEY
    from baselines.references.online import MULTI_MOBILE_SPAWN_KEY
    from baselines.references.star import STAR_SPAWN_KEY

    keys = [SPAWN_KEY, ENERGY_SPAWN_KEY, MOBILE_SPAWN_KEY, MULTI_MOBILE_SPAWN_KEY, FLEET_SPAWN_KEY]
    keys.append(STAR_SPAWN_KEY)
    assert len(set(keys)) == len(keys)
    tasks = star_tasks(STAR_SIZE, 7)
    seen = [(t["star"]["elements"][0] ** 2, t["star"]["bits"], t["star"]["access"], t["star"]["protocol"])
            for t in tasks]  # fmt: skip
    assert all(seen.count(s) == 2 for s in SETTINGS) and len(SETTINGS) == 27
    assert {s[2:] for s in seen} == {("tdma", "es"), ("noma", "es"), ("noma", "ms")}
    assert all(t["star"]["group"] == 1 and not t["star"]["direct_link"] for t in tasks)
    assert len({t["seed"] for t in tasks}) == len(tasks)
    assert star_tasks(3, 7) == tasks[:3]  # a prefix: the draws are in turn
    with pytest.raises(ValueError, match="n must be an integer >= 1"):
        star_tasks(0, 7)


def test_the_shipped_suite_is_registered_and_holds_every_setting(shipped):
    assert len(shipped) == STAR_SIZE >= 40 and shipped.sha256 == SUITES["star-v1"].sha256
    assert shipped.kind == "star-control" and shipped.star_control and shipped.scores == ("optimum", "bound")
    assert dict(shipped.env_kwargs) == {"channel_phases": True}
    settings = [(s.star["elements"][0] ** 2, s.star["bits"], s.star["access"], s.star["protocol"])
                for s in shipped]  # fmt: skip
    assert sorted(settings, key=str) == sorted(2 * list(SETTINGS), key=str)


def test_every_stored_row_is_ordered_as_the_optimum_and_its_bound_require(shipped):
    """optimum <= bound (= under TDMA: closed form), the optimum's actions replay it, and no row
    (a setting the env scores) is above it; the continuous optimum's actions on a continuous grid
    are the optimum."""
    for s in shipped:
        opt, ub = s.value("optimum"), s.value("bound")
        assert 0 < opt <= ub * (1 + PLANNER_REL), s.index
        if s.star["access"] == "tdma":
            assert opt == pytest.approx(ub, rel=PLANNER_REL), s.index
        assert s.reference["optimum"]["replayed"] == pytest.approx(opt, rel=PLANNER_REL), s.index
        for r in ("quantised", "aligned", "phases", "random"):
            assert s.value(r) <= opt * (1 + PLANNER_REL), (s.index, r)
        if s.star["bits"] is None:
            assert s.value("quantised") == pytest.approx(opt, rel=PLANNER_REL), s.index
        assert s.value("random") < 0.2 * opt
    assert any(s.value("optimum") < 0.9 * s.value("bound") for s in shipped)  # b-bit NOMA: a real gap


def test_the_score_is_the_envs_reward_sum_and_the_heuristic_reproduces_its_stored_row(shipped):
    results = evaluate(ChannelPhases(), shipped, n=FIRST)
    for s, row in zip(shipped.subset(FIRST), results, strict=True):
        assert row.rate == pytest.approx(s.value("phases"), rel=RATE_REL)
        if s.star["protocol"] == "es" and s.star["access"] == "noma":
            continue  # its branch and bound costs seconds: the TDMA and MS episodes are rerun by hand
        env = gym.make("ios_uav_env/STARControl-v0", **star_kwargs(s.star), **shipped.env_kwargs)
        policy = ChannelPhases().bind(StarTask.of(s.star, env))
        obs, _ = env.reset(seed=s.seed)
        rewards = []
        for _ in range(16):
            obs, reward, terminated, _, info = env.step(policy(obs))
            rewards.append(reward)
        assert terminated and row.rate == sum(rewards) / 16 == info["return"] / 16
        assert row.pct["optimum"] == 100 * row.rate / s.value("optimum") and row.feasible


def test_a_wrong_seed_line_pair_is_refused_by_name_at_load_and_at_the_rollout(copy, tmp_path):
    def other_seed(data):
        data["scenarios"][1]["seed"] += 1  # the config (the line) stays: the pair no longer matches

    with pytest.raises(ValueError, match=r"scenario 1: seed \d+ draws the line x = .* not the config's"):
        load_suite(tampered(copy, tmp_path, other_seed))
    s = load_suite(copy)[1]  # a rollout whose env builds another episode than the scenario's
    env = gym.make("ios_uav_env/STARControl-v0", **star_kwargs(s.star))
    with pytest.raises(RuntimeError, match=r"scenario 1: the env reset with seed \d+ drew the line x = "):
        star_episode(env, ChannelPhases().bind(StarTask.of(s.star, env)), s.seed + 1, s.config, "scenario 1")


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d["scenarios"][0]["star"].pop("bits"), "star must have exactly the fields"),
        (lambda d: d["scenarios"][0]["star"].update(bits=9), r"star: bits must be"),
        (lambda d: d["scenarios"][0]["star"].update(protocol="ms"), "protocol must be 'es' with access"),
        (lambda d: d["scenarios"][0]["star"].update(elements=[2, 2]), "elements must be a surface shape"),
        (lambda d: d["scenarios"][0]["star"].update(elements=[8, 8]), "config must be STARControl-v0's"),
        (lambda d: d["scenarios"][0].update(seed=-1), "seed must be an integer >= 0"),
        (lambda d: d["scenarios"][0].pop("star"), "star must be an object"),
        (lambda d: d["scenarios"][0]["config"].update(q0=[-300.0, -150.0], qF=[-300.0, 150.0]), r"line x in"),
        (lambda d: d["scenarios"][1]["aligned"].update(rate=99.0), "no plan's rate may exceed it"),
        (lambda d: d["scenarios"][1]["optimum"].update(rate=0.0), r"optimum.rate \(bps/Hz\) must be"),
        (lambda d: d.update(env_id="ios_uav_env/STARUAV-v0"), "env_id of a star-control suite"),
        (lambda d: d.update(references=["optimum", "aligned"]), "references of a star-control suite"),
        (lambda d: d["scenarios"][0].update(fleet={"uavs": 2}), "only a several-UAV suite's scenarios"),
    ],
)
def test_a_tampered_suite_is_refused_naming_the_field(copy, tmp_path, change, message):
    with pytest.raises(ValueError, match=message) as err:
        load_suite(tampered(copy, tmp_path, change))
    assert "tampered.json" in str(err.value)


def test_a_star_in_another_kind_of_suite_is_refused(tmp_path):
    data = json.loads(suite_path("multi-node-v1").read_text())
    data["name"] = "multi-node-star-v1"
    data["scenarios"][0]["star"] = {"bits": 1}
    path = tmp_path / "x.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="only a STAR-control suite's scenarios have a star"):
        load_suite(path)


def test_the_registered_file_refuses_a_changed_value(tmp_path):
    data = json.loads(suite_path("star-v1").read_text())
    data["scenarios"][5]["random"]["rate"] *= 1.5
    path = tmp_path / "star-v1.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="the file was modified"):
        load_suite(path)


class _Model:
    """An SB3-like model of one scenario's widths: ``predict`` and an ``observation_space``."""

    def __init__(self, task: StarTask) -> None:
        self.observation_space = gym.spaces.Box(-1, 1, (len(task.observation_names),))
        self.width = task.action_dim

    def predict(self, obs, deterministic=True):
        assert deterministic and obs.shape == self.observation_space.shape
        return np.zeros(self.width), None


class _PerScenario:
    """A per-scenario factory: ``bind`` returns a model of the scenario's widths."""

    name = "zeros, one model per scenario"

    def bind(self, task: StarTask) -> _Model:
        return _Model(task)


def test_a_policy_is_bound_per_scenario_and_one_of_another_width_fails_naming_the_scenario(copy):
    suite = load_suite(copy)
    results = evaluate(_PerScenario(), suite)
    assert [r.feasible for r in results] == [True] * FIRST
    # zero actions: TDMA and ES serve both users; under MS every element reflects (a = 0 is not > 0),
    # so user t hears nothing (its links are blocked) and the max-min is 0
    assert results.scenarios[0].rate > 0 and results.scenarios[1].rate > 0 and results.scenarios[2].rate == 0
    task = StarTask(  # a model of another surface (8 x 8): the first scenario has 16 elements
        (8, 8), None, 1, "es", "tdma", False, tuple(f"f{i}" for i in range(8 + 128)), 129
    )
    with pytest.raises(ValueError, match=r"star-dev-v1 scenario 0: the policy takes observations of shape"):
        evaluate(_Model(task), suite)
    with pytest.raises(ValueError, match=r"scenario 0: action must be a finite array of shape \(33,\)"):
        evaluate(lambda obs: np.zeros(3), suite)
    with pytest.raises(PolicyError, match="ChannelPhases is unbound"):
        evaluate(ChannelPhases().__call__, suite)


def test_sb3_models_bound_per_scenario_are_scored(copy):
    """Real SB3 models (untrained PPO, one made on each scenario's env by ``bind``), through the
    same scorer: each row is the env's reward sum of the model's deterministic actions."""
    sb3 = pytest.importorskip("stable_baselines3")

    class PPOPerScenario:
        name = "PPO per scenario"

        def bind(self, task):
            env = gym.make("ios_uav_env/STARControl-v0", elements=task.elements, bits=task.bits,
                           access=task.access, protocol=task.protocol)  # fmt: skip
            return sb3.PPO("MlpPolicy", env, seed=0, device="cpu", n_steps=16, batch_size=16)

    suite = load_suite(copy)
    results = evaluate(PPOPerScenario(), suite)
    assert len(results) == FIRST and all(0 <= r.pct["optimum"] <= 100 + 1e-9 for r in results)
    # scenario 1 (ES-NOMA) has scenario 0's observation (M = 16) but another action width
    with pytest.raises(ValueError, match=r"scenario 1: the policy gives actions of shape \(33,\)"):
        evaluate(PPOPerScenario().bind(StarTask.of(suite[0].star, gym.make("ios_uav_env/STARControl-v0",
                 elements=(4, 4)))), suite, n=2)  # fmt: skip


def test_the_keywords_are_pinned_and_hiding_the_channel_phases_is_another_task(copy):
    suite = load_suite(copy)
    with pytest.raises(ValueError, match=r"\['bits'\] would be ignored .* the STAR keywords"):
        evaluate(ChannelPhases(), suite, env_kwargs={"bits": 1})
    with pytest.raises(ValueError, match="channel_phases=False .* change the task"):
        evaluate(_PerScenario(), suite, env_kwargs={"channel_phases": False})
    hide = {"channel_phases": False}
    hidden = evaluate(_PerScenario(), suite, env_kwargs=hide, n=1, allow_task_change=True)
    assert "[not star-dev-v1's task]" in hidden.summary()
    with pytest.raises(ValueError, match="ChannelPhases reads the channel phases"):
        evaluate(ChannelPhases(), suite, env_kwargs={"channel_phases": False}, n=1, allow_task_change=True)
    with pytest.raises(ValueError, match="batched and at_once are for UAV-flight suites"):
        evaluate(ChannelPhases(), suite, batched=True)
    with pytest.raises(ValueError, match="scores the surface's settings, not flights"):
        score_trajectories({0: np.zeros((16, 2))}, suite)


def test_the_pipeline_freezes_a_suite_the_loader_takes_and_the_command_line_shows_and_scores(frozen, capsys):
    suite = load_suite(frozen)
    assert len(suite) == 1 and suite[0].star["access"] == "tdma"
    assert suite[0].value("optimum") == suite[0].value("bound")
    record = solve_star(star_tasks(3, 20261130)[2], 20261130, random_episodes=1)  # MS-NOMA: cheap
    assert check_star_record(record) == [] and record["bound"]["upper_bound"] > record["optimum"]["rate"]
    assert benchmark_main(["show", "--suite", str(frozen)]) == 0
    shown = capsys.readouterr().out
    for r in ("optimum", "bound", "quantised", "aligned", "phases", "random"):
        assert f"{r} on star-quick-v1 (1 scenarios): % of optimum mean" in shown
    policy = "ios_uav_env.benchmark.star_policies:ChannelPhases"
    assert benchmark_main(["evaluate", "--suite", str(frozen), "--policy", policy]) == 0
    line = capsys.readouterr().out
    assert "on star-quick-v1 (1 scenarios): % of optimum mean 100.00" in line and "feasible 1/1" in line


def test_the_pipeline_never_overwrites_the_shipped_suite(tmp_path):
    before = suite_path("star-v1").read_bytes()
    with pytest.raises(SystemExit, match="'star-v1' is a registered suite"):  # 1 scenario: other content
        references_main(["star", "--n", "1", "--cache", str(tmp_path / "cache")])
    assert suite_path("star-v1").read_bytes() == before


def test_the_heuristics_docstring_example_holds():
    import doctest

    from ios_uav_env.benchmark import star_policies

    assert doctest.testmod(star_policies).failed == 0
