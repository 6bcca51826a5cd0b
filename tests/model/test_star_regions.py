"""A STAR surface's two users over a flight (``model.star_regions``): the paper's IOS is the frame's
max-min schedule, NOMA with energy splitting is never below TDMA, one slot against its per-slot
optimum, and bad inputs."""

from __future__ import annotations

import numpy as np
import pytest

from ios_uav_env import ScenarioConfig, maxmin_rate
from ios_uav_env.model.star import StarSurface, star_channels
from ios_uav_env.model.star_regions import star_maxmin
from ios_uav_env.model.star_slot import slot_optimum

USERS = np.array([[-100.0, -20.0], [60.0, 30.0]])  # one on each side of the plane x = 0
CONFIG = ScenarioConfig(T=40.0, ios_shape=(20, 10))
FLIGHT = np.linspace(CONFIG.q0, CONFIG.qF, CONFIG.N)  # crosses the plane: the roles swap midway


@pytest.mark.parametrize("surface", ["ios", "ris"])
def test_the_papers_surface_with_tdma_is_the_frames_schedule(surface):
    cfg = CONFIG.replace(surface=surface)
    got = star_maxmin(cfg, FLIGHT, USERS, StarSurface("fixed", "shared"), "tdma")
    want = maxmin_rate(cfg.replace(ground_nodes=tuple(map(tuple, USERS))), FLIGHT)
    assert got.value == pytest.approx(want, rel=1e-9) and got.upper == pytest.approx(want, rel=1e-9)


def test_noma_with_energy_splitting_is_never_below_tdma():
    es = StarSurface("es")
    noma = star_maxmin(CONFIG, FLIGHT, USERS, es, "noma")
    tdma = star_maxmin(CONFIG, FLIGHT, USERS, es, "tdma")
    assert noma.value >= tdma.value * (1 - 1e-9)  # its regions hold TDMA's vertices
    assert noma.value <= noma.upper and noma.gap <= 1e-5
    # the users' order does not matter
    swapped = star_maxmin(CONFIG, FLIGHT, USERS[::-1], es, "noma")
    assert swapped.value == pytest.approx(noma.value, rel=1e-6)


@pytest.mark.parametrize("position", [(-150.0, 0.0), (120.0, 40.0)])
def test_one_slot_with_time_sharing_beats_each_per_slot_max_min(position):
    q = np.array([position])
    es = StarSurface("es")
    got = star_maxmin(CONFIG, q, USERS, es, "noma")
    r = 0 if position[0] < 0 else 1  # the user on the UAV's side reflects
    ch = star_channels(CONFIG, position, USERS[r], USERS[1 - r])
    for access in ("noma", "tdma"):
        one = slot_optimum(ch, es, access)
        assert got.upper >= one.value * (1 - 1e-9)
        assert got.value >= one.value * (1 - 1e-5)  # time sharing only adds (the B&B's tolerance)


def test_what_it_cannot_price_is_refused():
    with pytest.raises(ValueError, match="protocol 'es' with independent continuous phases"):
        star_maxmin(CONFIG, FLIGHT, USERS, StarSurface("ms"), "noma")
    with pytest.raises(ValueError, match="access must be one of"):
        star_maxmin(CONFIG, FLIGHT, USERS, StarSurface("es"), "sdma")
    with pytest.raises(ValueError, match="opposite sides"):
        star_maxmin(CONFIG, FLIGHT, np.array([[-100.0, 0.0], [-50.0, 10.0]]), StarSurface("es"), "tdma")
    with pytest.raises(ValueError, match="trajectory must be"):
        star_maxmin(CONFIG, FLIGHT[:, :1], USERS, StarSurface("es"), "tdma")
    with pytest.raises(TypeError, match="StarSurface"):
        star_maxmin(CONFIG, FLIGHT, USERS, "es", "tdma")
