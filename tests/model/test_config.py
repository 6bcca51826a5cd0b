"""ScenarioConfig: the paper's defaults, derived values and validation."""

import dataclasses
import math
import pickle

import numpy as np
import pytest

from ios_uav_env import ScenarioConfig


def test_defaults_are_the_papers():
    c = ScenarioConfig()
    assert (c.surface, c.T, c.dt, c.v_max) == ("ios", 150.0, 1.0, 25.0)
    assert c.q0 == (-400.0, 20.0) and c.qF == (400.0, 20.0)
    assert c.ground_node == (-100.0, -20.0) and c.ios_center == (0.0, 0.0, 40.0)
    assert c.ios_shape == (100, 60) and c.uav_altitude == 100.0
    assert (c.epsilon, c.kappa, c.alpha, c.power_w, c.noise_dbm, c.wavelength) == (
        3.55,
        3.0,
        5.0,
        0.1,
        -80.0,
        0.05,
    )


def test_derived_values():
    c = ScenarioConfig()
    assert c.N == 150 and c.D == 25.0 and c.M == 6000
    assert math.isclose(c.eta, 1e10, rel_tol=1e-12)
    assert math.isclose(c.noise_w, 1e-11, rel_tol=1e-12)
    assert math.isclose(c.J, 0.05 * 0.025 / (4 * math.pi) ** 1.5, rel_tol=1e-12)
    assert c.transmit_factor == 3.55
    assert c.replace(surface="ris").transmit_factor == 0.0
    derived = {"N", "D", "eta", "M"}
    assert not derived & {f.name for f in dataclasses.fields(c)}, "derived values must not be fields"


def test_frozen_hashable_picklable():
    c = ScenarioConfig()
    with pytest.raises(dataclasses.FrozenInstanceError):
        c.T = 10.0  # type: ignore[misc]
    assert hash(c) == hash(ScenarioConfig())
    assert pickle.loads(pickle.dumps(c)) == c
    assert ScenarioConfig(**c.to_dict()) == c


def test_node_configs_are_made_once_and_leave_the_config_as_it_was():
    """``node_config(k)`` is node k's single-node config (G = w_k, nothing else changed), made
    once per config; asking for it changes neither equality, hashing, ``to_dict`` nor a pickle."""
    nodes = ((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0))
    c, fresh = ScenarioConfig(ground_nodes=nodes), ScenarioConfig(ground_nodes=nodes)
    before = (hash(c), c.to_dict())
    for k, w in enumerate(nodes):
        single = c.node_config(k)
        assert single == dataclasses.replace(c, ground_nodes=None, ground_node=w)
        assert single.K == 1 and single.ground_node == w
        assert c.node_config(k) is single  # made once
    assert c == fresh and (hash(c), c.to_dict()) == before
    back = pickle.loads(pickle.dumps(c))
    assert back == c and back.node_config(2) == c.node_config(2)
    assert c.replace(ground_nodes=nodes[:2]).node_config(1).ground_node == nodes[1]  # not the old cache
    with pytest.raises(ValueError, match="node index k"):
        c.node_config(3)


def test_node_configs_are_the_validated_replacements_field_for_field():
    """The node configs are made without running the checks again: each must still be the config
    that ``dataclasses.replace`` makes and validates, every field equal and of the same type (drawn
    scenarios with moving nodes, the energy objective with a budget, a motion box, a dict given for
    the propulsion model, a RIS, STAR's defaults)."""
    from ios_uav_env.model.mobility import GaussMarkov
    from ios_uav_env.model.scenarios import MULTINODE_RANGES, ScenarioRanges, sample_multinode

    rng = np.random.default_rng(4)
    walk = GaussMarkov(box=((-400.0, 400.0), (-300.0, 300.0)))
    base = ScenarioConfig(motion={"kind": "gauss_markov"}, objective="energy_efficiency", energy_budget_j=4e5)
    ranges = ScenarioRanges(T=MULTINODE_RANGES.T, base=base)
    configs = [sample_multinode(rng, ranges, (2, 4)) for _ in range(4)]
    configs += [sample_multinode(rng, MULTINODE_RANGES, (2, 4)).replace(motion=walk, surface="ris",
                                                                        propulsion={"rho": 1.2})]  # fmt: skip
    for c in configs:
        for k, w in enumerate(c.nodes):
            single, made = c.node_config(k), dataclasses.replace(c, ground_nodes=None, ground_node=w)
            assert single == made and hash(single) == hash(made) and single.to_dict() == made.to_dict()
            for field in dataclasses.fields(made):
                mine, theirs = getattr(single, field.name), getattr(made, field.name)
                assert type(mine) is type(theirs) and mine == theirs, field.name
            assert single.node_config(0) is single and pickle.loads(pickle.dumps(single)) == made


def test_min_horizon_is_the_boundary():
    c = ScenarioConfig()
    assert c.min_horizon() == 33.0  # 800 m at 25 m per move: 32 moves, 33 slots
    ScenarioConfig(T=33.0)
    with pytest.raises(ValueError, match=r"T=32.0 s is too short.*T must be >= 33 s"):
        ScenarioConfig(T=32.0)


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"surface": "stars"}, "surface"),
        ({"T": -1.0}, "T"),
        ({"T": float("nan")}, "T"),
        ({"dt": 0.0}, "dt"),
        ({"v_max": 0.0}, "v_max"),
        ({"T": 150.5}, "T"),
        ({"ios_shape": (0, 60)}, "ios_shape"),
        ({"ios_shape": (100, -1)}, "ios_shape"),
        ({"ios_shape": (10.5, 6)}, "ios_shape"),
        ({"q0": (1.0, float("nan"))}, "q0"),
        ({"qF": (1.0, 2.0, 3.0)}, "qF"),
        ({"ground_node": "here"}, "ground_node"),
        ({"epsilon": -1.0}, "epsilon"),
        ({"kappa": float("inf")}, "kappa"),
        ({"wavelength": 0.0}, "wavelength"),
        ({"uav_altitude": 40.0}, "uav_altitude"),
        ({"ios_center": (0.0, 0.0, 0.5)}, "ios_center"),
        ({"quadrature_nodes": -1}, "quadrature_nodes"),
        ({"noise_dbm": float("nan")}, "noise_dbm"),
    ],
)
def test_bad_values_name_the_field(changes, field):
    with pytest.raises(ValueError, match=field):
        ScenarioConfig(**changes)


def test_unknown_field_fails_loudly():
    message = r"ScenarioConfig.replace\(\) got an unexpected keyword argument 'speed'"
    with pytest.raises(TypeError, match=message):
        ScenarioConfig().replace(speed=3)
    with pytest.raises(TypeError):
        ScenarioConfig(speed=3)  # type: ignore[call-arg]


def test_numpy_scalars_are_accepted_and_normalised():
    import numpy as np

    c = ScenarioConfig(T=np.int64(100), v_max=np.float32(25.0), quadrature_nodes=np.int64(4))
    assert c == ScenarioConfig(T=100.0, quadrature_nodes=4)
    assert type(c.T) is float and type(c.quadrature_nodes) is int
    with pytest.raises(ValueError, match="T"):
        ScenarioConfig(T=True)


def test_moves_needed_counts_whole_moves_for_numbers_and_arrays():
    from ios_uav_env import moves_needed

    assert moves_needed(0.0, 25.0) == 0 and moves_needed(25.0, 25.0) == 1 and moves_needed(25.001, 25.0) == 2
    assert isinstance(moves_needed(30.0, 25.0), int)
    assert moves_needed(25.0 * (1 + 1e-12), 25.0) == 1  # rounding of a whole number of moves
    np.testing.assert_array_equal(moves_needed(np.array([0.0, 10.0, 50.0, 51.0]), 25.0), [0, 1, 2, 3])
    assert ScenarioConfig().min_horizon() == (moves_needed(800.0, 25.0) + 1) * 1.0 == 33.0


def test_scene_box_holds_the_scene_with_its_margin():
    from ios_uav_env import scene_box

    config = ScenarioConfig(ground_node=(50.0, 300.0))
    assert scene_box(config) == (-400.0, 400.0, 0.0, 300.0)
    assert scene_box(config, 10.0) == (-410.0, 410.0, -10.0, 310.0)
    assert scene_box(config, ends=False) == (0.0, 50.0, 0.0, 300.0)  # G and the IOS only


@pytest.mark.parametrize(("gx", "side"), [(60.0, 1.0), (-60.0, -1.0), (0.0, 0.0)])
def test_the_ground_side_is_the_reflection_side_of_the_side_factor(gx, side):
    """sign(x_G - x_c): a UAV on G's side of the plane is served by reflection (factor 1), on the
    other by transmission (epsilon), as ``channel.side_factor`` and the rate kernel read it."""
    from ios_uav_env.model.channel import rate_kernel, side_factor

    surface = "ios" if side else "none"  # (a node in the plane needs no surface)
    config = ScenarioConfig(ground_node=(gx, 30.0), surface=surface)
    assert config.ground_side == side and rate_kernel(config).g_side == side
    if side:
        x = np.array([side * 50.0, -side * 50.0])
        np.testing.assert_array_equal(side_factor(config, x), [1.0, config.transmit_factor])
