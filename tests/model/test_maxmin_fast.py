"""The max-min schedule without an LP solver (ios_uav_env/model/maxmin.py): the column generation
gives HiGHS's value on hundreds of instances (degenerate ones included) with a valid
certificate, rejects wrong answers, agrees with its plain-Python compilation, and is what the
multi-node envs report at an episode end (score_plan's value, without HiGHS)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model import maxmin, schedule
from ios_uav_env.model.maxmin import CAPPED, CERTIFIED, FAST_TOL, UNCERTIFIED, certificate, fast_schedule
from ios_uav_env.model.maxmin_paths import path_values
from ios_uav_env.model.schedule import certified_schedule, dual_value, maxmin_schedule
from tests.processes import run_without_numba

pytest.importorskip("scipy")


def _bumps(rng: np.random.Generator, k: int, n: int, floor: float) -> np.ndarray:
    """Each node's rate a bump along the flight (a node served well in one stretch), + ``floor``."""
    x = np.linspace(0.0, 1.0, n)
    centres, heights = rng.uniform(0, 1, (k, 1)), rng.uniform(0.5, 3.0, (k, 1))
    return heights * np.exp(-(((x - centres) / 0.1) ** 2)) + floor


def _first(k: int, factor: float) -> np.ndarray:
    """(K, 1): node 0's rates multiplied by ``factor``, the others' as drawn."""
    return np.r_[[factor], np.ones(k - 1)][:, None]


#: Families of (K, N) rate matrices: generic, and the degenerate kinds (ties, equal rows, a node
#: without rate in most slots, one node far weaker or far stronger than the others).
FAMILIES = {
    "uniform": lambda rng, k, n: rng.uniform(0.0, 2.0, (k, n)),
    "bumps": lambda rng, k, n: _bumps(rng, k, n, 0.01),
    "integer ties": lambda rng, k, n: np.round(rng.uniform(0.0, 3.0, (k, n))),
    "equal rows": lambda rng, k, n: np.tile(rng.uniform(0.1, 1.0, n), (k, 1)),
    "equal rates": lambda rng, k, n: np.full((k, n), 0.7),
    "a node mostly zero": lambda rng, k, n: rng.uniform(0, 2, (k, n)) * np.r_[[rng.uniform(size=n) < 0.1],
                                                                             np.ones((k - 1, n))],
    "a far node": lambda rng, k, n: rng.uniform(0.1, 2.0, (k, n)) * _first(k, 1e-10),
    "a dominant node": lambda rng, k, n: rng.uniform(0.1, 2.0, (k, n)) * _first(k, 1e6),
}  # fmt: skip


def _instances(family: str, count: int, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count:
        k, n = int(rng.integers(2, maxmin.MAX_NODES + 1)), int(rng.integers(2, 301))
        r = FAMILIES[family](rng, k, n)
        if np.all(r.sum(axis=1) > 0):  # (a node that cannot be served: value 0, no solve)
            out.append(r)
    return out


def _assert_certified(r: np.ndarray, found: tuple) -> None:
    """The shares are a schedule scoring ``value``, the weights a simplex point whose bound g(w)
    is ``dual``, and the two agree to FAST_TOL."""
    shares, weights, value, dual = found
    assert np.all(shares >= 0) and np.all(shares.sum(axis=0) <= 1 + 1e-12)
    assert value == pytest.approx(np.mean(shares * r, axis=1).min(), rel=1e-13)
    assert np.all(weights >= 0) and weights.sum() == pytest.approx(1.0, abs=1e-12)
    assert dual == pytest.approx(dual_value(r, weights), rel=1e-13)
    assert abs(dual - value) <= FAST_TOL * dual  # (weak duality: value <= dual, up to rounding)


@pytest.mark.slow_without_numba
@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_the_value_is_highs_value_with_a_valid_certificate(family):
    """40 instances per family (K = 2..8, N = 2..300): the fast path answers (no fallback), its
    certificate holds, and its value is HiGHS's to 1e-10 relative."""
    for r in _instances(family, 40, seed=len(family)):
        found = fast_schedule(r)
        assert found is not None, f"no certified answer for K, N = {r.shape} ({family})"
        _assert_certified(r, found)
        reference = maxmin_schedule(r).value
        assert found[2] == pytest.approx(reference, rel=1e-10, abs=0), (family, r.shape)


def test_on_rates_of_a_wide_range_it_is_inside_highs_bracket():
    """Rates falling to 1e-300 along the flight: HiGHS is certified only to its tolerance here
    (1e-9 of the value), the column generation to FAST_TOL, inside HiGHS's [primal, dual]."""
    rng = np.random.default_rng(11)
    compared = 0
    for _ in range(40):
        k, n = int(rng.integers(2, 9)), int(rng.integers(20, 301))
        x = np.linspace(0, 1, n)
        r = rng.uniform(0.5, 3, (k, 1)) * np.exp(-(((x - rng.uniform(0, 1, (k, 1))) / 0.05) ** 2))
        if not np.all(r.mean(axis=1) > 1e-3):
            continue
        found = fast_schedule(r)
        assert found is not None
        _assert_certified(r, found)
        try:
            highs = maxmin_schedule(r)
        except RuntimeError:  # HiGHS's own certificate failed (its tolerances): nothing to compare
            continue
        assert highs.value * (1 - 1e-13) <= found[3] and found[2] <= highs.dual_value * (1 + 1e-13)
        compared += 1
    assert compared >= 20


def test_the_certificate_rejects_wrong_answers():
    r = np.random.default_rng(4).uniform(0.1, 2.0, (3, 50))
    shares, weights, value, dual = fast_schedule(r)
    assert certificate(r, shares, weights)[2] == CERTIFIED
    assert certificate(r, 0.999 * shares, weights)[2] == UNCERTIFIED  # a worse schedule: a gap
    assert certificate(r, shares, np.array([1.0, 0.0, 0.0]))[2] == UNCERTIFIED  # a worse bound
    over = shares.copy()
    over[:, 0] *= 1.01  # column sum 1.01: not a schedule
    assert certificate(r, over, weights)[2] == UNCERTIFIED
    assert certificate(r, shares, 1.01 * weights)[2] == UNCERTIFIED  # off the simplex
    negative = shares.copy()
    negative[0, 1] = -1e-3
    assert certificate(r, negative, weights)[2] == UNCERTIFIED


def test_the_scorer_takes_the_fast_path_and_falls_back_to_highs(monkeypatch):
    """certified_schedule is the fast answer for 2 <= K <= 8 (HiGHS is never called), HiGHS for
    K = 1, more than 8 nodes, a node that cannot be served, or an uncertified fast answer."""
    r = np.random.default_rng(6).uniform(0.1, 2.0, (4, 60))
    real = schedule.maxmin_schedule
    calls = []

    def counted(rates, fixed=None):
        calls.append(np.shape(rates))
        return real(rates, fixed)

    monkeypatch.setattr(schedule, "maxmin_schedule", counted)
    best = certified_schedule(r)
    assert not calls and best.value == pytest.approx(real(r).value, rel=1e-12)
    assert best.value == np.mean(best.shares * r, axis=1).min()
    assert best.dual_value == dual_value(r, best.weights)
    many = np.random.default_rng(7).uniform(0.1, 2.0, (9, 30))
    for rates in (r[:1], many, np.r_[r[:2], np.zeros((1, 60))]):
        assert certified_schedule(rates).value == pytest.approx(real(rates).value, rel=1e-12, abs=1e-300)
    assert calls == [(1, 60), (9, 30), (3, 60)]
    monkeypatch.setattr(schedule, "fast_schedule", lambda rates: None)  # the certificate failed
    certified_schedule(r)
    assert calls[-1] == (4, 60)


def test_refusals_name_the_shape():
    with pytest.raises(ValueError, match=r"2 <= K <= 8.*\(9, 5\)"):
        fast_schedule(np.ones((9, 5)))
    with pytest.raises(ValueError, match=r"\(1, 5\)"):
        fast_schedule(np.ones((1, 5)))
    with pytest.raises(ValueError, match=r"sizes must be \(K, N\).*N in \[7, 7\]"):
        path_values([0], np.array([[2, 7]]), np.zeros((1, 5, 2)), np.zeros((1, 2, 3, 1)), np.zeros((1, 2, 9)))


def test_maxmin_row_edge_cases():
    r = np.random.default_rng(9).uniform(0.1, 2.0, (3, 20))
    assert maxmin.maxmin_row(r[:1]) == (pytest.approx(r[0].mean(), rel=1e-15),) * 2 + (CERTIFIED,)
    assert maxmin.maxmin_row(np.r_[r[:2], np.zeros((1, 20))]) == (0.0, 0.0, CERTIFIED)
    value, _, status = maxmin.maxmin_row(np.ones((9, 20)))
    assert np.isnan(value) and status == CAPPED
    assert maxmin.maxmin_row(r)[0] == pytest.approx(maxmin_schedule(r).value, rel=1e-12)


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_the_pricing_gives_each_slot_to_the_first_best_node(family):
    """The priced vertex (the master's column): every slot to the first node of largest w_k r_k[n]
    (ties included: equal rows, integer rates, zero weights), its rates R_k / B_k and g(w) the
    slot-by-slot sums to rounding."""
    rng = np.random.default_rng(len(family) + 100)
    for r in _instances(family, 10, seed=len(family) + 200):
        k, n = r.shape
        bounds = r.mean(axis=1)
        for w in (np.full(k, 1.0 / k), rng.dirichlet(np.ones(k)), np.eye(k)[rng.integers(k)]):
            assign, out = np.full(n, -1, dtype=np.int8), np.empty(k)
            g = maxmin._price(r, w, assign, bounds, out, np.empty(n))
            products = w[:, None] * r
            np.testing.assert_array_equal(assign, np.argmax(products, axis=0))  # (the first maximum)
            expected = np.array([r[j, assign == j].sum() for j in range(k)]) / (n * bounds)
            np.testing.assert_allclose(out, expected, rtol=1e-13, atol=0)
            assert g == pytest.approx(products.max(axis=0).mean(), rel=1e-13)


def test_compiled_and_plain_python_agree():
    """The same instances under numba and under IOS_UAV_ENV_NO_NUMBA=1: the same values (to
    rounding: fast-math sums) and both certified."""
    if not HAVE_NUMBA:
        pytest.skip("numba is not installed: only the plain-Python path exists")
    rng = np.random.default_rng(12)
    cases = [rng.uniform(0, 2, (int(rng.integers(2, 6)), int(rng.integers(2, 60)))) for _ in range(8)]
    cases += [_bumps(rng, 4, 80, 0.0), np.full((3, 10), 0.5)]
    code = (
        "import json, sys, numpy as np\n"
        "from ios_uav_env.jit import HAVE_NUMBA\n"
        "from ios_uav_env.model.maxmin import fast_schedule\n"
        "cases = [np.array(c) for c in json.load(sys.stdin)]\n"
        "print(json.dumps([HAVE_NUMBA] + [fast_schedule(r)[2] for r in cases]))\n"
    )
    plain = json.loads(run_without_numba(code, stdin=json.dumps([c.tolist() for c in cases]), timeout=300))
    assert plain[0] is False
    np.testing.assert_allclose(plain[1:], [fast_schedule(r)[2] for r in cases], rtol=1e-13, atol=0)


#: Every multi-node id with short episodes (a few slots' flights of random moves).
ENV_IDS = {
    "ios_uav_env/IOSUAV-MultiNode-v0": {"T": 40.0},
    "ios_uav_env/IOSUAV-MultiNode-Random-v0": {"ranges": "short"},
    "ios_uav_env/IOSUAV-MultiNode-Mobile-v0": {"ranges": "short"},
}


def _kwargs(env_id: str) -> dict:
    from ios_uav_env.model.scenarios import ScenarioRanges

    kwargs = dict(ENV_IDS[env_id])
    if kwargs.get("ranges") == "short":
        kwargs["ranges"] = ScenarioRanges(T=(40.0, 60.0))
    return kwargs


@pytest.fixture
def no_highs(monkeypatch):
    """HiGHS may not be called: the best-schedule values come from the column generation."""

    def refuse(*args, **kwargs):
        raise AssertionError("the HiGHS schedule was called")

    monkeypatch.setattr(schedule, "maxmin_schedule", refuse)


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_the_envs_report_score_plans_value_by_the_fast_path(env_id, no_highs):
    """At every episode end, single and batched: info["best_schedule_rate"] is score_plan's
    best_schedule_rate of the flight (on the true node paths) to 1e-12 relative, without HiGHS."""
    gym = pytest.importorskip("gymnasium")
    from ios_uav_env import score_plan

    env = gym.make(env_id, **_kwargs(env_id)).unwrapped
    rng = np.random.default_rng(1)
    for seed in (0, 1):
        env.reset(seed=seed)
        terminated = False
        while not terminated:
            _, _, terminated, _, info = env.step(rng.uniform(-1, 1, env.action_space.shape))
        best = score_plan(env.config, env.trajectory, env.shares, env.truth).best_schedule_rate
        assert info["best_schedule_rate"] == pytest.approx(best, rel=1e-12) and best > 0
    vec = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point", **_kwargs(env_id))
    vec.reset(seed=2)
    ended = 0
    while ended < 4:
        _, _, terminated, _, info = vec.step(rng.uniform(-1, 1, (3, *vec.single_action_space.shape)))
        for i in np.flatnonzero(terminated):
            truth = vec.envs[i].truth
            best = score_plan(vec.configs[i], vec.trajectories[i], vec.schedules[i], truth).best_schedule_rate
            assert info["best_schedule_rate"][i] == pytest.approx(best, rel=1e-12) and best > 0
            ended += 1


def test_the_batched_env_keeps_each_slots_rates_and_recomputes_after_a_flight(no_highs):
    """The batched env stores the rates its kernels computed slot by slot (node_rates of the
    flight, to rounding) and scores an ended row from them; a row flown by ``fly`` (slots
    skipped) is scored from its path instead, still score_plan's value."""
    gym = pytest.importorskip("gymnasium")
    from ios_uav_env import score_plan
    from ios_uav_env.model.schedule import node_rates

    vec = gym.make_vec("ios_uav_env/IOSUAV-MultiNode-v0", num_envs=2, vectorization_mode="vector_entry_point",
                       T=40.0)  # fmt: skip
    vec.reset(seed=0)
    vec.fly([1], [[0.0, 0.0]], [5])
    rows, rng = vec.rows.kernel_rows, np.random.default_rng(3)
    assert rows.stored.tolist() == [True, False]
    checked = set()
    for _ in range(2 * vec.configs[0].N):  # row 1 ends 5 steps before row 0
        _, _, terminated, _, info = vec.step(rng.uniform(-1, 1, (2, *vec.single_action_space.shape)))
        for i in set(np.flatnonzero(terminated)) - checked:
            config = vec.configs[i]
            if i == 0:
                kept = rows.rate_path[0, : config.N, : config.K].T
                np.testing.assert_allclose(kept, node_rates(config, vec.trajectories[0]), rtol=1e-12, atol=0)
            best = score_plan(config, vec.trajectories[i], vec.schedules[i]).best_schedule_rate
            assert info["best_schedule_rate"][i] == pytest.approx(best, rel=1e-12)
            checked.add(i)
    assert checked == {0, 1}
