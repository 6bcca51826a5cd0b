"""The links' interface: the single-antenna link's surface phases and beam as inputs, and the
multi-antenna link's closed-form rate (one antenna: the single-antenna link's)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from ios_uav_env.components import LINKS, MultiAntennaLink, SingleAntennaLink, World
from ios_uav_env.model import channel
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.score import score_plan

POSITIONS = np.array([[-50.0, 10.0], [30.0, -40.0], [200.0, 100.0]])


@pytest.mark.parametrize("surface", ["ios", "ris", "none"])
@pytest.mark.parametrize("node", [(-100.0, -20.0), (60.0, 30.0)])  # the UAV's side, and across
def test_closed_form_phases_give_the_envs_rate(surface, node):
    """Given the closed-form phases, the per-element expected gain is zeta^2: the link's rate is the
    env's (``channel.slot_rates``), to rounding; ``phases=None`` is that rate itself."""
    cfg = ScenarioConfig(surface=surface, ground_node=node)
    link = SingleAntennaLink()
    assert np.array_equal(link.rates(cfg, POSITIONS), channel.slot_rates(cfg, POSITIONS))
    aligned = link.rates(cfg, POSITIONS, phases=channel.phase_shifts(cfg, POSITIONS))
    np.testing.assert_allclose(aligned, channel.slot_rates(cfg, POSITIONS), rtol=1e-12)


@pytest.mark.parametrize("node", [(-100.0, -20.0), (60.0, 30.0)])
def test_other_phases_never_beat_the_closed_form(node):
    """Eq. (13) aligns every element with the direct path, so any other phases give at most its
    rate, and strictly less somewhere when the surface serves the node."""
    cfg = ScenarioConfig(surface="ios", ground_node=node)
    link, rng = SingleAntennaLink(), np.random.default_rng(0)
    best = link.rates(cfg, POSITIONS)
    shape = channel.phase_shifts(cfg, POSITIONS).shape
    for _ in range(5):
        other = link.rates(cfg, POSITIONS, phases=rng.uniform(0.0, 2 * np.pi, shape))
        assert np.all(other <= best + 1e-12) and np.any(other < best - 1e-3)


def test_phases_do_nothing_without_a_surface():
    cfg = ScenarioConfig(surface="none")
    shape = channel.phase_shifts(cfg, POSITIONS).shape
    phases = np.random.default_rng(1).uniform(0.0, 2 * np.pi, shape)
    link = SingleAntennaLink()
    np.testing.assert_allclose(
        link.rates(cfg, POSITIONS, phases=phases), link.rates(cfg, POSITIONS), rtol=1e-12
    )


def test_bad_inputs_are_refused():
    cfg = ScenarioConfig()
    link = SingleAntennaLink()
    with pytest.raises(ValueError, match="link 'single_antenna' has 1 antenna"):
        link.rates(cfg, POSITIONS, beam=np.ones(1))
    with pytest.raises(ValueError, match=r"phases must have shape"):
        link.rates(cfg, POSITIONS, phases=np.zeros((3, 2)))
    with pytest.raises(ValueError, match=r"models one ground node.*node_config\(k\)"):
        link.rates(ScenarioConfig(ground_nodes=((-100.0, -20.0), (60.0, 30.0))), POSITIONS)


@pytest.mark.parametrize("nodes", [((-100.0, -20.0),), ((-100.0, -20.0), (60.0, 30.0), (120.0, -80.0))])
def test_the_links_region_gives_the_frames_max_min(nodes):
    """The single-antenna link serves one node per slot: its regions' max-min over the flight is
    the schedule's (``maxmin_rate``) for any K, the mean rate for K = 1."""
    from ios_uav_env import maxmin_rate
    from ios_uav_env.model.regions import maxmin_regions

    cfg = ScenarioConfig(ground_nodes=nodes, T=40.0)
    q = np.linspace(cfg.q0, cfg.qF, cfg.N)
    got = maxmin_regions(SingleAntennaLink().region_pricer(cfg, q), cfg.K)
    assert got.value == pytest.approx(maxmin_rate(cfg, q), rel=1e-9) and got.gap <= 1e-9


# --- the multi-antenna link ------------------------------------------------------------------


@pytest.mark.parametrize("surface", ["ios", "ris", "none", "star"])
@pytest.mark.parametrize("node", [(-100.0, -20.0), (60.0, 30.0)])
def test_one_antenna_of_the_multi_antenna_link_is_the_single_antenna_link(surface, node):
    cfg = ScenarioConfig(surface=surface, ground_node=node)
    one = MultiAntennaLink(antennas=1)
    assert np.array_equal(one.rates(cfg, POSITIONS), SingleAntennaLink().rates(cfg, POSITIONS))
    assert one.config_fields() == SingleAntennaLink().config_fields() == {"antennas": 1}


def test_the_multi_antenna_links_rate_is_the_closed_form_and_grows_with_the_antennas():
    """Its antennas, not the config's, set the rate: ``channel.slot_rates`` of the config with them."""
    cfg = ScenarioConfig()
    rates = [MultiAntennaLink(antennas=n).rates(cfg, POSITIONS) for n in (1, 2, 4, 8)]
    assert np.array_equal(rates[2], channel.slot_rates(cfg.replace(antennas=4), POSITIONS))
    assert np.array_equal(rates[2], MultiAntennaLink(antennas=4).rates(cfg.replace(antennas=8), POSITIONS))
    for lower, higher in itertools.pairwise(rates):
        assert np.all(higher >= lower) and np.all(higher > lower + 0.1)


def test_the_multi_antenna_link_in_a_world():
    link = MultiAntennaLink()
    assert link.antennas == 4 and LINKS.make({"kind": "multi_antenna", "antennas": 8}).antennas == 8
    world = World(link=link)
    config = ScenarioConfig().replace(**world.config_fields())
    assert config.antennas == 4 and World.of(config) == world
    assert World.of(ScenarioConfig(antennas=1)).link == SingleAntennaLink()


@pytest.mark.parametrize("value", [0, 65, 2.5, True, "4"])
def test_the_multi_antenna_links_bad_inputs_are_refused(value):
    with pytest.raises(ValueError, match=r"link.antennas must be an integer in \[1, 64\] \(N_t\)"):
        MultiAntennaLink(antennas=value)
    link, cfg = MultiAntennaLink(), ScenarioConfig()
    with pytest.raises(ValueError, match=r"closed-form optimum: pass phases=None and beam=None.*SlotChannel"):
        link.rates(cfg, POSITIONS, phases=channel.phase_shifts(cfg, POSITIONS))
    with pytest.raises(ValueError, match=r"closed-form optimum"):
        link.rates(cfg, POSITIONS, beam=np.ones((3, 4)))
    with pytest.raises(ValueError, match=r"models one ground node"):
        link.rates(ScenarioConfig(ground_nodes=((-100.0, -20.0), (60.0, 30.0))), POSITIONS)


def test_the_multi_antenna_links_region_of_one_node_is_its_mean_rate():
    from ios_uav_env.model.regions import maxmin_regions

    cfg = ScenarioConfig(T=40.0, antennas=4)
    q = np.linspace(cfg.q0, cfg.qF, cfg.N)
    got = maxmin_regions(MultiAntennaLink().region_pricer(cfg, q), 1)
    assert got.value == pytest.approx(score_plan(cfg, q).rate, rel=1e-9) and got.gap <= 1e-9


def test_the_multi_antenna_links_region_of_several_nodes_is_miso_pricers():
    """Several nodes are served at once (SDMA with the per-slot AO beams): the link prices the
    slots' regions as ``miso_regions.miso_pricer`` (what ``miso_maxmin`` solves from), each point
    below its certified bound; static nodes only."""
    from ios_uav_env.model.array import scenario_array
    from ios_uav_env.model.miso_regions import miso_pricer

    cfg = ScenarioConfig(
        ground_nodes=((-30.0, -20.0), (40.0, 30.0)), antennas=2, ios_shape=(3, 2), T=5.0,
        q0=(-50.0, 20.0), qF=(50.0, 20.0),
    )  # fmt: skip
    q = np.linspace(cfg.q0, cfg.qF, cfg.N)
    w = np.array([0.3, 0.7])
    point, bound = MultiAntennaLink(antennas=2).region_pricer(cfg, q)(w)
    want_point, want_bound = miso_pricer(cfg, scenario_array(cfg), q)(w)
    assert np.array_equal(point, want_point) and bound == want_bound and float(w @ point) <= bound
    with pytest.raises(ValueError, match="static nodes"):
        MultiAntennaLink().region_pricer(cfg, q, paths=np.zeros((cfg.N, 2, 2)))
