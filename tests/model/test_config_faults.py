"""Fault injection on ScenarioConfig: a ground node on the IOS plane is refused where the
scenario is made, so that every planner, env and tool gets the same clear error."""

from __future__ import annotations

import pytest

from ios_uav_env import ScenarioConfig
from ios_uav_env.benchmark import SUITES, load_suite

SMALL = ScenarioConfig(T=40.0, ios_shape=(10, 6))


@pytest.mark.parametrize(
    ("changes", "field", "node"),
    [
        ({"ground_node": (0.0, 50.0)}, "ground_node", r"\(0\.0, 50\.0\)"),
        ({"ground_node": (0.0, 50.0), "surface": "ris"}, "ground_node", r"\(0\.0, 50\.0\)"),
        ({"ground_nodes": ((0.0, 0.0), (-100.0, -20.0))}, r"ground_nodes\[0\]", r"\(0\.0, 0\.0\)"),
        ({"ground_nodes": ((-100.0, -20.0), (-0.0, 30.0))}, r"ground_nodes\[1\]", r"\(-0\.0, 30\.0\)"),
        ({"ground_node": (5.0, 50.0), "ios_center": (5.0, 0.0, 40.0)}, "ground_node", r"\(5\.0, 50\.0\)"),
    ],
)
def test_a_ground_node_on_the_ios_plane_is_refused_naming_the_field_the_node_and_the_plane(
    changes, field, node
):
    plane = changes.get("ios_center", (0.0,))[0]
    with pytest.raises(
        ValueError, match=rf"^{field}={node} lies on the IOS plane x = ios_center\[0\] = {plane:g} m"
    ):
        SMALL.replace(**changes)


def test_a_replace_that_moves_a_node_onto_the_plane_or_the_plane_onto_a_node_is_refused():
    with pytest.raises(ValueError, match="on the IOS plane"):
        SMALL.replace(ground_node=(0.0, -20.0))
    with pytest.raises(
        ValueError, match=r"ground_node=\(-100\.0, -20\.0\) lies on the IOS plane x = .* = -100 m"
    ):
        SMALL.replace(ios_center=(-100.0, 0.0, 40.0))
    with pytest.raises(ValueError, match="on the IOS plane"):
        SMALL.replace(surface="none", ground_node=(0.0, 50.0)).replace(surface="ios")


def test_without_a_surface_and_off_the_plane_a_node_is_accepted():
    # no surface: no plane, no side to choose (the direct link only)
    assert SMALL.replace(surface="none", ground_node=(0.0, 50.0)).ground_node == (0.0, 50.0)
    assert SMALL.replace(ground_node=(1e-9, 50.0)).ground_node == (1e-9, 50.0)


def test_the_shipped_suites_still_load_with_their_registered_hashes_and_no_node_on_the_plane():
    for name, registered in SUITES.items():
        suite = load_suite(name)
        assert suite.sha256 == registered.sha256
        on_plane = [
            s.index
            for s in suite
            if s.config.surface != "none" and any(x == s.config.ios_center[0] for x, _ in s.config.nodes)
        ]
        assert on_plane == []
