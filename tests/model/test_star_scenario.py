"""A STAR surface as a scenario of the one frame (``ScenarioConfig(surface="star")``): its fields and
their guards, its rate against the STAR layer's per-slot TDMA optimum (``model.star_slot``), its
place against the IOS, and the frame's tools on it (the envs, ``score_plan``, the DP and SCA
planners, the two-node schedule against ``star_regions.star_maxmin``)."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

import ios_uav_env  # noqa: F401  (registers the ids)
from ios_uav_env import ScenarioConfig, maxmin_rate, score_plan
from ios_uav_env.components import SURFACES, STARSurface, World
from ios_uav_env.model import channel, star
from ios_uav_env.model.config import (
    STAR_ACCESS,
    STAR_FIELDS,
    STAR_MAX_BITS,
    STAR_PHASES,
    STAR_PROTOCOLS,
    SURFACE_KINDS,
)
from ios_uav_env.model.config import (
    SURFACES as PAPER_SURFACES,
)
from ios_uav_env.model.star_regions import star_maxmin
from ios_uav_env.model.star_slot import slot_optimum

STAR = ScenarioConfig(surface="star")
#: One node on each side of the plane x = 0.
NODES = ((-100.0, -20.0), (100.0, 30.0))
#: UAV positions on both sides of the plane, near and far from the surface.
POSITIONS = [(-100.0, -20.0), (-50.0, 40.0), (-300.0, 80.0), (20.0, 5.0), (120.0, 10.0), (300.0, -80.0)]


# --- the fields ------------------------------------------------------------------------------


def test_star_fields_stay_out_of_every_default_dict():
    """The guard of the suite hashes and cache keys: no STAR field in a dict at its default, for
    every surface, the STAR one included (its defaults are read back by ``from_dict``)."""
    for surface in SURFACE_KINDS:
        config = ScenarioConfig(surface=surface)
        d = config.to_dict()
        assert not set(STAR_FIELDS) & set(d), surface
        assert ScenarioConfig.from_dict(json.loads(json.dumps(d))) == config
    assert (
        ScenarioConfig().to_dict()
        == ScenarioConfig().replace(surface="star").replace(surface="ios").to_dict()
    )


def test_a_star_field_off_its_default_is_written_and_read_back():
    config = ScenarioConfig(surface="star", star_protocol="ms", star_phases="coupled")
    d = config.to_dict()
    assert (d["surface"], d["star_protocol"], d["star_phases"]) == ("star", "ms", "coupled")
    assert "star_bits" not in d and "star_access" not in d
    assert ScenarioConfig.from_dict(json.loads(json.dumps(d))) == config


def test_the_allowed_values_agree_with_the_star_layer():
    assert set(STAR_PROTOCOLS) == set(star.PROTOCOLS) - {"fixed"}
    assert STAR_PHASES == star.PHASE_MODELS and set(STAR_ACCESS) <= set(star.ACCESS)
    assert STAR_MAX_BITS == star.MAX_BITS
    assert PAPER_SURFACES == ("ios", "ris", "none") and SURFACE_KINDS == (*PAPER_SURFACES, "star")


@pytest.mark.parametrize("surface", ["ios", "ris", "none"])
@pytest.mark.parametrize(("field", "value"), [("star_protocol", "ms"), ("star_phases", "shared")])
def test_a_star_field_with_another_surface_is_refused(surface, field, value):
    with pytest.raises(
        ValueError, match=rf"{field}='{value}' is a field of the STAR surface: it needs surface='star'"
    ):
        ScenarioConfig(surface=surface, **{field: value})
    with pytest.raises(ValueError, match=field):
        ScenarioConfig(surface=surface).replace(**{field: value})


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"star_protocol": "fixed"}, r"star_protocol must be one of \('es', 'ms', 'ts'\), got 'fixed'"),
        ({"star_protocol": 3}, r"star_protocol must be one of"),
        ({"star_phases": "free"}, r"star_phases must be one of \('independent', 'coupled', 'shared'\)"),
        ({"star_bits": 0}, r"star_bits must be None \(continuous phases\) or an integer in \[1, 8\], got 0"),
        ({"star_bits": 9}, r"star_bits must be None"),
        ({"star_bits": True}, r"star_bits must be None"),
        ({"star_bits": 2.5}, r"star_bits must be None"),
        ({"star_access": "sdma"}, r"star_access must be one of"),
    ],
)
def test_bad_star_values_name_the_field_and_the_allowed_values(changes, message):
    with pytest.raises(ValueError, match=message):
        ScenarioConfig(surface="star", **changes)


@pytest.mark.parametrize("bits", [1, 2, 8])
def test_b_bit_phases_are_a_tdma_scenario_and_refused_under_noma_naming_tdma(bits):
    """b-bit phases with TDMA are a scenario of every protocol and phase model (coupled from 2
    bits), written and read back; with NOMA they are refused, naming the allowed access."""
    for protocol in STAR_PROTOCOLS:
        for phases in STAR_PHASES:
            if phases == "coupled" and bits == 1:
                continue
            fields = {"star_protocol": protocol, "star_phases": phases}
            config = ScenarioConfig(surface="star", star_bits=bits, **fields)
            assert config.to_dict()["star_bits"] == bits
            assert ScenarioConfig.from_dict(json.loads(json.dumps(config.to_dict()))) == config
    assert ScenarioConfig(surface="star", star_bits=np.int64(bits)).star_bits.__class__ is int
    with pytest.raises(
        ValueError,
        match=rf"star_bits={bits} with star_access='noma': b-bit phases are modelled with star_access='tdma'"
        r".*use star_access='tdma', or star_bits=None",
    ):
        ScenarioConfig(surface="star", star_bits=bits, star_access="noma")
    with pytest.raises(ValueError, match=rf"star_bits={bits!r} is a field of the STAR surface"):
        ScenarioConfig(surface="ios", star_bits=bits)


def test_one_bit_coupled_phases_and_several_antennas_with_bits_are_refused():
    """Coupled phases need 2 bits (the scenario refuses 1); several antennas with bits are a scenario
    the rate model refuses (the closed form of the multi-antenna UAV has aligned phases)."""
    with pytest.raises(ValueError, match=r"star_bits=1 with star_phases='coupled'.*not on the 1-bit grid"):
        ScenarioConfig(surface="star", star_bits=1, star_phases="coupled")
    config = ScenarioConfig(surface="star", star_bits=2, antennas=2, T=40.0)
    flight = np.linspace(config.q0, config.qF, config.N)
    refusal = r"antennas=2 with star_bits=2.*use antennas=1, or star_bits=None"
    for rate_of in (channel.slot_rates, lambda c, q: score_plan(c, q).rate, channel.aligned_gain):
        with pytest.raises(ValueError, match=refusal):
            rate_of(config, flight)


def test_leaving_the_star_surface_resets_its_fields():
    config = ScenarioConfig(surface="star", star_protocol="ts", star_phases="shared")
    assert config.replace(surface="ios") == ScenarioConfig()
    assert config.replace(surface="ris").to_dict() == ScenarioConfig(surface="ris").to_dict()
    assert config.replace(T=100.0).star_protocol == "ts"  # kept while the surface stays
    with pytest.raises(ValueError, match="star_protocol='ms' is a field of the STAR surface"):
        config.replace(surface="ios", star_protocol="ms")


def test_the_star_component_sets_and_reads_back_the_fields():
    assert "star" in SURFACES.names() and STARSurface.reflects and STARSurface.transmits
    world = World(surface={"kind": "star", "protocol": "ms", "phases": "coupled"})
    config = ScenarioConfig().replace(**world.config_fields())
    assert (config.surface, config.star_protocol, config.star_phases) == ("star", "ms", "coupled")
    assert World.of(config) == world and World.of(STAR) == World(surface="star")
    assert SURFACES.make(world.surface.to_dict()) == world.surface
    with pytest.raises(ValueError, match=r"surface.protocol must be one of"):
        STARSurface(protocol="fixed")
    bits = World(surface={"kind": "star", "bits": 3})
    assert ScenarioConfig().replace(**bits.config_fields()).star_bits == 3
    with pytest.raises(ValueError, match=r"surface.bits=3 with surface.access='noma'.*surface.access='tdma'"):
        World(surface={"kind": "star", "bits": 3, "access": "noma"})


# --- the channel -----------------------------------------------------------------------------


def test_the_transmit_factor_is_one():
    assert STAR.transmit_factor == 1.0 and STAR.replace(epsilon=0.5).transmit_factor == 1.0
    assert ScenarioConfig().transmit_factor == 3.55


@pytest.mark.parametrize("protocol", STAR_PROTOCOLS)
@pytest.mark.parametrize("phases", STAR_PHASES)
def test_slot_rates_are_the_star_layers_tdma_optimum(protocol, phases):
    """At each position the user on the UAV's side is served by reflection and the other by
    transmission; each one's ``slot_rates`` is its rate served alone in ``star_slot``'s TDMA
    optimum (the whole surface on its side, aligned phases), and the slot's max-min follows."""
    config = STAR.replace(ground_nodes=NODES, star_protocol=protocol, star_phases=phases)
    surface = star.StarSurface(protocol, phases)
    sides = set()
    for q in POSITIONS:
        r = 0 if q[0] * NODES[0][0] > 0 else 1  # the node on the UAV's side reflects
        ch = star.star_channels(config, q, NODES[r], NODES[1 - r])
        c_r = channel.slot_rates(config.node_config(r), q)[0]
        c_t = channel.slot_rates(config.node_config(1 - r), q)[0]
        best = slot_optimum(ch, surface, "tdma")
        share = best.setting["share"]
        assert best.rates[0] == pytest.approx(share * c_r, rel=1e-9, abs=1e-12)
        assert best.rates[1] == pytest.approx((1 - share) * c_t, rel=1e-9, abs=1e-12)
        assert best.value == pytest.approx(c_r * c_t / (c_r + c_t), rel=1e-9)
        assert slot_optimum(ch, surface, "tdma", "sum").value == pytest.approx(max(c_r, c_t), rel=1e-9)
        sides.add(r)
    assert sides == {0, 1}  # both nodes served from both sides


@pytest.mark.parametrize("node", NODES)
def test_star_against_the_ios_on_each_side(node):
    """Reflection: the STAR surface and the IOS are equal. Transmission: the IOS's amplitude via
    the surface is epsilon times the STAR's (the paper's pattern factor enters linearly and is not
    energy-normalised), so the IOS is above at the paper's epsilon = 3.55, equal at 1, below at 0.5."""
    ios, st = ScenarioConfig(ground_node=node), STAR.replace(ground_node=node)
    q = np.array(POSITIONS)
    across = q[:, 0] * node[0] < 0
    assert across.any() and (~across).any()
    np.testing.assert_allclose(
        channel.slot_rates(st, q[~across]), channel.slot_rates(ios, q[~across]), rtol=1e-12
    )
    ratio = channel.surface_amplitude(ios, q[across]) / channel.surface_amplitude(st, q[across])
    np.testing.assert_allclose(ratio, ios.epsilon, rtol=1e-12)
    assert np.all(channel.slot_rates(ios, q[across]) > channel.slot_rates(st, q[across]))
    np.testing.assert_allclose(
        channel.slot_rates(ios.replace(epsilon=1.0), q), channel.slot_rates(st, q), rtol=1e-12
    )
    assert np.all(channel.slot_rates(ios.replace(epsilon=0.5), q[across]) < channel.slot_rates(st, q[across]))


def test_the_per_element_model_agrees_with_the_kernel():
    q = np.array(POSITIONS)
    for node in NODES:
        st = STAR.replace(ground_node=node, ios_shape=(30, 20))
        exact = channel.element_amplitudes(st, q).sum(axis=1) + channel.direct_amplitude(st, q)
        np.testing.assert_allclose(channel.zeta(st, q), exact, rtol=1e-12)
        np.testing.assert_allclose(
            channel.phased_rates(st, q, channel.phase_shifts(st, q)), channel.slot_rates(st, q), rtol=1e-12
        )


# --- the frame's tools -----------------------------------------------------------------------


def test_the_two_node_schedule_is_star_maxmin_with_tdma():
    """Over a flight the frame's max-min schedule of a node on each side is the STAR layer's
    flight optimum under TDMA (``star_regions.star_maxmin``), for every protocol."""
    config = STAR.replace(T=40.0, ios_shape=(20, 10), ground_nodes=NODES)
    flight = np.linspace(config.q0, config.qF, config.N)  # crosses the plane: the roles swap
    want = maxmin_rate(config, flight)
    assert score_plan(config, flight).rate == pytest.approx(want, rel=1e-12)
    for protocol in STAR_PROTOCOLS:
        got = star_maxmin(config, flight, np.array(NODES), star.StarSurface(protocol), "tdma")
        assert got.value == pytest.approx(want, rel=1e-9) and got.upper == pytest.approx(want, rel=1e-9)


def test_the_single_node_env_runs_a_star_scenario():
    config = STAR.replace(T=40.0, ground_node=NODES[1])
    with pytest.raises(ValueError, match=r"config.surface='star' but the keyword surface='ios'"):
        gym.make("ios_uav_env/IOSUAV-v0", config=config)
    env = gym.make("ios_uav_env/IOSUAV-v0", config=config, surface="star")
    env.reset(seed=0)
    assert env.unwrapped.config == config
    done, rates = False, []
    rng = np.random.default_rng(0)
    while not done:
        _, _, terminated, truncated, info = env.step(rng.uniform(-1.0, 1.0, 2).astype(np.float32))
        rates.append(float(info["rate"]))
        done = terminated or truncated
    flight = env.unwrapped.trajectory
    np.testing.assert_allclose(rates, channel.slot_rates(config, flight[1:]), rtol=1e-9)
    assert float(info["average_rate"]) == pytest.approx(score_plan(config, flight).rate, rel=1e-9)


def test_the_multi_node_env_runs_a_node_on_each_side():
    config = STAR.replace(T=40.0, ground_nodes=NODES)
    env = gym.make("ios_uav_env/IOSUAV-MultiNode-v0", config=config)
    env.reset(seed=0)
    assert env.unwrapped.config.surface == "star"
    done = False
    rng = np.random.default_rng(1)
    while not done:
        _, _, terminated, truncated, info = env.step(rng.uniform(-1.0, 1.0, env.action_space.shape))
        done = terminated or truncated
    flight = env.unwrapped.trajectory
    assert float(info["best_schedule_rate"]) == pytest.approx(maxmin_rate(config, flight), rel=1e-6)


@pytest.mark.parametrize("nodes", [(NODES[0],), (NODES[1],), NODES])
def test_dp_gives_a_plan_that_score_plan_scores(nodes):
    from baselines import dp

    config = STAR.replace(T=40.0, ground_nodes=nodes)
    plan = dp.solve(config, resolution=12.5)
    score = score_plan(config, plan.trajectory)
    assert score.feasible and score.rate > 0
    if len(nodes) == 1:
        assert plan.info["dp_objective"] == pytest.approx(score.rate, rel=1e-9)
        ios = dp.solve(config.replace(surface="ios"), resolution=12.5)
        assert score_plan(config.replace(surface="ios"), ios.trajectory).rate >= score.rate  # epsilon > 1


def test_sca_gives_a_plan_named_for_the_star_surface():
    pytest.importorskip("cvxpy")
    from baselines import dp, sca

    config = STAR.replace(T=40.0, ground_node=NODES[1])
    plan = sca.solve(config)
    score = score_plan(config, plan.trajectory)
    assert plan.scheme == "sta" and score.feasible
    assert score.rate >= score_plan(config, dp.solve(config, resolution=12.5).trajectory).rate * (1 - 1e-3)


# --- NOMA: both sides' nodes in one slot, scored by score_plan ---------------------------------

#: A small surface at a high SNR, the UAV hovering on the reflection side: NOMA beats TDMA there.
NOMA = ScenarioConfig(
    surface="star", star_access="noma", ground_nodes=((-30.0, 0.0), (30.0, 0.0)), ios_shape=(20, 10),
    power_w=10.0, T=10.0, q0=(-30.0, 0.0), qF=(-30.0, 0.0),
)  # fmt: skip
HOVER = np.tile(NOMA.q0, (NOMA.N, 1))


def test_noma_is_written_and_read_back_and_needs_energy_splitting_with_independent_phases():
    assert NOMA.to_dict()["star_access"] == "noma" and ScenarioConfig.from_dict(NOMA.to_dict()) == NOMA
    for changes in ({"star_protocol": "ms"}, {"star_protocol": "ts"}, {"star_phases": "coupled"}):
        with pytest.raises(
            ValueError, match=r"star_access='noma' is modelled for star_protocol='es'.*star_maxmin"
        ):
            NOMA.replace(**changes)
    with pytest.raises(ValueError, match=r"surface.access='noma' is modelled for surface.protocol='es'"):
        STARSurface(protocol="ms", access="noma")


def test_score_plan_of_noma_is_star_maxmin_and_beats_tdma_here():
    score = score_plan(NOMA, HOVER)
    want = star_maxmin(NOMA, HOVER, np.array(NOMA.nodes), star.StarSurface("es"), "noma")
    assert score.feasible and not score.own_shares and score.best is None
    assert score.rate == score.best_schedule_rate == pytest.approx(want.value, rel=1e-12)
    tdma = NOMA.replace(star_access="tdma")
    assert score.rate > 1.05 * score_plan(tdma, HOVER).rate  # superposition pays at this SNR
    assert score.energy_efficiency == pytest.approx(
        NOMA.bandwidth_hz * NOMA.T * score.rate / score.energy, rel=1e-12
    )
    flight = np.linspace((-400.0, 20.0), (400.0, 20.0), 40)  # crosses the plane: the roles swap
    wide = NOMA.replace(T=40.0, q0=(-400.0, 20.0), qF=(400.0, 20.0))
    assert score_plan(wide, flight).rate >= score_plan(wide.replace(star_access="tdma"), flight).rate * (
        1 - 1e-9
    )


def test_what_score_plan_does_not_score_under_noma_is_refused():
    with pytest.raises(ValueError, match="shares are TDMA shares"):
        score_plan(NOMA, HOVER, shares=np.full((2, NOMA.N), 0.5))
    with pytest.raises(ValueError, match="static nodes only"):
        score_plan(NOMA, HOVER, paths=np.tile(np.array(NOMA.nodes), (NOMA.N, 1, 1)))
    for nodes in (((-30.0, 0.0),), ((-30.0, 0.0), (30.0, 0.0), (60.0, 10.0))):
        with pytest.raises(ValueError, match=r"scored over two ground_nodes, one on each side.*got K = "):
            score_plan(NOMA.replace(ground_nodes=nodes), HOVER)
    with pytest.raises(ValueError, match="opposite sides"):
        score_plan(NOMA.replace(ground_nodes=((-30.0, 0.0), (-60.0, 10.0))), HOVER)


def test_the_tdma_planners_refuse_noma_naming_dp_star():
    from baselines import registry

    with pytest.raises(
        registry.PlannerMismatch,
        match=r"planner 'dp' does not handle this config: star_access='noma'.*dp-star",
    ):
        registry.solve("dp", NOMA)
    handlers = registry.handlers(NOMA)
    assert {p.kind for p in handlers} == {"heuristic", "optimum", "local"}
    assert [p.name for p in handlers if p.kind != "heuristic"] == ["dp-star", "ao-star"]
    plan = registry.solve("hover", NOMA)
    assert plan.mean_rate == pytest.approx(score_plan(NOMA, plan.trajectory).rate, rel=1e-12)


@pytest.mark.parametrize("nodes", [1, 2])
def test_the_envs_refuse_noma_naming_the_scorer(nodes):
    """A NOMA scenario outside the NOMA ids is refused: with one node by the world's rule, naming
    the NOMA id and the scorer; with two nodes by the TDMA env itself, naming the NOMA id."""
    if nodes == 1:
        config, env_id, extra = NOMA.replace(ground_nodes=None), "ios_uav_env/IOSUAV-v0", {"surface": "star"}
        pattern = r"surface star \(noma\).*STARUAV-NOMA-v0.*score_plan \(ios_uav_env.model.star_regions"
    else:
        config, env_id, extra = NOMA, "ios_uav_env/IOSUAV-MultiNode-v0", {}
        pattern = r"surface star \(noma\).*one node per slot share \(TDMA\): use ios_uav_env/STARUAV-NOMA-v0"
    with pytest.raises(ValueError, match=pattern):
        gym.make(env_id, config=config, **extra)


@pytest.mark.parametrize("nodes", [(NODES[1],), NODES])
def test_the_certified_bound_lies_above_the_plans(nodes):
    from baselines import dp
    from baselines.dp_bound import clairvoyant_bound

    config = STAR.replace(T=40.0, ground_nodes=nodes)
    bound = clairvoyant_bound(config, None, resolution=12.5)
    plans = [dp.solve(config, resolution=12.5).trajectory]
    try:
        from baselines import sca
    except ImportError:  # cvxpy missing: the DP plan alone
        pass
    else:
        plan = sca.solve(config)
        assert plan.scheme == "sta"
        plans.append(plan.trajectory)
    rates = [score_plan(config, q).rate for q in plans]
    assert all(0 < r <= bound for r in rates), (rates, bound)


def test_a_star_episode_renders():
    pytest.importorskip("matplotlib")
    config = STAR.replace(T=40.0)
    env = gym.make("ios_uav_env/IOSUAV-v0", config=config, surface="star", render_mode="rgb_array")
    env.reset(seed=0)
    env.step(np.zeros(2, dtype=np.float32))
    frame = env.render()
    assert frame.ndim == 3 and frame.shape[2] == 3 and frame.std() > 0
