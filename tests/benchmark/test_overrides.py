"""Env arguments on a suite (ios_uav_env.benchmark.overrides): every argument of every suite's env
is classified; an argument the suite pins is refused as ignored, one that changes the task is
refused unless asked for, and then the results name the changed task wherever they are printed
or saved; a policy's own arguments cannot be silently contradicted."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from ios_uav_env.benchmark import SUITES, evaluate, load_suite, scoring
from ios_uav_env.benchmark import figures as figures_module
from ios_uav_env.benchmark.cli import main
from ios_uav_env.benchmark.overrides import (
    DRAW,
    FLEET,
    MISO,
    PINNED,
    PRESENTATION,
    REWARD,
    STAR,
    TASK,
    check_overrides,
    classify,
    env_arguments,
    env_defaults,
)
from ios_uav_env.envs.policies import HoverAt
from ios_uav_env.model.config import SCENARIO_FIELDS

SUITE_NAMES = sorted(SUITES)


@pytest.fixture(scope="module")
def suites():
    return {name: load_suite(name) for name in SUITE_NAMES}


@pytest.fixture
def no_scenario_runs(monkeypatch):
    def run(*args, **kwargs):
        raise AssertionError("a scenario ran before the env arguments were checked")

    monkeypatch.setattr(scoring, "play", run)


def _other(name: str, default):
    """A value of the task argument ``name`` other than ``default``."""
    return {"knowledge": "exact" if default != "exact" else "reports", "report_sigma": 3.0,
            "channel": "rician", "arrival_guard": not default, "share_sharpness": 9.0,
            "surface_sharpness": 9.0, "channel_phases": not default,
            "view": "v0" if default == "node_blocks" else "node_blocks",
            "action": "move" if default == "move_scores" else "move_scores",
            "draws": not default,
            "control": "residual" if default != "residual" else "direct"}[name]  # fmt: skip


def test_the_classes_are_disjoint_and_cover_every_argument_of_every_suite_env(suites):
    classes = [PRESENTATION, REWARD, frozenset(TASK), PINNED]
    assert sum(len(c) for c in classes) == len(frozenset().union(*classes))
    assert SCENARIO_FIELDS <= PINNED and DRAW <= PINNED
    for name, suite in suites.items():
        arguments = env_arguments(suite.env_id)
        assert {"arrival_guard", "knowledge", "T"} <= arguments, name
        # a UAV-flight env's own arguments, or the STAR- or MISO-control env's keywords
        surface = MISO if suite.miso_control else STAR | {"channel_phases"}
        own = surface if suite.star_control else {"peak_hint", "config"}
        assert own <= arguments, name
        unclassified = sorted(k for k in arguments if classify(k) == "unclassified")
        assert not unclassified, f"{name}: classify {unclassified} in ios_uav_env.benchmark.overrides"


@pytest.mark.parametrize("name", SUITE_NAMES)
def test_every_task_argument_is_refused_on_every_suite_naming_it(name, suites, no_scenario_runs):
    suite = suites[name]
    defaults = env_defaults(suite)
    taken = [k for k in TASK if k in env_arguments(suite.env_id)]
    assert "arrival_guard" in taken and "knowledge" in taken
    for k in taken:
        value = _other(k, defaults.get(k))
        with pytest.raises(ValueError) as err:
            evaluate(lambda obs: np.zeros(2), suite, env_kwargs={k: value}, n=1)
        message = str(err.value)
        assert f"{k}={value!r}" in message and f"suite {name}" in message, message
        assert "allow_task_change=True" in message and "--allow-task-change" in message, message
        if k in defaults:  # the suite's own value is no change
            assert check_overrides(suite, {k: defaults[k]}) == {}


@pytest.mark.parametrize("name", SUITE_NAMES)
def test_every_pinned_argument_is_refused_as_ignored_even_with_the_opt_in(name, suites, no_scenario_runs):
    suite = suites[name]
    config = suite[0].config
    taken = sorted(k for k in env_arguments(suite.env_id) if k in PINNED)
    assert "motion" in taken and ("focus" in taken or suite.schedules or suite.fleets or suite.star_control)
    # a fleet suite pins its fleet, a STAR- or MISO-control suite its keywords (access is both)
    assert FLEET <= set(taken) if suite.fleets else not (FLEET - STAR) & set(taken)
    if suite.miso_control:
        assert MISO <= set(taken) and not (STAR - MISO) & set(taken)
    else:
        assert STAR <= set(taken) if suite.star_control else not (STAR - FLEET) & set(taken)
    for k in taken:
        value = getattr(config, k) if k in SCENARIO_FIELDS else 0.5
        for allow in (False, True):
            with pytest.raises(ValueError, match="would be ignored") as err:
                evaluate(lambda obs: np.zeros(2), suite, env_kwargs={k: value}, n=1, allow_task_change=allow)
            assert repr(k) in str(err.value) and f"suite {name}" in str(err.value)


@pytest.mark.parametrize("name", SUITE_NAMES)
def test_presentation_and_reward_arguments_are_no_task_change(name, suites):
    suite = suites[name]
    for k in sorted((PRESENTATION | REWARD) & env_arguments(suite.env_id)):
        assert check_overrides(suite, {k: object()}) == {}, k


def test_knowledge_exact_on_mobile_v1_is_labelled_everywhere_with_the_opt_in(suites, tmp_path, monkeypatch):
    suite = suites["mobile-v1"]
    with pytest.raises(ValueError, match=r"knowledge='exact' \(the suite's: 'reports'"):
        evaluate(HoverAt("ground"), suite, env_kwargs={"knowledge": "exact"}, n=1)
    exact = {"knowledge": "exact"}
    results = evaluate(HoverAt("ground"), suite, env_kwargs=exact, n=1, allow_task_change=True)
    label = "mobile-v1 with knowledge='exact' [not mobile-v1's task]"
    assert results.task == label and results.task_changes == {"knowledge": "exact"}
    assert f"on {label} (1 scenarios)" in results.summary()
    titles = []
    real = figures_module.save_figure

    def capture(fig, path, **kw):
        titles.append(" ".join([fig._suptitle.get_text() if fig._suptitle else ""]
                               + [ax.get_title() for ax in fig.axes]))  # fmt: skip
        return real(fig, path, **kw)

    monkeypatch.setattr(figures_module, "save_figure", capture)
    paths = results.save(tmp_path)
    assert json.loads(paths["json"].read_text())["task"] == label
    assert json.loads(paths["json"].read_text())["task_changes"] == {"knowledge": "exact"}
    assert paths["markdown"].read_text().startswith(f"# fly to G and hover (heuristic) on {label}\n")
    assert {row["task"] for row in csv.DictReader(paths["csv"].open())} == {label}
    assert titles and all(label in t for t in titles), titles
    # the same policy on the suite's own task: no label anywhere
    plain = evaluate(HoverAt("ground"), suite, n=1)
    assert plain.task == "mobile-v1" and "[not" not in plain.summary()
    assert "task" not in plain.to_dict()["scenarios"][0] and plain.to_dict()["task_changes"] == {}


def test_a_scenario_field_such_as_motion_none_is_refused_not_ignored(suites, no_scenario_runs):
    with pytest.raises(ValueError, match=r"\['motion'\] would be ignored on suite mobile-v1"):
        evaluate(HoverAt("ground"), suites["mobile-v1"], env_kwargs={"motion": None}, n=1)


class Trained:
    """A policy that declares the env arguments it was trained with (as agents.loading's do)."""

    def __init__(self, env_kwargs):
        self.env_kwargs = env_kwargs

    def __call__(self, obs):
        return HoverAt("peak")(obs)


def test_env_kwargs_that_contradict_the_policy_s_own_observations_are_refused(suites, no_scenario_runs):
    energy = suites["energy-v1"]
    policy = Trained({"energy_reference": "loiter", "peak_hint": True})
    with pytest.raises(ValueError, match=r"with energy_reference='loiter', env_kwargs give 17155\.06"):
        evaluate(policy, energy, env_kwargs={"energy_reference": 17155.06, "peak_hint": True}, n=1)
    with pytest.raises(ValueError, match=r"energy_reference='loiter', env_kwargs leave it at None"):
        evaluate(policy, energy, env_kwargs={"peak_hint": True}, n=1)


def test_a_policy_s_training_draw_is_not_passed_to_a_suite(suites):
    policy = Trained({"peak_hint": True, "focus": {"ground_x": [-150, 150]}, "focus_prob": 0.5})
    results = evaluate(policy, suites["single-node-v1"], n=1)
    assert results.env_kwargs == {"peak_hint": True} and results.task == "single-node-v1"


def test_the_cli_refuses_a_task_change_and_labels_it_with_the_opt_in(tmp_path, capsys):
    spec = "ios_uav_env.envs.policies:HoverAt('ground')"
    argv = ["evaluate", "--suite", "mobile-v1", "--policy", spec, "--n", "1"]
    argv += ["--env-kwargs", "knowledge:exact"]
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert "argument --env-kwargs: " in line and "knowledge='exact'" in line and "--allow-task-change" in line
    assert main([*argv, "--allow-task-change", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert "on mobile-v1 with knowledge='exact' [not mobile-v1's task] (1 scenarios)" in printed
    assert "[not mobile-v1's task]" in (tmp_path / "results.md").read_text()
