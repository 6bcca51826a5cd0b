"""The separation guard (``model.separation``): the common fraction stops a team at its first
contact, keeps every pair apart between way-points too, and never lengthens a move."""

from __future__ import annotations

import numpy as np
import pytest

from ios_uav_env.model.separation import check_separated, flights_separated, min_distance, separated_moves


def _closest_along(q: np.ndarray, p: np.ndarray, samples: int = 2001) -> float:
    """The smallest pairwise distance on the straight flights q -> p (sampled)."""
    return min(min_distance(q + s * (p - q)) for s in np.linspace(0.0, 1.0, samples))


def test_head_on_pair_stops_at_the_separation():
    q = np.array([[0.0, 0.0], [30.0, 0.0]])
    p = np.array([[20.0, 0.0], [10.0, 0.0]])  # would cross
    t, reached = separated_moves(q, p, 10.0)
    assert t == pytest.approx([0.5, 0.5], rel=1e-8) and np.all(t < 0.5)
    assert min_distance(reached) >= 10.0 and min_distance(reached) == pytest.approx(10.0, rel=1e-7)
    assert _closest_along(q, p) < 10.0  # without the guard they would meet


def test_moving_apart_or_in_parallel_flies_the_whole_move():
    q = np.array([[0.0, 0.0], [12.0, 0.0]])
    for p in (np.array([[-5.0, 0.0], [20.0, 0.0]]), np.array([[0.0, 25.0], [12.0, 25.0]])):
        t, reached = separated_moves(q, p, 10.0)
        assert np.all(t == 1.0)
        np.testing.assert_array_equal(reached, p)


def test_a_pass_beside_within_the_separation_is_cut_short():
    """Endpoints far apart, but the straight flights pass within 4 m: the guard sees between
    the way-points."""
    q = np.array([[0.0, 0.0], [40.0, 4.0]])
    p = np.array([[40.0, 0.0], [0.0, 4.0]])
    assert min_distance(p) >= 10.0 and _closest_along(q, p) < 10.0
    t, reached = separated_moves(q, p, 10.0)
    assert np.all((0.0 < t) & (t < 1.0)) and _closest_along(q, reached) >= 10.0 - 1e-9


def test_random_teams_never_come_closer_than_the_separation():
    rng = np.random.default_rng(0)
    d_min = 8.0
    q = np.array([[0.0, 0.0], [20.0, 0.0], [0.0, 20.0], [20.0, 20.0]])
    for _ in range(300):
        p = q + rng.uniform(-25.0, 25.0, q.shape)
        t, reached = separated_moves(q, p, d_min)
        assert np.all((0.0 <= t) & (t <= 1.0)) and _closest_along(q, reached, 101) >= d_min
        lengths, wanted = np.hypot(*(reached - q).T), np.hypot(*(p - q).T)
        assert np.all(lengths <= wanted * (1 + 1e-12) + 1e-12)  # never longer than asked
        q = reached


def test_check_separated_names_the_field_and_the_pair():
    check_separated(np.array([[0.0, 0.0], [10.0, 0.0]]), 10.0, "starts")
    with pytest.raises(ValueError, match=r"starts: UAVs 0 and 1 are 5 m apart.*min_separation = 10"):
        check_separated(np.array([[0.0, 0.0], [5.0, 0.0]]), 10.0, "starts")


def test_flights_separated_sees_between_the_way_points():
    passing = np.array([[[0.0, 0.0], [40.0, 0.0]], [[40.0, 4.0], [0.0, 4.0]]])  # cross mid-slot
    assert min_distance(passing[:, 0]) >= 10.0 and min_distance(passing[:, 1]) >= 10.0
    assert not flights_separated(passing, 10.0)
    lanes = np.array([[[0.0, 0.0], [40.0, 0.0]], [[0.0, 12.0], [40.0, 12.0]]])
    assert flights_separated(lanes, 10.0) and not flights_separated(lanes, 12.5)


def test_a_bystander_flies_on_while_a_pair_stops_at_its_contact():
    q = np.array([[0.0, 0.0], [30.0, 0.0], [0.0, 200.0]])
    p = np.array([[20.0, 0.0], [10.0, 0.0], [25.0, 200.0]])  # the pair would cross; the third is far
    t, reached = separated_moves(q, p, 10.0)
    assert t[2] == 1.0 and np.array_equal(reached[2], p[2])
    assert t[:2] == pytest.approx([0.5, 0.5], rel=1e-8) and min_distance(reached) >= 10.0


def test_a_pair_in_contact_that_pushes_together_stays_put_the_others_do_not():
    q = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 100.0]])  # the pair exactly d_min apart
    p = np.array([[5.0, 0.0], [5.0, 1.0], [20.0, 100.0]])
    t, reached = separated_moves(q, p, 10.0)
    assert np.array_equal(t, [0.0, 0.0, 1.0]) and np.array_equal(reached[:2], q[:2])


def test_a_chain_of_contacts_settles_or_falls_back_to_the_common_fraction():
    rng = np.random.default_rng(11)
    for _ in range(200):  # crowded: six UAVs in a 60 m square, long moves
        q = np.array([[0.0, 0.0]])
        while len(q) < 6:
            c = rng.uniform(0.0, 60.0, 2)
            if np.all(np.hypot(*(q - c).T) >= 10.0):
                q = np.vstack([q, c])
        p = q + rng.uniform(-40.0, 40.0, q.shape)
        t, reached = separated_moves(q, p, 10.0)
        assert _closest_along(q, reached, 201) >= 10.0
        assert np.all((t >= 0.0) & (t <= 1.0))
