"""SCA planner: feasible and monotone iterates, the (16) bound, tiling error, fall-backs, inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("cvxpy")

import ios_uav_env as ie  # noqa: E402
from baselines import sca  # noqa: E402
from baselines.fixed import fly_hover_fly, straight_line  # noqa: E402
from baselines.sca_problem import Surrogate, tiled_config  # noqa: E402
from ios_uav_env import ScenarioConfig  # noqa: E402
from ios_uav_env.model import channel as ch

# T = 30 s (30 slots), q0 -> qF 300 m apart around the IOS; a 10 x 6 surface whose element gain
# (10^4 = (6000 / 60)^2) gives it the amplitude of the default 6000 elements, so the surface matters.
SMALL = ScenarioConfig(T=30, q0=(-150.0, 20.0), qF=(150.0, 20.0), ios_shape=(10, 6), g_element=1e4)
BEHIND = (100.0, 0.0)  # transmissive side (G is at x = -100): the IA optimum hovers here


@pytest.fixture(scope="module")
def plans() -> dict[str, object]:
    """Default multi-start SCA on SMALL for the three surfaces, with every iterate recorded."""
    return {s: sca.solve(SMALL.replace(surface=s), record_iterates=True) for s in ("ios", "ris", "none")}


def _solves(plan):
    return [h for h in plan.history if h["iteration"] > 0]


@pytest.mark.parametrize("surface", ["ios", "ris", "none"])
def test_plan_and_every_iterate_are_feasible_and_scored_by_the_model(plans, surface):
    plan = plans[surface]
    assert plan.feasible and plan.report.worst_violation <= 1e-6
    np.testing.assert_array_equal(plan.trajectory[0], SMALL.q0)  # pinned exactly
    np.testing.assert_array_equal(plan.trajectory[-1], SMALL.qF)
    assert plan.scheme == {"ios": "ia", "ris": "ra", "none": "cuc"}[surface]
    config = plan.config
    iterates = [h for h in plan.history if h.get("trajectory") is not None]
    assert len(iterates) >= len(plan.info["starts"]) + 3
    for h in iterates:  # re-check independently of the recorded numbers
        q = np.asarray(h["trajectory"])
        assert ie.check_trajectory(config, q).feasible, (h["start"], h["iteration"])
        assert h["mean_rate"] == pytest.approx(ie.average_rate(config, q), rel=1e-12)
    assert plan.mean_rate == max(s["mean_rate"] for s in plan.info["starts"])
    assert {"iteration", "mean_rate", "surrogate", "status", "seconds", "start"} <= set(plan.history[1])


@pytest.mark.parametrize("surface", ["ios", "ris", "none"])
def test_exact_objective_never_decreases(plans, surface):
    plan = plans[surface]
    for start in plan.info["starts"]:
        rates = [
            h["mean_rate"]
            for h in plan.history
            if h["start"] == start["start"] and h["mean_rate"] is not None
        ]
        assert len(rates) >= 2
        rel = np.diff(rates) / np.abs(rates[:-1])
        assert rel.min() >= -1e-9, (start, rel.min())
        assert start["stop"] in ("converged", "max_iters")


@pytest.mark.parametrize("surface", ["ios", "ris", "none"])
def test_surrogate_is_a_lower_bound_that_beats_the_previous_iterate(plans, surface):
    """(16): rate(q^l) <= surrogate optimum <= rate(q^(l+1)), to solver accuracy."""
    plan = plans[surface]
    previous = {}
    for h in plan.history:
        if h["iteration"] > 0 and h["surrogate"] is not None:
            assert h["surrogate"] <= h["mean_rate"] * (1 + 1e-8), h
            assert h["surrogate"] >= previous[h["start"]] * (1 - 1e-7), h
        if h["accepted"]:
            previous[h["start"]] = h["mean_rate"]


def test_surrogate_equals_the_exact_rate_at_the_linearisation_point():
    """Anchoring: the tiled surrogate reproduces the model's rate at q^l (no private formula)."""
    for surface in ("ios", "ris", "none"):
        config = SMALL.replace(surface=surface)
        q = fly_hover_fly(config, BEHIND).trajectory
        lin = Surrogate(config, 2, "CLARABEL").linearise(q)
        front = q[1:-1, 0] < 0  # G's side: reflection
        expected = {"ios": np.ones_like(front), "ris": front, "none": np.zeros_like(front)}[surface]
        np.testing.assert_array_equal(lin.active, expected)
        assert lin.constant == pytest.approx(ie.average_rate(config, q), rel=1e-12)


def test_coefficients_are_the_derivatives_of_the_slot_rate():
    """B, C_k, D of (16) against central differences of f(s, u, v) built from the model's terms."""
    config = SMALL
    q = straight_line(config).trajectory
    sur = Surrogate(config, 2, "CLARABEL")
    lin = sur.linearise(q)
    terms = ch.surface_terms(tiled_config(config, 2), q[1:-1]) * lin.anchor[:, None]
    a_d = ch.direct_amplitude(config, q[1:-1])

    def f(n, ds=0.0, du=None, dv=0.0):
        du = np.zeros(terms.shape[1]) if du is None else du
        z = np.sum(terms[n] * np.exp(ds - du)) + a_d[n] * math.exp(dv)
        return math.log2(1 + config.eta * z * z) / config.N

    h = 1e-6
    for n in (0, 5, 12, 27):
        assert lin.values["cb"][n] == pytest.approx((f(n, ds=h) - f(n, ds=-h)) / (2 * h), rel=1e-6)
        assert lin.values["cd"][n] == pytest.approx((f(n, dv=h) - f(n, dv=-h)) / (2 * h), rel=1e-6)
        for k in range(terms.shape[1]):
            e = np.eye(terms.shape[1])[k] * h
            fd = (f(n, du=e) - f(n, du=-e)) / (2 * h)
            assert lin.values["cc"][n, k] == pytest.approx(fd, rel=1e-6, abs=1e-15)
        assert lin.values["cb"][n] == pytest.approx(-lin.values["cc"][n].sum(), rel=1e-12)


@pytest.mark.parametrize(("tiles", "tol"), [(1, 1e-3), (2, 5e-4), (3, 1e-7), (4, 2e-8)])
def test_tiles_match_the_exact_element_sum(tiles, tol):
    """Tiled zeta vs the per-element sum: small M against the elements themselves, default M
    against the config's own model (itself ~1e-12 from the 6000 elements)."""
    rng = np.random.default_rng(1)
    q = rng.uniform([-400.0, -200.0], [400.0, 200.0], size=(300, 2))
    q[:20, 0] = rng.uniform(-30, 30, 20)  # near the surface, where tiling is worst
    small_exact = ScenarioConfig(ios_shape=(10, 6), quadrature_nodes=0)
    for reference in (small_exact, ScenarioConfig()):
        tiled = tiled_config(reference, tiles)
        exact = ch.surface_amplitude(reference, q)
        approx = ch.surface_terms(tiled, q).sum(axis=1)
        mask = exact > 0
        err = np.max(np.abs(approx[mask] - exact[mask]) / exact[mask])
        assert err <= tol, (reference.ios_shape, tiles, err)
    # the helper is the model's own decomposition: rows sum to surface_amplitude
    np.testing.assert_allclose(
        ch.surface_terms(ScenarioConfig(), q).sum(axis=1), ch.surface_amplitude(ScenarioConfig(), q)
    )


def test_reported_tiling_error_is_small(plans):
    err = plans["ios"].info["tiling_error"]
    assert plans["ios"].info["tiles"] == sca.DEFAULT_TILES
    assert 0 < err["zeta_max_rel"] <= 5e-4 and err["rate_rel"] <= 5e-4
    assert plans["none"].info["tiling_error"] is None


@pytest.mark.parametrize("surface", ["ios", "ris", "none"])
def test_improves_on_its_start_and_beats_fly_hover_fly(plans, surface):
    config = SMALL.replace(surface=surface)
    init = fly_hover_fly(config)
    single = sca.solve(config, init=init)
    assert single.mean_rate > init.mean_rate * (1 + 1e-4)
    assert single.info["starts"][0]["init_rate"] == pytest.approx(init.mean_rate)
    assert plans[surface].mean_rate >= single.mean_rate
    assert plans[surface].mean_rate > max(init.mean_rate, fly_hover_fly(config, BEHIND).mean_rate)


def test_ia_keeps_hovering_on_the_transmissive_side():
    """From a fly-hover-fly to a point behind the IOS, IA converges to a plan hovering there."""
    init = fly_hover_fly(SMALL, BEHIND)
    plan = sca.solve(SMALL, init=init)
    hover = _hover_points(plan.trajectory)
    assert len(hover) >= 10
    assert np.all(hover[:, 0] > 50.0)  # transmissive side (G is at x = -100)
    assert np.all(ch.side_factor(SMALL, hover[:, 0]) == SMALL.epsilon)
    assert plan.mean_rate > init.mean_rate
    # with a RIS the same start cannot stay there: nothing is transmitted behind the surface
    ra = sca.solve(SMALL.replace(surface="ris"), init=init)
    assert len(_hover_points(ra.trajectory)) >= 10
    assert np.all(_hover_points(ra.trajectory)[:, 0] < 0.0)


def _hover_points(q: np.ndarray) -> np.ndarray:
    """Way-points the UAV stays at (next move < 1 m)."""
    return q[:-1][np.linalg.norm(np.diff(q, axis=0), axis=1) < 1.0]


def test_dpp_and_rebuilt_problems_agree():
    init = fly_hover_fly(SMALL, BEHIND)
    a = sca.solve(SMALL, init=init, max_iters=3, tol=1e-12, dpp=True)
    b = sca.solve(SMALL, init=init, max_iters=3, tol=1e-12, dpp=False)
    assert a.info["n_iters"] == b.info["n_iters"] == 3
    np.testing.assert_allclose(a.trajectory, b.trajectory, atol=1e-4)
    assert a.mean_rate == pytest.approx(b.mean_rate, rel=1e-8)


def test_no_surface_slacks_without_a_surface():
    sur = Surrogate(SMALL.replace(surface="none"), 2, "CLARABEL")
    assert set(sur._vars) == {"xi", "psi", "v"}
    assert {"s", "u"} <= set(Surrogate(SMALL, 2, "CLARABEL")._vars)


def test_solver_exception_falls_back_to_the_last_feasible_iterate(monkeypatch):
    init = fly_hover_fly(SMALL, BEHIND)
    reference = sca.solve(SMALL, init=init, max_iters=1)
    calls = {"n": 0}
    original = Surrogate.solve

    def flaky(self, lin, verbose=False):
        calls["n"] += 1
        if calls["n"] >= 2:
            raise RuntimeError("boom")
        return original(self, lin, verbose)

    monkeypatch.setattr(Surrogate, "solve", flaky)
    with pytest.warns(RuntimeWarning, match="solver_error"):
        plan = sca.solve(SMALL, init=init, max_iters=10)
    last = plan.history[-1]
    assert last["status"] == "solver_error: RuntimeError: boom" and last["mean_rate"] is None
    assert plan.info["starts"][0]["stop"] == "solver_error" and plan.info["status"] == "failed"
    np.testing.assert_allclose(plan.trajectory, reference.trajectory)  # the first iterate, kept
    assert plan.feasible and plan.mean_rate == pytest.approx(reference.mean_rate)


def test_bad_solver_status_falls_back(monkeypatch):
    monkeypatch.setattr(
        Surrogate, "solve", lambda self, lin, verbose=False: (None, math.nan, "infeasible", 0.0)
    )
    init = fly_hover_fly(SMALL)
    with pytest.warns(RuntimeWarning):
        plan = sca.solve(SMALL, init=init)
    assert plan.history[-1]["status"] == "solver_error: status infeasible"
    np.testing.assert_array_equal(plan.trajectory, init.trajectory)


def test_solver_that_cannot_handle_the_cones_falls_back():
    init = fly_hover_fly(SMALL)
    with pytest.warns(RuntimeWarning):
        plan = sca.solve(SMALL, init=init, solver="OSQP")  # a QP solver: no exponential cones
    assert plan.history[-1]["status"].startswith("solver_error: ")
    np.testing.assert_array_equal(plan.trajectory, init.trajectory)
    assert plan.feasible and plan.info["status"] == "failed"


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"tiles": 0}, "tiles"),
        ({"tiles": 2.5}, "tiles"),
        ({"tiles": True}, "tiles"),
        ({"solver": "NO_SUCH_SOLVER"}, "solver"),
        ({"tol": 0.0}, "tol"),
        ({"tol": -1e-4}, "tol"),
        ({"tol": math.nan}, "tol"),
        ({"max_iters": 0}, "max_iters"),
        ({"init": np.zeros((5, 2))}, "init"),
        ({"init": []}, "init"),
    ],
)
def test_bad_inputs_raise_value_errors_naming_the_argument(kwargs, name):
    with pytest.raises(ValueError, match=name):
        sca.solve(SMALL, **kwargs)


def test_infeasible_init_is_rejected():
    q = straight_line(SMALL).trajectory.copy()
    q[5] += 40.0  # two steps longer than D
    with pytest.raises(ValueError, match=r"init\[0\] must be feasible"):
        sca.solve(SMALL, init=[q])


def test_tight_horizon_off_axis_solves_without_the_dp_start():
    # the 5 m DP grid cannot reach qF in N - 1 = 4 moves here; SCA must fall back to its other starts
    qf = (100 * math.cos(math.pi / 6), 100 * math.sin(math.pi / 6))
    cfg = ScenarioConfig(T=5.0, q0=(0.0, 0.0), qF=qf, ground_node=(-50.0, -20.0), ios_shape=(10, 6))
    plan = sca.solve(cfg)
    assert plan.feasible and plan.info["status"] == "ok"  # a start at exactly D per move is no failure
    assert not any(name.startswith("dp") for name, _ in sca.default_starts(cfg))


def test_a_losing_start_that_stops_early_is_recorded_without_a_warning(monkeypatch):
    import warnings

    original = sca._run

    def first_start_fails(surrogate, q0, name, *args):
        if name == "init0":  # stops at once on its (worse) initial trajectory
            return q0, ie.average_rate(SMALL, q0), 0, "solver_error"
        return original(surrogate, q0, name, *args)

    monkeypatch.setattr(sca, "_run", first_start_fails)
    starts = [straight_line(SMALL), fly_hover_fly(SMALL, BEHIND)]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plan = sca.solve(SMALL, init=starts, max_iters=3)
    assert plan.info["status"] == "partial_failure" and plan.info["start"] == "init1"
    with pytest.warns(RuntimeWarning, match="init0"):  # the winner failing still warns
        assert sca.solve(SMALL, init=starts[:1], max_iters=3).info["status"] == "failed"
    monkeypatch.setattr(sca, "_run", lambda s, q0, name, *a: (q0, ie.average_rate(SMALL, q0), 1, "decrease"))
    with warnings.catch_warnings():  # a stop on an exact decrease is SCA's normal end: recorded only
        warnings.simplefilter("error")
        assert sca.solve(SMALL, init=starts[:1]).info["status"] == "failed"
