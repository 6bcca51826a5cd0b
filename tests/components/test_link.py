"""The single-antenna link's interface: the surface's phases and the beam as inputs."""

from __future__ import annotations

import numpy as np
import pytest

from ios_uav_env.components import SingleAntennaLink
from ios_uav_env.model import channel
from ios_uav_env.model.config import ScenarioConfig

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
