"""``World``: reading an env's scenario and options back, the combination rules and their
messages, and the matrix of combinations."""

from __future__ import annotations

import pytest

from ios_uav_env.components import FAMILIES, UnsupportedWorld, World, combinations
from ios_uav_env.components import world as world_module
from ios_uav_env.model.config import ScenarioConfig


def test_the_default_world_is_the_papers_and_sets_every_field_at_its_default():
    """A component at its default leaves the scenario's dict (suite hashes, cache keys) unchanged."""
    world = World()
    assert ScenarioConfig().replace(**world.config_fields()).to_dict() == ScenarioConfig().to_dict()
    assert world.option_fields() == {"channel": "expected", "knowledge": "exact"}
    assert World.of(ScenarioConfig()) == world


@pytest.mark.parametrize("world", list(combinations(nodes=(1, 3), budgets=(None, 4e4))), ids=str)
def test_every_world_reads_back_from_its_scenario_and_options(world):
    nodes = ((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0))[: world.nodes]
    config = ScenarioConfig(ground_nodes=nodes).replace(**world.config_fields())
    options = world.option_fields()
    back = World.of(
        config,
        channel=options["channel"],
        knowledge=options["knowledge"],
        report_sigma=options.get("report_sigma"),
        filter_estimate=options.get("filter_estimate", False),
    )
    assert back == world


def test_the_matrix_holds_every_kind_of_every_family():
    worlds = list(combinations(nodes=(1,)))
    for family, registry in FAMILIES.items():
        assert {getattr(w, family).kind for w in worlds} == set(registry.names())
    assert (
        len(worlds) == len(set(worlds)) == 6 * (2 * 2) * 2 * 2 * 4
    )  # surfaces (STAR: TDMA, NOMA, 2-bit TDMA), links (one antenna or four) x fadings, objectives, motions,
    # knowledge


@pytest.mark.parametrize("rule", range(len(world_module.RULES)))
def test_each_rule_refuses_some_world_and_names_its_components(rule):
    """Every rule applies to some world of the matrix (no dead rule), and the refusal names every
    component of that world and the rule's reason."""
    applies, why = world_module.RULES[rule]
    hits = [w for w in combinations(nodes=(1, 3), budgets=(None, 4e4)) if applies(w)]
    assert hits, f"rule {rule} applies to no world: {why}"
    with pytest.raises(UnsupportedWorld) as err:
        hits[0].check()
    message = str(err.value)
    assert why in message
    for family, kind in hits[0].names().items():
        assert f"{family} {kind}" in message


def test_supported_worlds_pass_the_check():
    supported = [w for w in combinations(nodes=(1, 3)) if not w.problems()]
    assert World() in supported and World(nodes=3, motion="gauss_markov", knowledge="filtered") in supported
    for world in supported:
        assert world.check() is world


def test_the_single_antenna_fading_is_named_in_messages():
    assert (
        World(link={"kind": "single_antenna", "fading": "rician"}).names()["link"]
        == "single_antenna (rician)"
    )
    link = {"kind": "multi_antenna", "antennas": 8}
    assert World(link=link).names()["link"] == "multi_antenna (antennas=8)"
    assert World(objective={"kind": "rate", "budget_j": 1e4}).names()["objective"] == "rate within a budget"
