"""NOMA from the multi-antenna UAV (``miso_noma``, ``miso_noma_slot``): the SIC rates against a
plain re-derivation and the STAR model's two-user NOMA, the certified per-slot bound above every
NOMA setting and the AO, the AO's monotone steps, its starts, a gradient against finite differences,
and the AO against a multi-start numerical optimiser on tiny slots."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.optimize import minimize

from ios_uav_env.model import miso, miso_noma, miso_noma_slot, star
from tests.model.test_miso import random_slot

#: Rounding slack of a bound: the rates and the bound are sums of O(1) terms.
ROUNDING = 1e-12


def _brute_rates(H: np.ndarray, W: np.ndarray, order) -> np.ndarray:
    """The SIC rates re-derived message by message: the message of order[j] must be decoded by
    every user from position j on, each having removed the messages before it."""
    K = H.shape[0]
    out = np.empty(K)
    for j, user in enumerate(order):
        capacities = []
        for decoder in order[j:]:
            noise = 1.0 + sum(abs(H[decoder] @ W[:, later]) ** 2 for later in order[j + 1 :])
            capacities.append(np.log2(1.0 + abs(H[decoder] @ W[:, user]) ** 2 / noise))
        out[user] = min(capacities)
    return out


def _random_beams(rng: np.random.Generator, n_t: int, K: int) -> np.ndarray:
    W = rng.normal(size=(n_t, K)) + 1j * rng.normal(size=(n_t, K))
    return W / np.linalg.norm(W) * np.sqrt(rng.uniform(0.2, 1.0))


def test_sic_rates_are_the_decoding_chains_rates():
    rng = np.random.default_rng(0)
    for _ in range(20):
        K, n_t = int(rng.integers(2, 5)), int(rng.integers(1, 5))
        H = (rng.normal(size=(K, n_t)) + 1j * rng.normal(size=(K, n_t))) * rng.uniform(0.1, 10)
        W, order = _random_beams(rng, n_t, K), rng.permutation(K)
        rates = miso_noma.sic_rates(H, W, order)
        assert np.allclose(rates, _brute_rates(H, W, order), rtol=1e-12, atol=0)
        for objective, f in (("sum", np.sum), ("maxmin", np.min)):
            assert miso_noma.noma_value(H, W, order, objective) == pytest.approx(f(rates), rel=1e-12)
        last = order[-1]  # decodes everything: no interference left
        assert rates[last] == pytest.approx(np.log2(1 + abs(H[last] @ W[:, last]) ** 2), rel=1e-12)


def test_one_antenna_two_users_are_the_star_models_noma():
    """N_t = 1, K = 2, the weaker user (at the setting's |h_k|^2) decoded first: the rates are
    ``star.noma_rates`` of the SNRs and the power split, and the max-min over the beams is
    ``star.noma_maxmin``'s closed form."""
    rng = np.random.default_rng(1)
    for _ in range(4):
        slot = random_slot(rng, n_t=1, K=2, shape=(3, 2))
        H = slot.matrix(miso.random_phases(slot, rng))
        g = np.abs(H[:, 0]) ** 2
        order = np.argsort(g)
        for p in (0.0, 0.3, 0.5, 0.9, 1.0):
            W = np.array([[np.sqrt(p) * np.exp(1j * rng.uniform(0, 6)), np.sqrt(1 - p)]])
            expected = star.noma_rates(g[0], g[1], p)
            assert np.allclose(miso_noma.sic_rates(H, W, order), expected, rtol=1e-12, atol=1e-15)
        W, value = miso_noma_slot.improve_beams(H, np.array([[0.6, 0.8]]), order, "maxmin", steps=100)
        assert value == pytest.approx(float(star.noma_maxmin(g[0], g[1])[0]), rel=1e-6)
        assert np.linalg.norm(W) == pytest.approx(1.0, rel=1e-12)


def test_the_default_order_sorts_the_single_user_gains_and_bad_orders_are_refused():
    rng = np.random.default_rng(2)
    slot = random_slot(rng, n_t=2, K=3)
    gains = np.array([miso.user_gain_bound(slot, k) for k in range(3)])
    order = miso_noma.decoding_order(slot)
    assert np.all(np.diff(gains[order]) >= 0) and sorted(order) == [0, 1, 2]
    assert list(miso_noma.decoding_order(slot, (2, 0, 1))) == [2, 0, 1]
    H, W = slot.matrix(np.zeros(slot.M)), np.eye(2, 3) / 2
    for bad in ((0, 1), (0, 0, 1), (0, 1, 3), (0.0, 1.0, 2.0), "012", None):
        with pytest.raises(ValueError, match="order must be a permutation of 0, ..., 2"):
            miso_noma.sic_rates(H, W, bad)
    with pytest.raises(ValueError, match="beams must"):
        miso_noma.sic_rates(H, 2 * W, order)  # power 2 > 1
    with pytest.raises(ValueError, match="objective must be one of"):
        miso_noma_slot.noma_optimum(slot, "mean")
    with pytest.raises(ValueError, match="max_iter must be"):
        miso_noma_slot.noma_alternate(slot, "sum", np.zeros(slot.M), W, max_iter=-1)
    for bad_kw, match in (({"max_iter": True}, "max_iter must be"), ({"tol": "x"}, "tol must be a number")):
        with pytest.raises(ValueError, match=match):
            miso_noma_slot.noma_alternate(slot, "sum", np.zeros(slot.M), W, **bad_kw)
    with pytest.raises(ValueError, match="beams must be finite"):
        miso_noma_slot.noma_alternate(slot, "sum", np.zeros(slot.M), np.full((2, 3), np.nan))
    # the beams-only ascent checks what it is given: objective, order, beams, steps
    H2 = slot.matrix(np.zeros(slot.M))
    for args, match in (
        ((W, order, "bogus"), "objective must be one of"),
        ((W, (0, 0, 1), "sum"), "order must be a permutation"),
        ((np.zeros((2, 3)), order, "sum"), "beams must be nonzero"),
        ((np.full((2, 3), np.nan), order, "sum"), "beams must be finite"),
        ((np.ones((3, 2)), order, "sum"), r"beams must be a complex array of shape \(2, 3\)"),
    ):
        with pytest.raises(ValueError, match=match):
            miso_noma_slot.improve_beams(H2, *args)
    with pytest.raises(ValueError, match="steps must be an integer"):
        miso_noma_slot.improve_beams(H2, W, order, "sum", steps=-1)


def test_the_interference_free_bound_bounds_every_noma_setting_and_order():
    """R_k <= log2(1 + p_k G_k) for every order and setting: the slot's sum, max-min and weighted
    bounds lie above every NOMA rate vector (and would not if the SIC rates were miscomputed)."""
    rng = np.random.default_rng(3)
    for _ in range(6):
        K, n_t = int(rng.integers(2, 4)), int(rng.choice([1, 2, 4]))
        slot = random_slot(rng, n_t=n_t, K=K, shape=(4, 3), steering=str(rng.choice(["centre", "element"])))
        bounds = miso.slot_bounds(slot)
        weights = rng.dirichlet(np.ones(K))
        weighted = miso.weighted_sum_bound(bounds.gains, weights)
        for order in itertools.permutations(range(K)):
            for _ in range(10):
                W = _random_beams(rng, n_t, K)
                rates = miso_noma.sic_rates(slot.matrix(miso.random_phases(slot, rng)), W, order)
                p = np.sum(np.abs(W) ** 2, axis=0)
                assert np.all(rates <= np.log2(1 + p * bounds.gains) * (1 + ROUNDING) + 1e-15)
                assert rates.sum() <= bounds.sum_rate * (1 + ROUNDING)
                assert rates.min() <= bounds.maxmin_rate * (1 + ROUNDING)
                assert weights @ rates <= weighted * (1 + 1e-9)


@pytest.mark.slow_without_numba
@pytest.mark.parametrize("objective", miso.SLOT_OBJECTIVES)
def test_the_ao_climbs_from_its_starts_and_stays_below_the_bound(objective):
    rng = np.random.default_rng(4)
    for _ in range(3):
        K, n_t = int(rng.integers(2, 5)), int(rng.choice([1, 2, 4]))
        slot = random_slot(rng, n_t=n_t, K=K, shape=(4, 4))
        order = miso_noma.decoding_order(slot)
        best = miso_noma_slot.noma_optimum(slot, objective, max_iter=15)
        assert best.value <= miso.slot_bounds(slot).of(objective) * (1 + ROUNDING)
        assert best.value == pytest.approx(miso.objective_value(best.rates, objective), rel=1e-12)
        H = slot.matrix(best.phases)
        assert np.allclose(miso_noma.sic_rates(H, best.beams, order), best.rates, rtol=1e-12, atol=0)
        assert np.sum(np.abs(best.beams) ** 2) == pytest.approx(1.0, rel=1e-12)
        for name, phases, beams in miso_noma_slot.noma_starts(slot, objective):
            start = miso_noma.noma_value(slot.matrix(phases), beams, order, objective)
            run = miso_noma_slot.noma_alternate(slot, objective, phases, beams, max_iter=15, start=name)
            assert np.all(np.diff(run.history) >= 0) and run.history[0] >= start * (1 - ROUNDING)
            assert best.value >= run.value
        if objective == "sum":  # each user alone is a start: at least TDMA's best slot sum
            assert best.value >= miso.tdma_value(miso.tdma_rates(slot), "sum") * (1 - ROUNDING)
    again = miso_noma_slot.noma_optimum(slot, objective, max_iter=15, warm=best)
    assert again.value >= best.value * (1 - ROUNDING)  # the warm start is its own setting


def test_the_ascent_gradient_is_the_rates_derivative():
    """The real gradient of one rate r_ij (beams on the sphere's tangent, and the phases) against
    central finite differences."""
    rng = np.random.default_rng(5)
    slot = random_slot(rng, n_t=2, K=3, shape=(2, 2))
    order = np.array([2, 0, 1])
    psi = miso.random_phases(slot, rng)
    W = _random_beams(rng, 2, 3)
    W /= np.linalg.norm(W)
    B = np.exp(-1j * psi)[:, None, None] * miso_noma_slot._cascade(slot, W)[:, order][:, :, order]
    _, gradients = miso_noma_slot._gradients(slot.matrix(psi), W, order, B)
    for i, j in ((0, 0), (2, 0), (2, 1), (2, 2)):
        grad = gradients[i, j]
        direction = rng.normal(size=grad.size)
        n = W.size
        dW = (direction[:n] + 1j * direction[n : 2 * n]).reshape(W.shape)
        dW -= np.vdot(W, dW).real * W  # on the tangent: the normalisation is second order

        def rate(t, dW=dW, direction=direction, i=i, j=j, n=n):
            V = W + t * dW
            H = slot.matrix(psi + t * direction[2 * n :])
            return miso_noma_slot._parts(H, V / np.linalg.norm(V), order)[4][i, j]

        h = 1e-6
        numeric = (rate(h) - rate(-h)) / (2 * h)
        tangent = np.concatenate([dW.real.ravel(), dW.imag.ravel(), direction[2 * n :]])
        assert grad @ tangent == pytest.approx(numeric, rel=1e-5, abs=1e-9)


@pytest.mark.slow_without_numba
def test_the_ao_is_within_a_numerical_optimisers_reach_on_tiny_slots():
    """K = 2, N_t = 2, M = 4: Nelder-Mead from 6 random starts over the beams (on the sphere) and the
    phases finds no setting 0.2 % better than the AO, and comes within 1 % of it (the test can tell)."""
    rng = np.random.default_rng(6)
    for _ in range(1):
        slot = random_slot(rng, n_t=2, K=2, shape=(2, 2))
        order = miso_noma.decoding_order(slot)
        for objective in miso.SLOT_OBJECTIVES:
            ao = miso_noma_slot.noma_optimum(slot, objective).value

            def loss(x, slot=slot, order=order, objective=objective):
                W = (x[:4] + 1j * x[4:8]).reshape(2, 2)
                size = np.linalg.norm(W)
                return -miso_noma.noma_value(slot.matrix(x[8:]), W / size, order, objective) if size else 0.0

            found = -np.inf
            for _ in range(6):
                x = np.concatenate([rng.normal(size=8), rng.uniform(0, 2 * np.pi, 4)])
                for _ in range(2):  # a restart from its own end
                    x = minimize(loss, x, method="Nelder-Mead", options={"xatol": 1e-10, "fatol": 1e-14,
                                                                          "maxfev": 5000}).x  # fmt: skip
                found = max(found, -loss(x))
            assert found <= ao * (1 + 2e-3), objective
            assert found >= ao * (1 - 1e-2), objective
