"""model.miso_runs: many weighted-sum AO runs of a slot at once, each equal bit for bit to the AO
written run by run from the same start (tests/model/miso_reference.py: the arithmetic is the same,
operation for operation), as is miso_slot.alternate (a batch of one), on drawn channels of every
shape the scorer meets and wider arrays whose power multiplier is left to the plain-Python
bisection."""

import numpy as np
import pytest

from ios_uav_env.model.miso import SlotChannel
from ios_uav_env.model.miso_runs import (
    _LEFT,
    _multipliers,
    aligned_starts,
    best_weighted_rates,
    sum_rate_runs,
)
from ios_uav_env.model.miso_slot import alternate, optimise_slot, slot_optimum, wmmse_beams
from tests.model.miso_reference import sum_rate_run
from tests.model.miso_reference import wmmse_beams as reference_beams


def _channel(rng: np.random.Generator, k: int, n_t: int, m: int, scale: float) -> SlotChannel:
    def gaussian(*shape: int) -> np.ndarray:
        return rng.normal(size=shape) + 1j * rng.normal(size=shape)

    steering = np.exp(1j * rng.uniform(0.0, 2 * np.pi, (m, n_t)))
    return SlotChannel(scale * gaussian(k, m), steering, scale * gaussian(k, n_t), rank_one=False)


# (K, N_t, M, scale): the SDMA ids' shapes, a single antenna, and K = 8 users on N_t = 9 antennas (8 > 7
# live eigenvalues: the multiplier's plain-Python bisection); scales from interference- to noise-limited
SHAPES = [(2, 2, 4, 3.0), (3, 4, 8, 10.0), (4, 4, 16, 1.0), (3, 1, 6, 30.0), (8, 9, 3, 5.0), (4, 3, 1, 0.05)]


def _ends(run) -> tuple:
    """A SlotSolution's value, rates, phases, beams and history."""
    return run.value, run.rates, run.phases, run.beams, run.history


def _same(ends: tuple, other: tuple) -> bool:
    """Two runs' ends are equal, bit for bit."""
    return ends[0] == other[0] and all(np.array_equal(a, b) for a, b in zip(ends[1:], other[1:], strict=True))


def _same_run(runs, i, run) -> bool:
    """Run i of a batch ends where ``run`` (a SlotSolution) ends."""
    return _same(
        (runs.values[i], runs.rates[i], runs.phases[i], runs.beams[i], runs.histories[i]), _ends(run)
    )


@pytest.mark.parametrize("weighted", [True, False])
@pytest.mark.parametrize("k, n_t, m, scale", SHAPES)
def test_every_run_is_the_run_alone_bit_for_bit(k, n_t, m, scale, weighted):
    rng = np.random.default_rng(k * 100 + n_t * 10 + m)
    channel = _channel(rng, k, n_t, m, scale)
    starts = aligned_starts(channel) * 2
    phases = np.array([psi for _, psi, _ in starts])
    beams = np.array([w for _, _, w in starts])
    weights = rng.dirichlet(np.ones(k), size=len(starts)) if weighted else None
    if weighted:
        weights[0] = 0.0  # a run that weighs no user
    iterations = set()
    for max_iter in (0, 3, 12):
        runs = sum_rate_runs(channel, phases, beams, weights, max_iter=max_iter)
        for i in range(len(starts)):
            w = None if weights is None else weights[i]
            run = sum_rate_run(channel, phases[i], beams[i], weights=w, max_iter=max_iter)
            assert _same_run(runs, i, run), (max_iter, i)
            alone = alternate(channel, "sum", phases[i], beams[i], weights=w, max_iter=max_iter)
            assert _same(_ends(alone), _ends(run)), (max_iter, i)
            iterations.add(len(run.history))
        H = channel.matrix(phases[0])
        for i in range(len(starts)):  # one beam update: the public batch of one and the run alone
            w = None if weights is None else weights[i]
            assert np.array_equal(wmmse_beams(H, beams[i], w), reference_beams(H, beams[i], w))
    if weighted:  # (the plain sum rate's runs here all take the 12 iterations)
        assert len(iterations) > 3  # runs stop at different iterations: the stopping rule is per run


def _best_run_by_run(channel, starts, **options):
    """The first best of one run after the other from each start (the runs unbatched)."""
    runs = [sum_rate_run(channel, psi, W, start=name, **options) for name, psi, W in starts]
    return max(runs, key=lambda run: run.value)


def _slot_optimum_run_by_run(channel, warm):
    """slot_optimum's sum rate run by run: the aligned starts, each user alone, the warm start."""
    from ios_uav_env.model.miso_slot import alone_starts

    extra = alone_starts(channel) + ([("warm", warm.phases, warm.beams)] if warm is not None else [])
    return _best_run_by_run(channel, aligned_starts(channel) + extra)


def test_optimise_slot_is_the_first_best_of_its_runs_random_starts_included():
    from ios_uav_env.model.miso_slot import best_of_starts, optimise_starts

    channel = _channel(np.random.default_rng(5), 3, 2, 6, 4.0)
    got = optimise_slot(channel, "sum", random_starts=3, rng=np.random.default_rng(9), max_iter=20)
    starts = optimise_starts(channel, 3, np.random.default_rng(9))
    assert [name for name, _, _ in starts][-3:] == ["random 0 MRT", "random 1 MRT", "random 2 MRT"]
    expected = _best_run_by_run(channel, starts, max_iter=20)
    assert got.start == expected.start and got.value == expected.value
    assert np.array_equal(got.phases, expected.phases) and np.array_equal(got.history, expected.history)
    with pytest.raises(ValueError, match="starts must hold at least one"):
        best_of_starts(channel, "sum", [])


def test_the_slot_optimum_of_the_sum_rate_is_the_best_run_of_its_starts():
    rng = np.random.default_rng(11)
    for k, n_t, m, scale in [SHAPES[0], SHAPES[3]]:  # two users on two antennas; three on one
        warm = None
        for _ in range(2):  # the second slot warm-started from the first one's optimum
            channel = _channel(rng, k, n_t, m, scale)
            got, expected = slot_optimum(channel, "sum", warm=warm), _slot_optimum_run_by_run(channel, warm)
            assert got.start == expected.start and got.objective == "sum"
            assert _same(_ends(got), _ends(expected))
            warm = got


def test_the_best_run_per_weight_is_optimise_slots():
    rng = np.random.default_rng(7)
    for k, n_t, m, scale in SHAPES[:3]:  # the SDMA ids' shapes
        channel = _channel(rng, k, n_t, m, scale)
        weights = np.vstack([np.eye(k)[:1], rng.dirichlet(np.ones(k), size=3)])
        best = best_weighted_rates(channel, weights, max_iter=10)
        for w, rates in zip(weights, best, strict=True):
            expected = _best_run_by_run(channel, aligned_starts(channel), weights=w, max_iter=10)
            assert np.array_equal(rates, expected.rates), (k, n_t, m, w)
            assert np.array_equal(
                rates, optimise_slot(channel, random_starts=0, max_iter=10, weights=w).rates
            )


def test_a_wide_array_leaves_its_multiplier_to_the_plain_python_bisection():
    energy, lam = np.full((2, 9), 4.0), np.full((2, 9), 0.5)
    energy[1, 2:] = 0.0  # seven live eigenvalues: the compiled loop's
    mu = np.empty(2)
    _multipliers(energy, lam, np.zeros((2, 9), dtype=bool), np.sqrt(energy.sum(axis=1)), mu)
    assert mu[0] == _LEFT and mu[1] > 0.0


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda p, b, w: (p[:, :-1], b, w), "phases must be a finite"),
        (lambda p, b, w: (p, 2.0 * b, w), "total power"),
        (lambda p, b, w: (p, b[:, :, :1], w), "beams must be a finite"),
        (lambda p, b, w: (p, b, -w), "weights must be a finite"),
        (lambda p, b, w: (p, b, w[:1]), "weights must be a finite"),
    ],
)
def test_bad_runs_are_refused_naming_the_field(change, message):
    rng = np.random.default_rng(3)
    channel = _channel(rng, 2, 2, 4, 1.0)
    starts = aligned_starts(channel)
    phases = np.array([psi for _, psi, _ in starts])
    beams = np.array([w for _, _, w in starts])
    weights = np.full((len(starts), 2), 0.5)
    with pytest.raises(ValueError, match=message):
        sum_rate_runs(channel, *change(phases, beams, weights))
    with pytest.raises(ValueError, match="max_iter must be an integer >= 0"):
        sum_rate_runs(channel, phases, beams, weights, max_iter=-1)


def test_a_user_alone_replaces_the_ao_setting_only_when_strictly_better():
    from ios_uav_env.model.miso_runs import or_alone

    solo = np.array([2.0, 3.0])
    w = np.array([0.5, 0.5])
    assert np.array_equal(or_alone(w, np.array([1.0, 1.0]), solo), [0.0, 3.0])  # user 1 alone: 1.5 > 1.0
    assert np.array_equal(or_alone(w, np.array([2.0, 1.0]), solo), [2.0, 1.0])  # 1.5 = 1.5: the AO's kept
    assert np.array_equal(or_alone(np.array([1.0, 0.0]), np.array([1.0, 4.0]), solo), [2.0, 0.0])
