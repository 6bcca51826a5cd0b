"""The weighted-sum slot optimum of a STAR surface under NOMA on many positions at once
(``model.star_maps``): against the per-slot pricer of ``star_regions``, the single-user rates, the
frontier's monotonicity, and bad inputs."""

from __future__ import annotations

import numpy as np
import pytest

from ios_uav_env import ScenarioConfig, node_rates
from ios_uav_env.model.star import StarSurface
from ios_uav_env.model.star_maps import frontier_maps
from ios_uav_env.model.star_regions import star_pricer

USERS = np.array([[-100.0, -20.0], [60.0, 30.0]])  # one on each side of the plane x = 0
CONFIG = ScenarioConfig(T=40.0, ios_shape=(20, 10))
#: Both sides of the plane, near and far from the surface and the users.
POINTS = np.array([[-150.0, 0.0], [-20.0, 10.0], [-100.0, -20.0], [40.0, 60.0], [120.0, -80.0], [5.0, 0.0]])


@pytest.mark.parametrize("w_0", [0.0, 0.3, 0.5, 0.85, 1.0])
def test_each_position_against_the_pricer_of_its_slot(w_0):
    w = np.array([w_0, 1 - w_0])
    value, upper, rates = frontier_maps(CONFIG, POINTS, USERS).weighted_sum(w)
    assert np.allclose(w @ rates, value, rtol=1e-12)  # the rates of the setting found
    for p, q in enumerate(POINTS):
        point, bound = star_pricer(CONFIG, q[None], USERS, StarSurface("es"), "noma", tol=1e-9)(w)
        found = float(w @ point)  # a setting's weighted sum: <= f_w <= bound
        assert value[p] <= bound * (1 + 1e-12) and upper[p] >= found * (1 - 1e-12)
        assert value[p] >= found * (1 - 1e-5)  # the frontier on 65 angles: second order in the step


def test_the_ends_of_the_frontier_are_each_user_alone_with_the_whole_surface():
    maps = frontier_maps(CONFIG, POINTS, USERS)
    star = CONFIG.replace(surface="star", ground_nodes=tuple(map(tuple, USERS)))
    want = np.exp2(node_rates(star, POINTS)) - 1  # the TDMA node rates c_k = log2(1 + g_k)
    np.testing.assert_allclose(maps.full_snr, want, rtol=1e-10)
    # along the frontier user 0's amplitude falls and user 1's rises
    assert np.all(np.diff(maps.amps[0], axis=1) <= 1e-15) and np.all(np.diff(maps.amps[1], axis=1) >= -1e-15)
    # w = (1, 0): all to user 0, its single-user rate
    value = maps.weighted_sum(np.array([1.0, 0.0]))[0]
    np.testing.assert_allclose(value, np.log2(1 + want[0]), rtol=1e-12)


def test_blocks_do_not_change_the_table(monkeypatch):
    whole = frontier_maps(CONFIG, POINTS, USERS, points=9)
    monkeypatch.setattr("ios_uav_env.model.star_maps._CHUNK", 9 * CONFIG.M * 2)  # blocks of 2 positions
    np.testing.assert_allclose(frontier_maps(CONFIG, POINTS, USERS, points=9).amps, whole.amps, rtol=1e-14)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ((POINTS[:, :1], USERS), "positions must be a finite"),
        ((POINTS, USERS[:1]), "users must be two finite"),
        ((POINTS, np.array([[-10.0, 0.0], [-20.0, 0.0]])), "opposite sides"),
        ((POINTS, USERS, 1), "points .* integer >= 2"),
        ((POINTS, USERS, True), "points .* integer >= 2"),
    ],
)
def test_bad_inputs_are_refused_by_name(args, match):
    with pytest.raises(ValueError, match=match):
        frontier_maps(CONFIG, *args)


def test_bad_weights_are_refused():
    maps = frontier_maps(CONFIG, POINTS[:2], USERS, points=5)
    for w in ([0.5, 0.6], [1.0], [-0.1, 1.1]):
        with pytest.raises(ValueError, match="w must be two weights"):
            maps.weighted_sum(np.array(w))
