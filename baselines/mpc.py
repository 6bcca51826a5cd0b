r"""Online baselines for moving, roughly known nodes: MPC(k) and plan once.

**What the UAV knows** (``docs/model.md``, "Moving nodes"): the infrastructure, q0, qF, T and
the motion model's parameters (``config`` with its ``motion``), not the node paths. In slot n
(n = 0..N-1, the UAV at q[n]) it receives every node's position report z_k[n]
(``ios_uav_env.model.reports.position_reports``, std ``report_sigma``), serves the nodes with
its shares alpha[:, n] and then measures the rate of each node it served
(``measured_rates``). The planner's decisions at slot n (the shares of slot n, the position
q[n+1]) use the reports of slots 0..n and the measured rates of slots 0..n-1 only.

**MPC(k)** re-plans at slots n = 0, k, 2k, ...:

1. the :class:`~ios_uav_env.model.kalman.NodeFilter` folds in the reports so far; its estimate
   of slot n (clipped to each node's motion rectangle) and ``predict_paths(N - 1 - n)`` give the
   predicted paths of slots n..N-1;
2. the inner planner (``planner``) plans the rest of the flight on a scenario with q0 = q[n]
   and T = (N - n) dt (the remaining horizon, N - n slots, qF reachable by construction: the
   flown prefix is a prefix of a feasible plan, as the arrival guard's induction in
   ``ios_uav_env.model.guard`` keeps it), the nodes at their estimates: ``"tour"`` (default),
   ``baselines.tour.solve(paths=predicted)``; ``"dp"``, the receding-horizon DP of
   ``baselines.dp_moving`` on the predicted paths' rate maps (``grid_plan`` on the grid of
   spacing ``resolution`` anchored at q[n], arrival at qF at slot N a hard constraint, then
   ``refine`` corridor levels). With K > 1 nodes the DP maximises the per-slot rewards
   max_k w_k r_k at the dual weights w of the incumbent's predicted frame (step 3); the first
   plan is the better of the tour and the DP at the tour's weights. ``"dp-tour"``: with K > 1
   every plan has both candidates, the tour re-solved on the current predictions and the DP,
   and the better one is kept ("Several nodes" below); with one node it is ``"dp"``;
3. the rest of the frame is scheduled by ``maxmin_schedule(rates, fixed=past shares)`` on a
   rate matrix whose past columns are the *credited* rates of the slots flown and whose future
   columns are the predicted rates r_k(q[m]; ŵ_k[m]) of the plan; the new plan is kept only
   when this predicted frame value beats that of the incumbent (the previous plan's rest,
   rescheduled the same way), so the predicted value never decreases from one re-plan to the
   next (with exact knowledge MPC scores at least what its first plan, the offline tour or DP,
   scores);
4. the next k slots are flown: positions q[n+1..n+k] and shares alpha[:, n..n+k-1].

Credited rates (``credit``): ``"model"`` (default), r_k(q[i]; ŵ_k[i]) at the filter's estimate of
slot i made at slot i (the expected-gain rate the score counts); ``"measured"``: the measured
faded rate of each node served in slot i (0 where it was not served, where it does not count).
The tour chooses its route on the remaining horizon alone; the past enters through the shares
and the incumbent test.

**Several nodes: why ``"dp-tour"`` makes the tour a candidate at every re-plan.** The frame's dual weights w
already count the flown slots: the past columns enter the LP of ``maxmin_schedule`` with their
fixed shares, so w leans to the nodes that are behind over the whole flight, and the DP at w
maximises the continuation's Lagrangian

    L(q; w) = sum_k w_k P_k + (1/N) sum_{m >= n} max_k w_k r_k(q[m]; ŵ_k[m]),

P_k the flown slots' credited rate of node k: the dual function of the whole flight's max-min
(``schedule_lp.dual_value`` with ``fixed``), an upper bound on the max-min of its path, not that
max-min. Its maximiser gives every slot to one node's weighted rate; at the weights where the
incumbent is balanced it trades the nodes behind for the one in front, and its frame's max-min
is then low (a Lagrangian subproblem recovers no primal: ``dp_bound.solve_multinode`` recovers
one with tours through the hovers of DP paths at many of Kelley's weights; a re-plan solves one
subproblem). With the DP as the only candidate after the first plan (``"dp"``), a re-plan either keeps the
incumbent, made on older predictions, or switches to a path that chases one node, however often
it re-plans. The tour, re-solved on the current predictions, is the candidate that balances the
nodes; the DP stays a candidate and is kept where its predicted frame is worth more. For one node
(w = 1, L is the mean rate) nothing changes.

**Plan once** (``MPC(k=None)``): the plan made at slot 0 (the filter after the first reports),
flown to the end with its shares, never re-planned.

**Exact reports** (``report_sigma = 0``): the filter runs at ``EXACT_SIGMA`` (its gain is then
1 to rounding, so the estimate is the report); for static nodes the predicted paths are the
true ones.

**Draws** (:func:`run_online`): one numpy Generator ``np.random.default_rng(seed)``: the true
paths (``node_paths``, unless given), then per slot the K reports and, after serving, one
faded sample per node in node order (a node not served, share <= ``SERVED_SHARE``, draws its
sample too and measures nothing, so the stream does not depend on the shares: the draws of the
multi-node env's ``knowledge="reports"``); one seed gives one episode, bit for bit.

**Score**: ``ios_uav_env.score_plan`` on the true paths with the planner's own shares.
``seconds`` is the wall time spent planning (filter, tour or DP, schedules), not drawing or
scoring. The inner planner does not touch the generator, so the draws of one seed are the same
whichever planner flies.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

import ios_uav_env as ie
from baselines import tour
from baselines.grid import DEFAULT_MARGIN, validate_grid_args
from baselines.registry import check as check_planner
from ios_uav_env import ScenarioConfig
from ios_uav_env.model.kalman import NodeFilter
from ios_uav_env.model.motion import check_paths, node_bounds, node_paths
from ios_uav_env.model.reports import REPORT_SIGMA, SERVED_SHARE, measured_rates, position_reports
from ios_uav_env.model.schedule import Schedule
from ios_uav_env.model.score import PlanScore

#: m, the filter's report std when the reports are exact (``report_sigma = 0``).
EXACT_SIGMA = 1e-6
#: The inner planners of a re-plan (module docstring, step 2, and "Several nodes").
INNER_PLANNERS: tuple[str, ...] = ("tour", "dp", "dp-tour")
#: The DP planner's defaults: grid spacing (m) and corridor refinement levels.
DP_RESOLUTION = 5.0
DP_REFINE = 2

__all__ = ["DP_REFINE", "DP_RESOLUTION", "EXACT_SIGMA", "MPC", "SERVED_SHARE", "OnlineResult", "Replan",
           "run_online"]  # fmt: skip


@dataclass(frozen=True)
class MPC:
    """An online planner (module docstring): re-plan every ``k`` slots, or once (``k=None``)."""

    k: int | None = 1  # slots between re-plans (>= 1); None: plan once at slot 0
    credit: Literal["model", "measured"] = "model"  # rates credited to the past slots
    max_points: int | None = None  # tour: most hover points per route (None: its default)
    orders: int = 2  # tour: orders solved per subset
    keep: int = 5  # tour: LP winners scored exactly
    planner: Literal["tour", "dp", "dp-tour"] = "tour"  # the inner planner of each re-plan (module docstring)
    resolution: float = DP_RESOLUTION  # dp: grid spacing (m), in (0, D]
    refine: int = DP_REFINE  # dp: corridor refinement levels (baselines.dp_moving), >= 0

    def __post_init__(self) -> None:
        k = self.k
        if k is not None and (isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1):
            raise ValueError(f"MPC.k must be None (plan once) or an integer >= 1 (slots), got {k!r}")
        if self.credit not in ("model", "measured"):
            raise ValueError(f"MPC.credit must be 'model' or 'measured', got {self.credit!r}")
        if self.planner not in INNER_PLANNERS:
            raise ValueError(f"MPC.planner must be one of {INNER_PLANNERS}, got {self.planner!r}")
        r = self.resolution
        if isinstance(r, bool) or not isinstance(r, (int, float)) or not (math.isfinite(r) and r > 0):
            raise ValueError(f"MPC.resolution must be a finite number > 0 (m; at most D), got {r!r}")
        f = self.refine
        if isinstance(f, bool) or not isinstance(f, (int, np.integer)) or f < 0:
            raise ValueError(f"MPC.refine must be an integer >= 0 (corridor levels), got {f!r}")

    @property
    def name(self) -> str:
        """``"plan-once"`` or ``"mpc-k<k>"``; with the DP, ``"plan-once-dp"`` or ``"mpc-dp-k<k>"``
        (``"dp-tour"``: ``"plan-once-dp-tour"`` or ``"mpc-dp-tour-k<k>"``)."""
        if self.planner != "tour":
            return f"plan-once-{self.planner}" if self.k is None else f"mpc-{self.planner}-k{self.k}"
        return "plan-once" if self.k is None else f"mpc-k{self.k}"


@dataclass(frozen=True)
class Replan:
    """One re-plan of an episode: the predicted frame values (bps/Hz, ``_frame``'s ``value`` on the
    predictions of ``slot``) of the incumbent (None at the first plan) and of each candidate
    (``"tour"``, ``"dp"``), and what was flown next (a candidate's name, or ``"incumbent"``)."""

    slot: int
    incumbent: float | None
    candidates: dict[str, float]
    kept: str


@dataclass(frozen=True)
class OnlineResult:
    """One online episode: what was flown, its score on the true paths, the planning time."""

    scheme: str  # the planner's name
    trajectory: np.ndarray  # (N, 2) m, the flown q[n]
    shares: np.ndarray  # (K, N) alpha_k[n] used
    score: PlanScore  # score_plan(config, trajectory, shares (K > 1), paths=true paths)
    seconds: float  # s, wall time spent planning
    n_plans: int  # re-plans made (the first plan included)
    n_kept: int  # re-plans that replaced the incumbent (the first plan included)
    paths: np.ndarray  # (N, K, 2) m, the true node paths
    reports: np.ndarray  # (N, K, 2) m, the position reports
    measured: np.ndarray  # (K, N) bps/Hz, measured rates (NaN where a node was not served)
    replans: tuple[Replan, ...] = ()  # every re-plan's predicted frame values, in order

    @property
    def rate(self) -> float:
        """bps/Hz, the max-min (K = 1: average) rate with the planner's own shares."""
        return float(self.score.rate)

    @property
    def feasible(self) -> bool:
        """Eq. (10) holds for the flown trajectory."""
        return bool(self.score.feasible)


def _rest_config(config: ScenarioConfig, q: np.ndarray, n: int, nodes: np.ndarray) -> ScenarioConfig:
    """The static scenario of slots n..N-1: q0 = q, N - n slots, nodes at ``nodes`` (K, 2)."""
    pts = [tuple(float(v) for v in p) for p in nodes]
    where = {"ground_node": pts[0]} if config.K == 1 else {"ground_nodes": pts}
    rest_t = (config.N - n) * config.dt
    return config.replace(q0=(float(q[0]), float(q[1])), T=rest_t, motion=None, **where)


def _frame(
    config: ScenarioConfig, past: tuple[np.ndarray, np.ndarray], rest_q: np.ndarray, pred: np.ndarray
) -> Schedule:
    """The predicted frame's schedule (its ``value``, ``shares`` (K, N) and dual ``weights``): the
    best continuation of the past slots' shares ``past[1]`` (K, n0) at their credited rates
    ``past[0]`` (K, n0), the rest of the flight ``rest_q`` (N - n0, 2) on the predicted paths
    ``pred`` (N - n0, K, 2)."""
    credited, fixed = past
    rates = np.concatenate([credited, ie.node_rates(config, rest_q, pred)], axis=1)
    return ie.maxmin_schedule(rates, fixed if fixed.shape[1] else None)


def _dp_rest(
    planner: MPC, rest: ScenarioConfig, pred: np.ndarray, weights: np.ndarray | None
) -> np.ndarray | None:
    """The DP's plan of the rest of the flight on the predicted paths (``dp_moving.grid_plan`` at
    ``weights``, then ``planner.refine`` corridor levels), or None when no grid path is in time."""
    from baselines import dp_moving

    found = dp_moving.grid_plan(rest, pred, planner.resolution, weights=weights)
    if found is None:
        return None
    return dp_moving.refine_plan(rest, pred, *found, planner.resolution, planner.refine, weights)[0]


def _tour_rest(
    config: ScenarioConfig,
    planner: MPC,
    rest: ScenarioConfig,
    pred: np.ndarray,
    past: tuple[np.ndarray, np.ndarray],
) -> tuple[Schedule, np.ndarray]:
    """The tour's plan of the rest of the flight on the predicted paths, with its predicted frame."""
    rest_q = tour.solve(
        rest, paths=pred, max_points=planner.max_points, orders=planner.orders, keep=planner.keep
    ).trajectory
    return _frame(config, past, rest_q, pred), rest_q


def _check_seed(seed: Any) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    return int(seed)


def run_online(
    config: ScenarioConfig,
    planner: MPC,
    seed: int,
    *,
    report_sigma: float = REPORT_SIGMA,
    paths: np.ndarray | None = None,
) -> OnlineResult:
    """One online episode of ``planner`` on ``config`` (module docstring, "Draws").

    ``paths`` (N, K, 2) m: the true node paths (default: drawn by ``node_paths`` from the
    episode's generator first); ``report_sigma`` (m): the reports' error std (0: exact).
    """
    check_planner("mpc", config)
    if not isinstance(planner, MPC):
        raise TypeError(f"planner must be an MPC (MPC(k=...) or MPC(k=None)), got {type(planner).__name__}")
    if planner.planner != "tour":
        validate_grid_args(config, planner.resolution, DEFAULT_MARGIN)
    rng = np.random.default_rng(_check_seed(seed))
    truth = node_paths(config, rng) if paths is None else check_paths(config, paths)
    if not (isinstance(report_sigma, (int, float)) and math.isfinite(report_sigma) and report_sigma >= 0):
        raise ValueError(f"report_sigma must be a finite number >= 0 (m), got {report_sigma!r}")
    n_slots, k_nodes = config.N, config.K
    lo, hi = node_bounds(config) if config.motion is not None else (None, None)
    q = np.empty((n_slots, 2))
    q[0] = config.q0
    shares = np.zeros((k_nodes, n_slots))
    credited = np.zeros((k_nodes, n_slots))
    reports = np.empty((n_slots, k_nodes, 2))
    measured = np.full((k_nodes, n_slots), np.nan)
    plan_q: np.ndarray | None = None  # the incumbent's positions of every slot (N, 2)
    plan_a: np.ndarray | None = None  # the incumbent's shares (K, N)
    seconds, n_plans, n_kept = 0.0, 0, 0
    replans: list[Replan] = []
    filt: NodeFilter | None = None
    for n in range(n_slots):
        reports[n] = position_reports(truth[n], rng, report_sigma)
        t0 = time.perf_counter()
        if filt is None:
            filt = NodeFilter.start(config, reports[n], max(float(report_sigma), EXACT_SIGMA))
        else:
            filt.step(reports[n])
        estimate = filt.position if lo is None else np.clip(filt.position, lo, hi)
        replan = plan_q is None or (planner.k is not None and n % planner.k == 0 and n < n_slots - 1)
        if replan:
            pred = np.concatenate([estimate[None], filt.predict_paths(n_slots - 1 - n)])
            if lo is not None:
                pred = np.clip(pred, lo, hi)
            past = (credited[:, :n], shares[:, :n])
            rest = _rest_config(config, q[n], n, estimate)
            old = None if plan_q is None else _frame(config, past, plan_q[n:], pred)
            found: list[tuple[Schedule, np.ndarray]] = []  # (predicted frame, rest of the flight)
            names: list[str] = []  # the candidates' planners, in the order of found
            if planner.planner == "tour":
                found.append(_tour_rest(config, planner, rest, pred, past))
                names.append("tour")
            else:
                weights = None if k_nodes == 1 or old is None else old.weights
                if k_nodes > 1 and (weights is None or planner.planner == "dp-tour"):  # the tour (below)
                    found.append(_tour_rest(config, planner, rest, pred, past))
                    names.append("tour")
                    weights = found[0][0].weights if weights is None else weights
                rest_q = _dp_rest(planner, rest, pred, weights)
                if rest_q is not None:
                    found.append((_frame(config, past, rest_q, pred), rest_q))
                    names.append("dp")
            if not found and old is None:  # the tour (or no grid path in time: the tour stands in)
                found.append(_tour_rest(config, planner, rest, pred, past))
                names.append("tour")
            n_plans += 1
            # the best candidate (the first of equal values)
            best = max(range(len(found)), key=lambda i: found[i][0].value) if found else None
            new = None if best is None else found[best]
            replaced = new is not None and (old is None or new[0].value > old.value)
            replans.append(Replan(
                slot=n, incumbent=None if old is None else float(old.value),
                candidates={name: float(f[0].value) for name, f in zip(names, found, strict=True)},
                kept=names[best] if replaced and best is not None else "incumbent",
            ))  # fmt: skip
            if replaced:
                assert new is not None
                plan_q = np.concatenate([q[:n], new[1]])
                plan_a, n_kept = new[0].shares, n_kept + 1
            elif old is not None:
                plan_a = old.shares
            else:  # the first plan of the flight found no route: nothing to fly
                raise RuntimeError(f"{planner.name}: no plan at slot {n} (the inner planner found no route)")
        assert plan_q is not None and plan_a is not None
        shares[:, n] = plan_a[:, n]
        if n + 1 < n_slots:
            q[n + 1] = plan_q[n + 1]
        here = ie.node_rates(config, q[n : n + 1], estimate[None])[:, 0]
        seconds += time.perf_counter() - t0
        # every node's sample is drawn (the stream does not depend on the shares); the served keep theirs
        sample = measured_rates(
            config, np.repeat(q[n : n + 1], k_nodes, axis=0), np.repeat(truth[n : n + 1], k_nodes, axis=0),
            np.arange(k_nodes), rng,
        )  # fmt: skip
        served = shares[:, n] > SERVED_SHARE
        measured[served, n] = sample[served]
        credited[:, n] = here if planner.credit == "model" else np.nan_to_num(measured[:, n])
    score = ie.score_plan(config, q, shares if k_nodes > 1 else None, paths=truth, best_schedule=False)
    return OnlineResult(
        scheme=planner.name, trajectory=q, shares=shares, score=score, seconds=seconds,
        n_plans=n_plans, n_kept=n_kept, paths=truth, reports=reports, measured=measured,
        replans=tuple(replans),
    )  # fmt: skip
