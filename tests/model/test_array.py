"""The UAV's ULA: the steering vector's properties, its sign against exact path lengths, and the
validation of ArrayConfig."""

import math

import numpy as np
import pytest

from ios_uav_env.model.array import ArrayConfig, link_cosines, link_response, steering_vector


@pytest.mark.parametrize("n_t", [1, 2, 4, 8])
def test_the_steering_vector_has_norm_sqrt_n_t_and_unit_entries(n_t):
    cosines = np.random.default_rng(n_t).uniform(-1.0, 1.0, 50)
    a = steering_vector(ArrayConfig(n_t=n_t), cosines)
    assert a.shape == (50, n_t)
    np.testing.assert_allclose(np.abs(a), 1.0, rtol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(a, axis=1), math.sqrt(n_t), rtol=1e-14)


def test_broadside_is_all_ones_and_endfire_alternates_at_half_a_wavelength():
    array = ArrayConfig(n_t=6)
    np.testing.assert_allclose(steering_vector(array, 0.0), np.ones(6), atol=1e-15)
    for end in (1.0, -1.0):  # neighbours differ by exp(+-j pi) = -1
        a = steering_vector(array, end)
        np.testing.assert_allclose(a[1:] / a[:-1], -np.ones(5), atol=1e-14)
    # one wavelength apart, endfire is a grating lobe: all antennas in phase again
    a = steering_vector(ArrayConfig(n_t=6, spacing_wl=1.0), 1.0)
    np.testing.assert_allclose(a[1:] / a[:-1], np.ones(5), atol=1e-13)


def test_one_antenna_is_the_paper_s_single_antenna():
    np.testing.assert_array_equal(steering_vector(ArrayConfig(), np.linspace(-1, 1, 7)), np.ones((7, 1)))


def test_the_far_field_response_matches_the_exact_path_lengths():
    """Antenna n at q + delta_n d u is nearer a target along u: in the channel's convention
    exp(-j 2 pi dist / lambda), exp(-j k (|p_n - t| - |q - t|)) ~ a_n far away (a sign error fails)."""
    wavelength = 0.05
    rng = np.random.default_rng(3)
    for _ in range(20):
        array = ArrayConfig(n_t=8, orientation_rad=rng.uniform(0, 2 * np.pi))
        origin = np.array([*rng.uniform(-50, 50, 2), 100.0])
        target = origin + rng.normal(size=3) * 300.0
        antennas = origin + np.outer(array.offsets * wavelength, array.axis)
        exact = np.exp(
            -2j
            * np.pi
            / wavelength
            * (np.linalg.norm(antennas - target, axis=1) - np.linalg.norm(origin - target))
        )
        far = link_response(array, origin, target)
        # the far-field error is ~ k (aperture)^2 / (2 distance): < 1e-3 rad here
        assert np.max(np.abs(exact - far)) < 2e-3
        assert np.max(np.abs(exact - far.conj())) > 1e-2  # the other sign is far off


def test_link_cosines_follow_the_orientation():
    array = ArrayConfig(n_t=2, orientation_rad=np.pi / 2)  # along y
    origin = np.zeros(3)
    targets = np.array([[0.0, 10.0, 0.0], [10.0, 0.0, 0.0], [0.0, -3.0, 4.0]])
    np.testing.assert_allclose(link_cosines(array, origin, targets), [1.0, 0.0, -0.6], atol=1e-15)
    with pytest.raises(ValueError, match="coincides"):
        link_cosines(array, origin, origin)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"n_t": 0}, r"n_t must be an integer in \[1, 64\]"),
        ({"n_t": 2.5}, r"n_t must be an integer in \[1, 64\]"),
        ({"n_t": True}, r"n_t must be an integer in \[1, 64\]"),
        ({"n_t": 65}, r"n_t must be an integer in \[1, 64\]"),
        ({"spacing_wl": 0.0}, r"spacing_wl must be a number in \(0, 4\]"),
        ({"spacing_wl": float("nan")}, r"spacing_wl must be a number in \(0, 4\]"),
        ({"spacing_wl": 5.0}, r"spacing_wl must be a number in \(0, 4\]"),
        ({"orientation_rad": float("inf")}, "orientation_rad must be a finite number"),
        ({"orientation_rad": "x"}, "orientation_rad must be a finite number"),
        ({"steering": "centroid"}, r"steering must be one of \('centre', 'element'\)"),
    ],
)
def test_bad_array_configs_name_the_field_and_the_range(kwargs, message):
    with pytest.raises(ValueError, match=message):
        ArrayConfig(**kwargs)


def test_steering_refuses_cosines_outside_minus_one_one():
    with pytest.raises(ValueError, match=r"cos_psi must be finite and in \[-1, 1\]"):
        steering_vector(ArrayConfig(n_t=2), [0.5, 1.5])
