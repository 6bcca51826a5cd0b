"""The per-slot optimum: alternating optimisation never lowers its objective, stays below the
certified bound and above MRT/ZF with aligned phases; the beam updates against their optimality
conditions and a numerical optimiser; the plain-Python sweeps agree with the compiled ones."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.optimize import minimize

from ios_uav_env.model import miso, miso_slot
from tests.model.test_miso import random_slot
from tests.processes import run_without_numba

#: Rounding slack of "never decreases": one AO iteration sums K^2 M products of O(1) numbers, so a
#: stationary objective moves by ~1e-15 relative; any real decrease of a broken update is larger.
ROUNDING = 1e-12


def _cases(seed: int, n: int):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        n_t, K = int(rng.choice([1, 2, 4])), int(rng.choice([2, 3, 4]))
        yield random_slot(rng, n_t=n_t, K=K, steering=str(rng.choice(["centre", "element"]))), rng


@pytest.mark.slow_without_numba
@pytest.mark.parametrize("objective", miso.SLOT_OBJECTIVES)
def test_every_iteration_keeps_or_raises_the_objective(objective):
    for slot, rng in _cases(11, 6):
        phases = miso.random_phases(slot, rng)
        run = miso_slot.alternate(
            slot, objective, phases, miso.mrt_beams(slot.matrix(phases)), max_iter=15, tol=0
        )
        steps = np.diff(run.history)
        assert np.all(steps >= -ROUNDING * np.abs(run.history[1:])), run.history
        assert run.history[-1] > run.history[0]  # it does move from a random start
        assert run.value == pytest.approx(run.history[-1], rel=1e-12)
        np.testing.assert_allclose(miso.user_rates(slot.matrix(run.phases), run.beams), run.rates, rtol=1e-12)


@pytest.mark.slow_without_numba
@pytest.mark.parametrize("objective", miso.SLOT_OBJECTIVES)
def test_the_optimum_lies_between_the_aligned_baselines_and_the_bound(objective):
    for slot, _ in _cases(23 if objective == "sum" else 29, 12):
        best = miso_slot.optimise_slot(slot, objective, random_starts=1, max_iter=30)
        bound = miso.slot_bounds(slot).of(objective)
        base = miso.baselines(slot, objective, np.random.default_rng(0))
        assert best.value <= bound * (1 + 1e-12)
        for name in ("MRT aligned", "ZF aligned"):
            assert np.isnan(base[name]) or best.value >= base[name] * (1 - ROUNDING), (name, best.value, base)
        assert np.sum(np.abs(best.beams) ** 2) <= 1 + 1e-12


@pytest.mark.slow_without_numba
@pytest.mark.parametrize("objective", miso.SLOT_OBJECTIVES)
def test_the_phase_updates_gain_over_the_beams_alone(objective):
    """From random phases, AO beats the best beams for those phases (max-min: the exact optimum;
    sum: WMMSE's fixed point) in most slots: the phase updates do work (a no-op one fails this)."""
    gains = []
    for slot, rng in _cases(61, 8):
        phases = miso.random_phases(slot, rng)
        H = slot.matrix(phases)
        if objective == "maxmin":
            W = miso_slot.maxmin_beams(H)
        else:
            W = miso.mrt_beams(H)
            for _ in range(200):
                W = miso_slot.wmmse_beams(H, W)
        alone = miso.objective_value(miso.user_rates(H, W), objective)
        joint = miso_slot.alternate(slot, objective, phases, miso.mrt_beams(H), max_iter=30).value
        gains.append(joint / alone - 1.0)
    if objective == "maxmin":
        assert min(gains) >= -ROUNDING
    assert np.sum(np.array(gains) > 1e-3) >= len(gains) // 2, gains


@pytest.mark.slow_without_numba
def test_one_user_reaches_the_closed_form():
    for slot, _ in _cases(31, 6):
        one = miso.SlotChannel(slot.coef[:1], slot.to_elements, slot.direct[:1], slot.rank_one)
        for objective in miso.SLOT_OBJECTIVES:
            best = miso_slot.optimise_slot(one, objective, random_starts=1)
            optimum = np.log2(1.0 + miso.user_gain_bound(one, 0))
            if one.rank_one:
                assert best.value == pytest.approx(optimum, rel=1e-12)
            else:
                assert best.value <= optimum * (1 + 1e-12)


@pytest.mark.slow_without_numba
def test_maxmin_beams_balance_the_sinrs_at_full_power_and_no_optimiser_beats_them():
    rng = np.random.default_rng(41)
    for _ in range(2):
        slot = random_slot(rng, n_t=2, K=2)
        H = slot.matrix(miso.random_phases(slot, rng))
        W = miso_slot.maxmin_beams(H)
        s = miso.sinr(H, W)
        assert np.sum(np.abs(W) ** 2) == pytest.approx(1.0, rel=1e-12)
        assert s.max() == pytest.approx(s.min(), rel=1e-9)
        for other in (miso.mrt_beams(H), miso.zf_beams(H)):
            assert s.min() >= miso.sinr(H, other).min()

        def loss(x, H=H):  # -min SINR of W = x / ||x||
            w = (x[:4] + 1j * x[4:]).reshape(2, 2)
            return -miso.sinr(H, w / np.linalg.norm(w)).min()

        found = max(-minimize(loss, rng.normal(size=8), method="Nelder-Mead",
                              options={"xatol": 1e-9, "fatol": 1e-13, "maxiter": 6000}).fun
                    for _ in range(4))  # fmt: skip
        assert found <= s.min() * (1 + 1e-9)
        assert found >= s.min() * (1 - 1e-3)  # the search does get there: the test can tell


def test_wmmse_beam_updates_keep_the_power_and_climb_to_a_stationary_point():
    rng = np.random.default_rng(43)
    for _ in range(5):
        slot = random_slot(rng, n_t=4, K=3)
        H = slot.matrix(miso.random_phases(slot, rng))
        W = miso.mrt_beams(H)
        values = [miso.user_rates(H, W).sum()]
        for _ in range(300):
            W = miso_slot.wmmse_beams(H, W)
            assert np.sum(np.abs(W) ** 2) <= 1 + 1e-12
            values.append(miso.user_rates(H, W).sum())
        assert np.all(np.diff(values) >= -ROUNDING * np.abs(values[1:]))

        # a stationary point: a quasi-Newton search from the last beams (W = x / ||x||, full power
        # is optimal) finds less than 1e-6 relative more
        def loss(x, H=H):
            w = (x[:12] + 1j * x[12:]).reshape(4, 3)
            return -miso.user_rates(H, w / np.linalg.norm(w)).sum()

        polished = -minimize(loss, np.concatenate([W.real.ravel(), W.imag.ravel()]), method="BFGS").fun
        assert polished <= values[-1] * (1 + 1e-6)


@pytest.mark.slow_without_numba
def test_the_plain_python_sweeps_agree_with_the_compiled_ones():
    slot, rng = next(_cases(47, 1))
    phases = miso.random_phases(slot, rng)
    arrays = {"coef": slot.coef, "to_elements": slot.to_elements, "direct": slot.direct}
    payload = json.dumps(
        {k: [v.real.tolist(), v.imag.tolist()] for k, v in arrays.items()} | {"phases": phases.tolist()}
    )
    code = (
        "import json, sys\nimport numpy as np\nfrom ios_uav_env.jit import HAVE_NUMBA\n"
        "from ios_uav_env.model import miso, miso_slot\n"
        "d = json.load(sys.stdin)\n"
        "a = {k: np.array(d[k][0]) + 1j * np.array(d[k][1]) for k in ('coef', 'to_elements', 'direct')}\n"
        "slot = miso.SlotChannel(a['coef'], a['to_elements'], a['direct'], " + str(slot.rank_one) + ")\n"
        "p = np.array(d['phases'])\n"
        "W = miso.mrt_beams(slot.matrix(p))\n"
        "runs = [miso_slot.alternate(slot, o, p, W, max_iter=3, tol=0) for o in ('sum', 'maxmin')]\n"
        "out = [run.history.tolist() for run in runs]\n"
        "print(json.dumps([HAVE_NUMBA, out]))\n"
    )
    have, plain = json.loads(run_without_numba(code, stdin=payload, timeout=300))
    assert have is False
    for objective, history in zip(miso.SLOT_OBJECTIVES, plain, strict=True):
        compiled = miso_slot.alternate(
            slot, objective, phases, miso.mrt_beams(slot.matrix(phases)), max_iter=3, tol=0
        )
        np.testing.assert_allclose(history, compiled.history, rtol=1e-10)


def test_bad_arguments_name_the_field_and_the_range():
    slot, _ = next(_cases(53, 1))
    phases = np.zeros(slot.M)
    W = miso.mrt_beams(slot.matrix(phases))
    with pytest.raises(ValueError, match=r"objective must be one of \('sum', 'maxmin'\)"):
        miso_slot.optimise_slot(slot, "energy")
    with pytest.raises(ValueError, match="random_starts must be an integer >= 0"):
        miso_slot.optimise_slot(slot, random_starts=-1)
    with pytest.raises(ValueError, match="max_iter must be an integer >= 0"):
        miso_slot.alternate(slot, "sum", phases, W, max_iter=2.5)
    with pytest.raises(ValueError, match="tol must be a number >= 0"):
        miso_slot.alternate(slot, "sum", phases, W, tol=float("nan"))
    for objective in miso.SLOT_OBJECTIVES:  # the single start's beams, named as one setting's
        with pytest.raises(ValueError, match=r"beams must have total power"):
            miso_slot.alternate(slot, objective, phases, 2 * W)
        with pytest.raises(
            ValueError, match=r"beams must be a finite complex array of shape \(\d+, \d+\) \(N_t, K\)"
        ):
            miso_slot.alternate(slot, objective, phases, W[:, :1])


@pytest.mark.slow_without_numba
@pytest.mark.parametrize("objective", miso.SLOT_OBJECTIVES)
def test_slot_optimum_beats_its_starts_and_repeats(objective):
    """``slot_optimum``: at least the plain AO without random starts, at least each user alone (the
    sum rate: TDMA's value, one user all the slot) and the warm setting's own value; below the
    bound; the same inputs give the same solution bit for bit."""
    rng = np.random.default_rng(21)
    for _ in range(3):
        slot, other = random_slot(rng, n_t=3, K=3, shape=(4, 6)), random_slot(rng, n_t=3, K=3, shape=(4, 6))
        warm = miso_slot.slot_optimum(other, objective)  # another slot's setting: feasible here too
        best = miso_slot.slot_optimum(slot, objective, warm=warm)
        plain = miso_slot.optimise_slot(slot, objective, random_starts=0)
        here = miso.objective_value(miso.user_rates(slot.matrix(warm.phases), warm.beams), objective)
        assert best.value >= max(plain.value, here) * (1 - ROUNDING)
        if objective == "sum":
            assert best.value >= miso.tdma_value(miso.tdma_rates(slot), "sum") * (1 - ROUNDING)
        assert best.value <= miso.slot_bounds(slot).of(objective) * (1 + 1e-9)
        again = miso_slot.slot_optimum(slot, objective, warm=warm)
        assert again.value == best.value and np.array_equal(again.beams, best.beams)
