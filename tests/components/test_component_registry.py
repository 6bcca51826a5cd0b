"""The component registries: names, dicts and objects in; clear errors naming the family and the
allowed names out; every component's ``to_dict`` read back to the same component."""

from __future__ import annotations

import dataclasses

import pytest

from ios_uav_env.components import FAMILIES, Component, Registry, World
from ios_uav_env.model.mobility import GaussMarkov


@pytest.mark.parametrize("family", list(FAMILIES))
def test_every_kind_round_trips_through_to_dict(family):
    registry = FAMILIES[family]
    assert registry.names(), family
    for kind in registry.names():
        component = registry.make(kind)
        assert component.kind == kind and component.family == family
        assert registry.make(component.to_dict()) == component
        assert registry.make(component) is component


@pytest.mark.parametrize("family", list(FAMILIES))
def test_unknown_kind_names_the_family_and_the_kinds(family):
    registry = FAMILIES[family]
    with pytest.raises(ValueError, match=rf"{family} must be one of .*{registry.names()[0]}.*'nope'"):
        registry.make("nope")
    with pytest.raises(ValueError, match=f"{family} given as a dict needs a 'kind'"):
        registry.make({})
    with pytest.raises(ValueError, match=rf"{family} must be a name in"):
        registry.make(3)


def test_unknown_parameter_is_named():
    with pytest.raises(ValueError, match=r"motion 'gauss_markov' has no parameters \['sped'\]"):
        World(motion={"kind": "gauss_markov", "sped": 2.0})


@pytest.mark.parametrize(
    ("world", "message"),
    [
        (
            {"objective": {"kind": "rate", "budget_j": -1.0}},
            r"objective.budget_j must be a finite number > 0 \(J; or None\)",
        ),
        (
            {"objective": {"kind": "rate", "budget_j": True}},
            r"objective.budget_j must be a finite number > 0 \(J; or None\)",
        ),
        ({"knowledge": {"kind": "reports", "sigma": float("nan")}}, r"knowledge.sigma must be a finite"),
        ({"link": {"kind": "single_antenna", "fading": "rayleigh"}}, r"link.fading must be one of"),
        (
            {"motion": {"kind": "gauss_markov", "memory": 1.0}},
            r"GaussMarkov.memory must be a number in \[0, 1\)",
        ),
        ({"nodes": 0}, r"nodes must be an integer >= 1"),
        ({"nodes": 2.0}, r"nodes must be an integer >= 1"),
    ],
)
def test_bad_parameters_name_the_field(world, message):
    with pytest.raises(ValueError, match=message):
        World(**world)


def test_components_are_frozen_and_hashable():
    world = World(motion="gauss_markov", knowledge="filtered")
    assert hash(world) == hash(World(motion="gauss_markov", knowledge="filtered"))
    with pytest.raises(dataclasses.FrozenInstanceError):
        world.nodes = 2  # type: ignore[misc]


def test_a_kind_cannot_be_registered_twice():
    registry: Registry[Component] = Registry("thing")

    @registry.register("a")
    @dataclasses.dataclass(frozen=True)
    class A(Component):
        kind = "a"

    with pytest.raises(ValueError, match="thing 'a' is registered already"):
        registry.register("a")(A)


def test_the_gauss_markov_component_sets_the_models_own_class():
    """The config's motion must stay a ``GaussMarkov`` (dataclass equality compares classes: a
    subclass would change every moving scenario's equality and hash)."""
    motion = World(motion={"kind": "gauss_markov", "speed": 3.0}).config_fields()["motion"]
    assert type(motion) is GaussMarkov and motion == GaussMarkov(speed=3.0)
