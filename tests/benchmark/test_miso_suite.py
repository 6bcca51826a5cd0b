"""miso-v1: the frozen MISO-control suite (the agent sets the UAV's beams and the surface's phases),
its draws, its references' order (bound >= AO >= every row, the AO within its stated gap of the
bound), its scoring by the env's reward sum and its pipeline."""

from __future__ import annotations

import json
import re

import gymnasium as gym
import numpy as np
import pytest

from baselines.references.__main__ import main as references_main
from baselines.references.miso import (
    AO_GAP,
    MISO_SIZE,
    SETTINGS,
    ao_gaps,
    check_miso_record,
    miso_tasks,
    solve_miso,
)
from ios_uav_env.benchmark import SUITES, evaluate, load_suite
from ios_uav_env.benchmark.cli import main as benchmark_main
from ios_uav_env.benchmark.miso_policies import DirectMRT
from ios_uav_env.benchmark.miso_suite import MisoTask, miso_kwargs
from ios_uav_env.benchmark.suite_registry import MISO_REFERENCES, suite_path
from tests.benchmark.quick_suites import shipped_copy
from tests.tolerances import PLANNER_REL, RATE_REL

#: The shipped suite's first scenarios: N_t = 2, K = 2, M = 16, the sum rate and the max-min rate.
FIRST = 2


@pytest.fixture(scope="module")
def shipped():
    return load_suite("miso-v1")


@pytest.fixture
def copy(tmp_path):
    """A copy of the shipped suite's first scenarios under a new name (it loads with its own hash)."""
    return shipped_copy(tmp_path, "miso-v1", "miso-dev-v1", FIRST)


def _record(s) -> dict:
    """A stored scenario as a record of ``solve_miso`` (what ``check_miso_record`` reads)."""
    return {"index": s.index, **{r: dict(s.reference[r]) for r in MISO_REFERENCES}}


def test_the_draws_are_a_stream_of_their_own_and_cover_every_setting_alike():
    from baselines.references.draws import ENERGY_SPAWN_KEY, SPAWN_KEY
    from baselines.references.fleet import FLEET_SPAWN_KEY
    from baselines.references.miso import MISO_SPAWN_KEY
    from baselines.references.mobile import MOBILE_SPAWN_KEY
    from baselines.references.online import MULTI_MOBILE_SPAWN_KEY
    from baselines.references.star import STAR_SPAWN_KEY

    keys = [SPAWN_KEY, ENERGY_SPAWN_KEY, MOBILE_SPAWN_KEY, MULTI_MOBILE_SPAWN_KEY, FLEET_SPAWN_KEY]
    keys += [STAR_SPAWN_KEY, MISO_SPAWN_KEY]
    assert len(set(keys)) == len(keys)
    tasks = miso_tasks(MISO_SIZE, 7)
    seen = [(t["miso"]["antennas"], t["miso"]["users"], t["miso"]["elements"][0] ** 2, t["miso"]["objective"])
            for t in tasks]  # fmt: skip
    assert len(SETTINGS) == 24 and all(seen.count(s) == 2 for s in SETTINGS)
    assert {s[3] for s in seen} == {"sum", "maxmin"} and {s[0] for s in seen} == {2, 4, 8}
    assert len({t["seed"] for t in tasks}) == len(tasks)
    assert miso_tasks(3, 7) == tasks[:3]  # a prefix: the draws are in turn
    with pytest.raises(ValueError, match="n must be an integer >= 1"):
        miso_tasks(0, 7)


def test_the_shipped_suite_is_registered_and_holds_every_setting(shipped):
    assert len(shipped) == MISO_SIZE and shipped.sha256 == SUITES["miso-v1"].sha256
    assert shipped.kind == "miso-control" and shipped.miso_control and shipped.star_control
    assert shipped.scores == ("optimum", "bound") and dict(shipped.env_kwargs) == {}
    settings = [(s.miso["antennas"], s.miso["users"], s.miso["elements"][0] ** 2, s.miso["objective"])
                for s in shipped]  # fmt: skip
    assert sorted(settings, key=str) == sorted(2 * list(SETTINGS), key=str)
    # above every seed a MISOControl-v0 run trains or is scored on (examples/miso_control_ppo.py: 0, ...
    # and 1000, 1001, ...): no suite episode is a training episode
    assert min(s.seed for s in shipped) >= 10**7


def test_bound_ao_and_every_row_are_ordered_and_the_ao_is_within_its_stated_gap(shipped):
    """bound >= AO, the AO's actions replay it (>= it: the replay spends full power), no row above
    it (slack PLANNER_REL: float64 sums of the same slot values re-run), ZF only where N_t >= K,
    and optimum >= (1 - AO_GAP) bound everywhere, the gap the description states."""
    for s in shipped:
        opt, ub = s.value("optimum"), s.value("bound")
        assert 0 < opt <= ub * (1 + PLANNER_REL), s.index
        assert opt >= (1 - AO_GAP) * ub, s.index
        assert s.reference["optimum"]["replayed"] >= opt * (1 - PLANNER_REL), s.index
        for r in MISO_REFERENCES[2:]:
            assert s.value(r) <= opt * (1 + PLANNER_REL), (s.index, r)
        assert s.reference["zf_aligned"]["feasible"] == (s.miso["antennas"] >= s.miso["users"]), s.index
        assert check_miso_record(_record(s)) == [], s.index
    gaps = ao_gaps([_record(s) for s in shipped])
    assert gaps.max() <= AO_GAP and f"stated gap of {100 * AO_GAP:g}%" in shipped.description
    assert f"largest gap is {100 * gaps.max():.2f}%" in shipped.description
    assert f"mean {100 * gaps.mean():.2f}%" in shipped.description


@pytest.mark.parametrize(
    "change, note",
    [
        ({"mrt_aligned": 2.0}, "mrt_aligned .* > optimum"),
        ({"bound": 0.5}, "optimum .* > bound"),
        ({"bound": 100.0}, "more than the stated gap"),
        ({"replayed": 0.5}, "the AO's actions score"),
    ],
)
def test_the_checks_fail_on_a_record_out_of_order(shipped, change, note):
    rec = _record(shipped[0])
    opt = rec["optimum"]["rate"]
    for name, factor in change.items():
        if name == "bound":
            rec["bound"]["upper_bound"] = factor * opt
        elif name == "replayed":
            rec["optimum"]["replayed"] = factor * opt
        else:
            rec[name]["rate"] = factor * opt
    notes = check_miso_record(rec)
    assert notes and any(re.search(note, n) for n in notes), notes


def test_a_policy_is_scored_by_the_envs_reward_sum_and_reproduces_its_stored_row(shipped):
    """DirectMRT on the first scenarios: its stored ``direct`` row within RATE_REL (a float32
    observation read by the policy, re-run on another CPU), and the env's reward sum by hand."""
    results = evaluate(DirectMRT(), shipped, n=FIRST)
    for s, row in zip(shipped.subset(FIRST), results, strict=True):
        assert row.rate == pytest.approx(s.value("direct"), rel=RATE_REL)
        env = gym.make("ios_uav_env/MISOControl-v0", **miso_kwargs(s.miso), optimum=False)
        policy = DirectMRT().bind(MisoTask.of(s.miso, env))
        obs, _ = env.reset(seed=s.seed)
        rewards = []
        for _ in range(16):
            obs, reward, terminated, _, info = env.step(policy(obs))
            rewards.append(reward)
        assert terminated and row.rate == pytest.approx(sum(rewards) / 16, rel=PLANNER_REL)
        assert row.pct["optimum"] == 100 * row.rate / s.value("optimum") and row.feasible


def test_a_wrong_seed_and_a_miso_elsewhere_are_refused_by_name(copy, tmp_path):
    data = json.loads(copy.read_text())
    data["scenarios"][1]["seed"] += 1  # the config (the line) stays: the pair no longer matches
    path = tmp_path / "miso-bad-v1.json"
    path.write_text(json.dumps({**data, "name": "miso-bad-v1"}))
    with pytest.raises(ValueError, match=r"scenario 1: seed \d+ draws the line .* MISOControl-v0"):
        load_suite(path)
    data = json.loads(copy.read_text())
    data["scenarios"][0]["miso"]["users"] = 3  # another users' count: another config
    path.write_text(json.dumps({**data, "name": "miso-bad-v1"}))
    with pytest.raises(ValueError, match="scenario 0: config must be MISOControl-v0's episode scenario"):
        load_suite(path)
    star = json.loads(suite_path("star-v1").read_text())
    star = {**star, "name": "star-bad-v1", "scenarios": star["scenarios"][:1]}
    star["scenarios"][0]["miso"] = data["scenarios"][0]["miso"]
    path.write_text(json.dumps(star))
    with pytest.raises(ValueError, match="only a MISO-control suite's scenarios have a miso"):
        load_suite(path)


def test_the_keywords_are_pinned(copy):
    suite = load_suite(copy)
    with pytest.raises(
        ValueError, match=r"\['antennas'\] would be ignored on suite miso-dev-v1: every scenario's keywords"
    ):
        evaluate(DirectMRT(), suite, n=1, env_kwargs={"antennas": 8})
    with pytest.raises(ValueError, match="scenario 0: the policy gives actions of shape"):

        class Wide:
            action_space = gym.spaces.Box(-1, 1, (3,))

            def __call__(self, obs):
                return np.zeros(3)

        evaluate(Wide(), suite, n=1)


def test_the_pipeline_freezes_a_suite_the_loader_takes_and_the_command_line_shows_and_scores(
    tmp_path, capsys
):
    argv = ["miso", "--quick", "--n", "1", "--cache", str(tmp_path / "cache"), "--dir", str(tmp_path)]
    assert references_main(argv) == 0
    frozen = tmp_path / "miso-quick-v1.json"
    suite = load_suite(frozen)
    assert len(suite) == 1 and suite[0].miso["objective"] == "sum"
    assert suite[0].value("optimum") < suite[0].value("bound")
    record = solve_miso(miso_tasks(2, 20261130)[1], 20261130, random_episodes=1)  # max-min, N_t = K = 2
    assert check_miso_record(record) == [] and record["zf_aligned"]["feasible"]
    capsys.readouterr()
    assert benchmark_main(["show", "--suite", str(frozen)]) == 0
    shown = capsys.readouterr().out
    for r in MISO_REFERENCES:
        assert f"{r} on miso-quick-v1 (1 scenarios): % of optimum mean" in shown
    policy = "ios_uav_env.benchmark.miso_policies:DirectMRT"
    assert benchmark_main(["evaluate", "--suite", str(frozen), "--policy", policy]) == 0
    line = capsys.readouterr().out
    assert "on miso-quick-v1 (1 scenarios): % of optimum mean" in line and "feasible 1/1" in line


def test_the_pipeline_never_overwrites_the_shipped_suite(tmp_path):
    before = suite_path("miso-v1").read_bytes()
    with pytest.raises(SystemExit, match="'miso-v1' is a registered suite"):  # 1 scenario: other content
        references_main(["miso", "--n", "1", "--cache", str(tmp_path / "cache")])
    assert suite_path("miso-v1").read_bytes() == before


def test_an_unbound_heuristic_is_refused_naming_bind():
    """``DirectMRT`` reads the observation by the scenario's names: called before ``bind`` it has no
    names to read, and says so instead of acting on an unknown layout."""
    with pytest.raises(ValueError, match=r"DirectMRT is unbound: bind it to the scenario"):
        DirectMRT()(np.zeros(8, dtype=np.float32))
