"""The online baselines (baselines.mpc): MPC(k) and plan once on moving, roughly known nodes."""

from __future__ import annotations

import numpy as np
import pytest

from baselines import dp_moving, tour
from baselines.dp_bound import clairvoyant_bound
from baselines.mpc import MPC, run_online
from ios_uav_env import ScenarioConfig
from ios_uav_env.model.mobility import GaussMarkov
from ios_uav_env.model.motion import node_paths

STATIC = ScenarioConfig(
    ground_nodes=((-60.0, -20.0), (80.0, -40.0)),
    T=20.0,
    q0=(-100.0, 20.0),
    qF=(100.0, 20.0),
    ios_shape=(10, 6),
)
MOBILE = STATIC.replace(motion=GaussMarkov())


@pytest.fixture(scope="module")
def mobile_runs() -> dict[str, object]:
    return {p.name: run_online(MOBILE, p, 3) for p in (MPC(k=None), MPC(k=10))}


def test_static_exact_knowledge_gives_the_offline_tour() -> None:
    offline = tour.solve(STATIC).mean_rate
    once = run_online(STATIC, MPC(k=None), 0, report_sigma=0.0)
    assert once.rate == pytest.approx(offline, rel=1e-9)  # the same plan, its own best shares
    # MPC keeps a re-plan only when its predicted value (exact here) beats the incumbent's, so
    # it scores at least its first plan, the offline tour (1e-9: the LP's certificate).
    mpc = run_online(STATIC, MPC(k=4), 0, report_sigma=0.0)
    assert mpc.rate >= offline - 1e-9
    assert mpc.n_plans == 5


def test_plans_are_feasible_and_shares_a_schedule(mobile_runs: dict) -> None:
    for run in mobile_runs.values():
        assert run.feasible
        assert run.trajectory.shape == (MOBILE.N, 2)
        np.testing.assert_array_equal(run.trajectory[0], MOBILE.q0)
        np.testing.assert_allclose(run.trajectory[-1], MOBILE.qF, atol=1e-9)
        assert np.all(run.shares >= 0) and np.all(run.shares.sum(axis=0) <= 1 + 1e-9)
        assert run.seconds > 0
    assert mobile_runs["plan-once"].n_plans == 1
    assert mobile_runs["mpc-k10"].n_plans == 2


def test_the_clairvoyant_bound_is_above_every_row(mobile_runs: dict) -> None:
    truth = mobile_runs["plan-once"].paths
    bound = clairvoyant_bound(MOBILE, truth, resolution=10.0)
    clairvoyant = tour.solve(MOBILE, paths=truth).mean_rate
    for rate in (clairvoyant, *(run.rate for run in mobile_runs.values())):
        assert 0 < rate <= bound


def test_a_seeded_episode_reproduces_bit_for_bit(mobile_runs: dict) -> None:
    again = run_online(MOBILE, MPC(k=10), 3)
    first = mobile_runs["mpc-k10"]
    for name in ("trajectory", "shares", "paths", "reports", "measured"):
        np.testing.assert_array_equal(getattr(again, name), getattr(first, name))
    assert again.rate == first.rate
    other = run_online(MOBILE, MPC(k=10), 4)
    assert not np.array_equal(other.paths, first.paths)


@pytest.mark.parametrize("inner", ["tour", "dp"])
def test_mpc_sees_only_the_reports_so_far(inner: str) -> None:
    short = MOBILE.replace(T=12.0, q0=(-50.0, 20.0), qF=(50.0, 20.0))
    truth = node_paths(short, np.random.default_rng(11))
    changed = truth.copy()
    n = 4
    changed[n + 1 :] = truth[n]  # the nodes stop after slot n
    a = run_online(short, MPC(k=2, planner=inner), 0, paths=truth)
    b = run_online(short, MPC(k=2, planner=inner), 0, paths=changed)
    np.testing.assert_array_equal(a.trajectory[: n + 2], b.trajectory[: n + 2])  # moves to q[n+1]
    np.testing.assert_array_equal(a.shares[:, : n + 1], b.shares[:, : n + 1])
    assert not np.array_equal(a.reports[n + 1 :], b.reports[n + 1 :])  # the truth did change


@pytest.mark.parametrize("k", [0, -1, 1.5, True, "2"])
def test_k_is_validated(k: object) -> None:
    with pytest.raises(ValueError, match=r"MPC\.k"):
        MPC(k=k)  # type: ignore[arg-type]


def test_bad_seed_and_sigma_are_refused() -> None:
    with pytest.raises(ValueError, match="seed"):
        run_online(STATIC, MPC(k=None), -1)
    with pytest.raises(ValueError, match="report_sigma"):
        run_online(STATIC, MPC(k=None), 0, report_sigma=-1.0)


def test_the_mobile_env_and_run_online_share_the_episodes_draws() -> None:
    """One node, a pinned scenario and the same seed: the env's generator draws what
    run_online's does, in the same order (the path, then per slot a report and a measured
    rate), so an agent on the env and the planner face the same truth and the same noise.
    Flying the planner's trajectory, the env reports, measures and scores what it did."""
    from ios_uav_env.envs.single import IOSUAVEnv

    config = STATIC.replace(ground_nodes=((-60.0, -20.0),), motion=GaussMarkov())
    run = run_online(config, MPC(k=10), 4)
    env = IOSUAVEnv(config, knowledge="reports")
    env.reset(seed=4, options={"config": config})
    np.testing.assert_array_equal(env.paths, run.paths)
    q = run.trajectory
    for n in range(1, config.N):
        move = (q[n] - q[n - 1]) / config.D
        env.step(move / max(1.0, float(np.hypot(*move))))
    np.testing.assert_allclose(env.trajectory, q, atol=1e-9)  # the guard keeps a feasible move
    np.testing.assert_array_equal(env.reports, run.reports)
    np.testing.assert_allclose(env.measured_rates, run.measured[0], rtol=1e-9)  # ulp of the LoS phase
    assert env._info()["average_rate"] == pytest.approx(run.score.rate, rel=1e-9) and run.score.rate > 0


ONE = STATIC.replace(ground_nodes=((-60.0, -20.0),))


def test_the_dp_planner_is_a_choice_named_apart() -> None:
    assert MPC().planner == "tour" and MPC(k=1).name == "mpc-k1" and MPC(k=None).name == "plan-once"
    assert MPC(k=1, planner="dp").name == "mpc-dp-k1" and MPC(k=None, planner="dp").name == "plan-once-dp"
    assert MPC(k=10, planner="dp-tour").name == "mpc-dp-tour-k10"
    bad = [({"planner": "sca"}, r"MPC\.planner"), ({"resolution": 0.0}, r"MPC\.resolution"),
           ({"resolution": True}, r"MPC\.resolution"), ({"refine": -1}, r"MPC\.refine")]  # fmt: skip
    for kwargs, match in bad:
        with pytest.raises(ValueError, match=match):
            MPC(**{"k": 1, "planner": "dp", **kwargs})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"resolution must be a finite number in \(0, D=25\] m"):
        run_online(ONE, MPC(k=None, planner="dp", resolution=30.0), 0)


def test_static_exact_knowledge_mpc_dp_flies_the_grid_optimum() -> None:
    """One static node known exactly: every re-plan is the DP on the true map over the same grid
    (anchored at a grid point), so MPC-DP flies the clairvoyant grid optimum; the refinement
    only adds to it."""
    optimum = dp_moving.solve(ONE, resolution=5.0, refine=0, bound=False).mean_rate
    once = run_online(ONE, MPC(k=None, planner="dp", refine=0), 0, report_sigma=0.0)
    mpc = run_online(ONE, MPC(k=4, planner="dp", refine=0), 0, report_sigma=0.0)
    assert once.rate == pytest.approx(optimum, rel=1e-9) and mpc.rate == pytest.approx(optimum, rel=1e-9)
    assert mpc.n_plans == 5 and once.n_plans == 1
    refined = run_online(ONE, MPC(k=None, planner="dp"), 0, report_sigma=0.0)
    assert refined.feasible and refined.rate >= optimum - 1e-12


def test_several_nodes_mpc_dp_starts_from_the_tour() -> None:
    """K = 2: the first plan is the better of the tour and the weighted DP at the tour's dual
    weights, so with exact knowledge MPC-DP scores at least the offline tour."""
    offline = tour.solve(STATIC).mean_rate
    run = run_online(STATIC, MPC(k=5, planner="dp"), 0, report_sigma=0.0)
    assert run.feasible and run.rate >= offline - 1e-9
    again = run_online(STATIC, MPC(k=5, planner="dp"), 0, report_sigma=0.0)
    np.testing.assert_array_equal(again.trajectory, run.trajectory)


@pytest.mark.parametrize("inner", ["dp", "dp-tour"])
def test_the_dp_replans_at_the_incumbents_dual_weights(monkeypatch: pytest.MonkeyPatch, inner: str) -> None:
    """K = 2: the first plan solves the tour, then the weighted DP at the tour frame's dual
    weights; a re-plan runs the DP at the weights of the incumbent's frame (the first frame of the
    re-plan). ``"dp"`` solves the tour at the first plan only, ``"dp-tour"`` at every plan (before
    the DP, whose weights are still the incumbent's)."""
    from baselines import mpc

    frames: list = []
    calls: list[tuple[int, np.ndarray]] = []
    tours: list[int] = []
    real_frame, real_plan, real_tour = mpc._frame, dp_moving.grid_plan, mpc._tour_rest

    def frame(*args):
        frames.append(real_frame(*args))
        return frames[-1]

    def grid_plan(*args, weights=None, **kwargs):
        calls.append((len(frames), weights))
        return real_plan(*args, weights=weights, **kwargs)

    def tour_rest(*args):
        tours.append(len(frames))
        return real_tour(*args)

    monkeypatch.setattr(mpc, "_frame", frame)
    monkeypatch.setattr(mpc, "_tour_rest", tour_rest)
    monkeypatch.setattr(dp_moving, "grid_plan", grid_plan)
    run = run_online(MOBILE, MPC(k=5, planner=inner), 3)
    assert run.n_plans == 4 and len(calls) == 4 and len(tours) == (4 if inner == "dp-tour" else 1)
    np.testing.assert_array_equal(calls[0][1], frames[calls[0][0] - 1].weights)  # the tour's frame
    assert tours[0] == 0
    if inner == "dp-tour":
        for (seen, weights), before in zip(calls[1:], tours[1:], strict=True):
            assert seen == before + 1  # the incumbent's frame, the tour's, then the DP
            np.testing.assert_array_equal(weights, frames[before - 1].weights)
    else:
        for seen, weights in calls[1:]:  # the incumbent's frame, then the DP
            np.testing.assert_array_equal(weights, frames[seen - 1].weights)
    assert not np.allclose(calls[1][1], 0.5)


def test_several_nodes_a_replan_keeps_at_least_the_tours_frame(monkeypatch: pytest.MonkeyPatch) -> None:
    """``"dp-tour"``, K = 2 static nodes known exactly (the predictions are the truth, the credited rates the
    scored ones): every plan's candidates are the tour and the weighted DP, and the next re-plan's
    incumbent frame (the kept plan, its flown shares fixed) is worth at least the best of them,
    so never less than the tour re-solved on the same predictions."""
    from baselines import mpc

    plans: list[list[tuple[str, float]]] = []  # per plan: (candidate, predicted frame value)
    real_frame, real_tour, real_dp = mpc._frame, mpc._tour_rest, mpc._dp_rest
    tag = ["old"]

    def frame(*args):
        f = real_frame(*args)
        if tag[0] == "old" or not plans:
            plans.append([])
        plans[-1].append((tag[0], f.value))
        tag[0] = "old"
        return f

    def tour_rest(*args):
        tag[0] = "tour"
        return real_tour(*args)

    def dp_rest(*args):
        q = real_dp(*args)
        tag[0] = "dp"
        return q

    monkeypatch.setattr(mpc, "_frame", frame)
    monkeypatch.setattr(mpc, "_tour_rest", tour_rest)
    monkeypatch.setattr(mpc, "_dp_rest", dp_rest)
    run = run_online(STATIC, MPC(k=5, planner="dp-tour"), 0, report_sigma=0.0)
    assert run.feasible and len(plans) == run.n_plans == 4
    assert [name for name, _ in plans[0]] == ["tour", "dp"]
    for made, after in zip(plans, plans[1:], strict=False):
        assert [name for name, _ in after] == ["old", "tour", "dp"]
        assert after[0][1] >= max(value for _, value in made) - 1e-9
    assert run.rate >= max(value for _, value in plans[-1]) - 1e-9


@pytest.mark.parametrize("inner", ["tour", "dp", "dp-tour"])
def test_every_replan_is_recorded_with_its_candidates(inner: str) -> None:
    """``OnlineResult.replans``: one record per plan, at the re-plan slots; the first has no
    incumbent; a plan flown next is the best candidate and beats the incumbent, else the incumbent
    is worth at least every candidate; the candidates are the inner planner's (``"dp"``: the tour at
    the first plan only, ``"dp-tour"``: at every plan); the replacements are ``n_kept``."""
    run = run_online(MOBILE, MPC(k=5, planner=inner), 3)
    assert len(run.replans) == run.n_plans >= 3
    assert [r.slot for r in run.replans] == [5 * i for i in range(run.n_plans)]
    assert run.replans[0].incumbent is None and run.replans[0].kept != "incumbent"
    assert sum(r.kept != "incumbent" for r in run.replans) == run.n_kept
    expected = {"tour": [["tour"]] * 2, "dp": [["tour", "dp"], ["dp"]], "dp-tour": [["tour", "dp"]] * 2}[
        inner
    ]
    for i, r in enumerate(run.replans):
        assert list(r.candidates) == expected[min(i, 1)], (i, r)
        best = max(r.candidates.values())
        if r.kept == "incumbent":
            assert r.incumbent is not None and r.incumbent >= best
        else:
            assert r.candidates[r.kept] == best and (r.incumbent is None or best > r.incumbent)
