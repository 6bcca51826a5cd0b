"""The STAR slot over rows (``ios_uav_env.model.star_rows``, ``star_slot.evaluate_rows`` and
``slot_optima``): each row of a batch is the slot computed alone, bit for bit, whatever the other
rows hold; the exact b-bit search over rows beats every grid setting of tiny surfaces; bad
settings are refused for the whole batch."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from ios_uav_env.model import star
from ios_uav_env.model.star import StarChannels, StarSurface
from ios_uav_env.model.star_rows import StarRows, discrete_phases
from ios_uav_env.model.star_slot import evaluate, evaluate_rows, slot_optima, slot_optimum


def _channels(rng: np.random.Generator, m: int, n: int) -> list[StarChannels]:
    return [
        StarChannels(
            rng.random(m),
            rng.random(m),
            rng.uniform(0, 2 * np.pi, m),
            rng.uniform(0, 2 * np.pi, m),
            float(0.3 * rng.random()),
            float(0.3 * rng.random()),
            float(rng.uniform(0.5, 5)),
            1.0,
            0.0,
        )  # fmt: skip
        for _ in range(n)
    ]


def _setting(rng: np.random.Generator, surface: StarSurface, access: str, n: int, m: int) -> dict:
    theta_r = star.quantise(rng.uniform(0, 2 * np.pi, (n, m)), surface.bits)
    theta_t = star.quantise(rng.uniform(0, 2 * np.pi, (n, m)), surface.bits)
    if access == "tdma":
        return dict(u_r=np.ones((n, m)), u_t=np.ones((n, m)), theta_r=theta_r, theta_t=theta_t,
                    share=rng.random(n))  # fmt: skip
    if surface.protocol == "ms":
        u_t = (rng.random((n, m)) > 0.5).astype(float)
        u_r = 1 - u_t
    else:
        gamma = rng.uniform(0, np.pi / 2, (n, m))
        u_r, u_t = np.cos(gamma), np.sin(gamma)
    return dict(u_r=u_r, u_t=u_t, theta_r=theta_r, theta_t=theta_t, split=rng.random(n))


CASES = [
    (StarSurface("es"), "tdma"), (StarSurface("es", bits=1), "tdma"), (StarSurface("es", bits=3), "tdma"),
    (StarSurface("es"), "noma"), (StarSurface("ms", bits=2), "noma"),
]  # fmt: skip


@pytest.mark.parametrize(("surface", "access"), CASES, ids=str)
def test_each_row_is_the_slot_computed_alone_bit_for_bit(surface, access):
    rng = np.random.default_rng(3)
    chans = _channels(rng, 12, 5)
    rows = StarRows.of(chans)
    setting = _setting(rng, surface, access, 5, 12)
    rate_r, rate_t = evaluate_rows(rows, surface, access, setting)
    value, upper = slot_optima(rows, surface, access)
    for i, ch in enumerate(chans):
        one = {key: v[i] if np.ndim(v) > 1 else float(v[i]) for key, v in setting.items()}
        assert evaluate(ch, surface, access, one) == (rate_r[i], rate_t[i])
        best = slot_optimum(ch, surface, access)
        assert (best.value, best.upper) == (value[i], upper[i])
        assert min(rate_r[i], rate_t[i]) <= upper[i] * (1 + 1e-12)
    # another batch around a row leaves it as it was (no reduction mixes rows)
    again = evaluate_rows(rows.take(slice(2, 4)), surface, access, {k: v[2:4] for k, v in setting.items()})
    assert np.array_equal(again[0], rate_r[2:4]) and np.array_equal(again[1], rate_t[2:4])


@pytest.mark.parametrize("bits", [1, 2])
def test_the_exact_discrete_phases_over_rows_beat_every_grid_setting(bits):
    """Brute force over all (2^b)^4 settings of 4-element rows: the rows' search reaches the best."""
    rng = np.random.default_rng(4)
    amps, phi, direct = rng.random((6, 4)), rng.uniform(0, 2 * np.pi, (6, 4)), 0.2 * rng.random(6)
    theta, amp = discrete_phases(amps, phi, direct, bits)
    grid = star.phase_grid(bits)
    for i in range(6):
        brute = max(
            abs(direct[i] + np.sum(amps[i] * np.exp(1j * (phi[i] - np.array(t)))))
            for t in itertools.product(grid, repeat=4)
        )
        assert amp[i] == pytest.approx(brute, rel=1e-12)
        assert star.best_discrete_phases(amps[i], phi[i], direct[i], bits)[1] == amp[i]
        assert np.array_equal(star.best_discrete_phases(amps[i], phi[i], direct[i], bits)[0], theta[i])


def test_a_bad_row_refuses_the_batch_by_name():
    rng = np.random.default_rng(5)
    rows = StarRows.of(_channels(rng, 4, 3))
    setting = _setting(rng, StarSurface("es"), "tdma", 3, 4)
    with pytest.raises(ValueError, match="share"):
        evaluate_rows(rows, StarSurface("es"), "tdma", {**setting, "share": np.array([0.5, 1.5, 0.5])})
    noma = _setting(rng, StarSurface("es"), "noma", 3, 4)
    noma["u_t"][1, 0] = 1.0  # u_r^2 + u_t^2 > 1 on one element of row 1
    noma["u_r"][1, 0] = 1.0
    with pytest.raises(ValueError, match=r"u_r\^2 \+ u_t\^2"):
        evaluate_rows(rows, StarSurface("es"), "noma", noma)
    with pytest.raises(ValueError, match="one surface size"):
        StarRows.of(_channels(rng, 4, 1) + _channels(rng, 5, 1))


def test_a_path_s_channels_are_each_positions_alone_bit_for_bit():
    from ios_uav_env.model.config import ScenarioConfig

    cfg = ScenarioConfig(ios_center=(0.0, 0.0, 5.0), ios_shape=(4, 4))
    path = np.column_stack([np.full(5, -120.0), np.linspace(-150, 150, 5)])
    chans = star.path_channels(cfg, path, (-5.0, 2.0), (5.0, -2.0))
    for q, ch in zip(path, chans, strict=True):
        alone = star.star_channels(cfg, q, (-5.0, 2.0), (5.0, -2.0))
        for name in ("a_r", "a_t", "phi_r", "phi_t", "direct_r", "direct_t", "eta", "fixed_r", "fixed_t"):
            assert np.array_equal(getattr(ch, name), getattr(alone, name)), name
    with pytest.raises(ValueError, match="user_r must be on the UAV's side"):
        star.path_channels(cfg, [[-120.0, 0.0], [30.0, 0.0]], (-5.0, 2.0), (5.0, -2.0))
