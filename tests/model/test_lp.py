"""ios_uav_env.model.lp.solve_lp: HiGHS through highspy, or through scipy's linprog without it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ios_uav_env.model import lp
from ios_uav_env.model.schedule import maxmin_schedule


@pytest.fixture(params=["highspy", "linprog"])
def backend(request, monkeypatch):
    """Each test runs on both routes to HiGHS."""
    if request.param == "linprog":
        monkeypatch.setattr(lp, "_highspy", lambda: None)
    elif lp._highspy() is None:
        pytest.skip("highspy is not installed")
    return request.param


def _random_lp(seed: int):
    """A bounded, feasible LP with inequality and equality rows and a unique optimum (random costs)."""
    rng = np.random.default_rng(seed)
    n = 12
    a_ub = rng.uniform(-1, 1, size=(8, n))
    b_ub = a_ub @ rng.uniform(0, 1, size=n) + rng.uniform(0.1, 1, size=8)  # an interior point
    a_eq = np.ones((1, n))
    return rng.normal(size=n), a_ub, b_ub, a_eq, np.array([n / 2]), np.where(np.arange(n) < 6, 1.0, np.inf)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_solution_is_the_optimum_and_its_duals_certify_it(backend, seed):
    """Feasible x with c x = value, and (strong duality) the duals reproduce the value:
    value = b_ub y + b_eq z + bound terms, checked against scipy's own solve."""
    from scipy.optimize import linprog

    c, a_ub, b_ub, a_eq, b_eq, upper = _random_lp(seed)
    got = lp.solve_lp(c, a_ub, b_ub, upper, a_eq=a_eq, b_eq=b_eq, dual_simplex=seed % 2 == 0)
    bounds = np.column_stack([np.zeros(12), upper])
    ref = linprog(c, A_ub=a_ub, b_ub=b_ub, A_eq=a_eq, b_eq=b_eq, bounds=bounds)
    assert got.optimal and ref.status == 0
    assert got.value == pytest.approx(ref.fun, rel=1e-8, abs=1e-10)
    assert got.value == pytest.approx(c @ got.x, rel=1e-9, abs=1e-12)
    assert np.all(a_ub @ got.x <= b_ub + 1e-7) and np.allclose(a_eq @ got.x, b_eq)
    assert np.all(got.x >= -1e-9) and np.all(got.x <= upper + 1e-9)
    np.testing.assert_allclose(got.ub_duals, ref.ineqlin.marginals, atol=1e-7)
    assert np.all(got.ub_duals <= 1e-9)


def test_an_infeasible_lp_is_reported_not_raised(backend):
    c, a_ub, b_ub, _, _, upper = _random_lp(0)
    got = lp.solve_lp(c, a_ub, b_ub, upper, a_eq=np.ones((1, 12)), b_eq=np.array([-1.0]))  # x >= 0
    assert not got.optimal and got.message


def test_max_min_schedules_agree_on_both_routes(monkeypatch):
    """The schedule's value is certified either way, so the two routes agree on it (and, on
    this non-degenerate case, on the shares)."""
    if lp._highspy() is None:
        pytest.skip("highspy is not installed")
    rates = np.random.default_rng(3).uniform(0.0, 2.0, size=(3, 40))
    fast = maxmin_schedule(rates)
    monkeypatch.setattr(lp, "_highspy", lambda: None)
    slow = maxmin_schedule(rates)
    assert fast.value == pytest.approx(slow.value, rel=1e-9)
    np.testing.assert_allclose(fast.shares, slow.shares, atol=1e-7)


def test_the_solver_prints_nothing():
    """HiGHS announces itself on the C stdout when first made; CLIs print their results there,
    so the solver is made silent (a fresh process: the banner comes once a process)."""
    if lp._highspy() is None:
        pytest.skip("highspy is not installed (linprog prints nothing)")
    code = (
        "import numpy as np\n"
        "from ios_uav_env.model import lp\n"
        "assert lp._highspy() is not None\n"
        "assert lp.solve_lp(np.array([-1.0]), np.ones((1, 1)), np.ones(1), np.ones(1)).optimal\n"
    )
    root = Path(lp.__file__).resolve().parents[2]
    done = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout == ""


def test_threads_solve_their_lps_apart(backend):
    """Each thread has its own solver: LPs solved from several threads at once get the answers
    they get one by one (one shared HiGHS instance would mix their models)."""
    from concurrent.futures import ThreadPoolExecutor

    problems = [_random_lp(seed) for seed in range(16)]

    def solve(p):
        c, a_ub, b_ub, a_eq, b_eq, upper = p
        return lp.solve_lp(c, a_ub, b_ub, upper, a_eq=a_eq, b_eq=b_eq).value

    alone = [solve(p) for p in problems]
    with ThreadPoolExecutor(4) as pool:
        for _ in range(3):
            assert list(pool.map(solve, problems)) == pytest.approx(alone, rel=1e-12)


@pytest.mark.parametrize("with_eq", [False, True])
def test_dense_rows_reach_highs_as_scipys_compressed_columns(with_eq):
    """A dense problem goes to HiGHS in the very arrays scipy's csc_array would give it (nonzeros
    column by column, rows ascending, int32 indices): the same model, so the same solution."""
    from scipy.sparse import csc_array, vstack

    rng = np.random.default_rng(4)
    a_ub = np.where(rng.uniform(size=(7, 9)) < 0.4, 0.0, rng.normal(size=(7, 9)))
    a_ub[:, 3] = 0.0  # an empty column
    a_eq = np.where(rng.uniform(size=(2, 9)) < 0.5, 0.0, 1.0) if with_eq else None
    scipy_rows = csc_array(a_ub) if a_eq is None else csc_array(vstack([csc_array(a_ub), csc_array(a_eq)]))
    indptr, indices, data = lp.dense_columns(a_ub, a_eq)
    for ours, theirs in ((indptr, scipy_rows.indptr), (indices, scipy_rows.indices), (data, scipy_rows.data)):
        assert ours.dtype == theirs.dtype and np.array_equal(ours, theirs)
    if lp._highspy() is None:
        return
    c, a, b, eq, b_eq, upper = _random_lp(5)
    dense = lp.solve_lp(c, a, b, upper, a_eq=eq, b_eq=b_eq)
    sparse = lp.solve_lp(c, csc_array(a), b, upper, a_eq=csc_array(eq), b_eq=b_eq)
    assert (
        dense.optimal
        and np.array_equal(dense.x, sparse.x)
        and np.array_equal(dense.ub_duals, sparse.ub_duals)
    )
