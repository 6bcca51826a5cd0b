r"""A multi-antenna UAV serving K users at once (SDMA): dp-miso-sdma's plan polished off the grid by
block-coordinate (alternating) optimisation with a trust-region SCA step on a continuous trajectory.

The scenario and its score are ``baselines.dp_miso_sdma``'s: N_t >= 2 antennas, K in [2, 4]
static users, an IOS of at most ``model.miso_sdma.MAX_ELEMENTS`` elements, and the flight's
max-min V(q) with time sharing of the per-slot settings P(q[n]) that ``score_plan`` credits (the
weighted-sum AO at the lattice weights and each user alone, ``model.miso_sdma``). :func:`solve`
starts from dp-miso-sdma's plan (or a given feasible flight) and alternates two blocks:

1. **The schedule** (the weights and time shares). The regions problem of the flight's settings
   (``regions.maxmin_regions`` with the exact pricer ``miso_sdma.sdma_pricer``, what
   ``sdma_maxmin`` solves) gives the time shares and its dual weights w*: V(q) <=
   (1/N) sum_n f_{w*}(q[n]) for every flight, f_w(p) = max_{R in P(p)} w . R, with equality to the
   solver's tolerance at the current flight (weak duality, ``dp_miso_sdma``'s "The dual").
2. **The trajectory.** One trust-region SCA step on (1/N) sum_n f_{w*}(q[n])
   (``baselines.trust_region``: the first-order model under the speed limit with fixed ends, the
   solver's overshoot of the speed limit repaired towards the straight line). f_w
   is a maximum over the J + K settings, each the slot's AO from fixed starts at its lattice weight,
   so (envelope) its gradient at q[n] is that of the active setting's w* . R_j (the first of
   largest w* . R_j at q[n]); it is taken by central finite differences of step ``fd_step`` m along
   x and y, the active setting re-optimised at each displaced position (``miso_sdma.slot_setting``
   at its lattice weight, or the user alone, ``miso.tdma_rates``): one AO per probe, not J + K.
3. **The test.** The candidate is scored by ``score_plan`` (feasibility by ``check_trajectory``
   inside it, every slot's settings re-optimised at the new positions): accepted only if feasible
   and higher, else the trust radius shrinks. The run stops on the radius floor, ``patience``
   rejections in a row, ``max_rounds`` rounds or ``max_seconds`` seconds of this stage.

**Guarantees.** Only feasible flights that score higher are accepted, so the plan is never below
the start (dp-miso-sdma's plan: never below the grid DP). Being a feasible flight, it is never above
``dp_miso_sdma.sdma_bound`` (every beam set and surface setting, interference-free), carried from
the start plan or computed at ``bound_resolution``; ``info["gap"]`` is the bound over the plan,
minus one. It is a local method: the first-order model carries no curvature and the AO's settings
are local optima from fixed starts; the trust region does the globalisation.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from baselines.plan import Plan
from baselines.registry import check as check_planner
from baselines.trust_region import ascend, checked_region, positive
from ios_uav_env import ScenarioConfig, check_trajectory, score_plan
from ios_uav_env.model.miso import tdma_rates
from ios_uav_env.model.miso_sdma import (
    check_sdma_scenario,
    sdma_pricer,
    slot_channel_at,
    slot_points,
    slot_setting,
    weight_lattice,
)
from ios_uav_env.model.regions import maxmin_regions

__all__ = [
    "FD_STEP", "MAX_ROUNDS", "MAX_SECONDS", "MIN_RADIUS", "PATIENCE", "RADIUS", "active_settings",
    "gradients", "solve",
]  # fmt: skip

#: m, the central finite difference's step of f_w's gradient.
FD_STEP = 0.5
#: m, the default initial trust radius, and its floor (below it the run stops).
RADIUS = 5.0
MIN_RADIUS = 0.05
#: Default caps on rounds, on rejections in a row and on the ascent's seconds.
MAX_ROUNDS = 30
PATIENCE = 6
MAX_SECONDS = 600.0


def active_settings(points: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(N,) the index j of each slot's first setting of largest w . R_j among ``points``
    (N, J + K, K), the lattice settings then the users alone (``miso_sdma.slot_points``' order)."""
    return np.argmax(np.asarray(points, dtype=float) @ np.asarray(w, dtype=float), axis=1)


def gradients(
    config: ScenarioConfig, q: np.ndarray, w: np.ndarray, active: np.ndarray, step: float = FD_STEP
) -> np.ndarray:
    """(N, 2): the central finite differences (step ``step`` m) of w . R_j at every way-point of
    ``q``, j = ``active``[n] the slot's active setting (module docstring), re-optimised at each of
    the four displaced positions; the ends' rows are zero (they do not move)."""
    lattice = weight_lattice(config.K)
    w = np.asarray(w, dtype=float)
    shifts = step * np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
    grad = np.zeros((len(q), 2))
    for n in range(1, len(q) - 1):
        values = np.empty(4)
        for i, shift in enumerate(shifts):
            channel = slot_channel_at(config, q[n] + shift)
            solo = tdma_rates(channel)
            j = int(active[n])
            if j < len(lattice):
                values[i] = float(w @ slot_setting(channel, lattice[j], solo))
            else:
                values[i] = float(w[j - len(lattice)] * solo[j - len(lattice)])
        grad[n] = [(values[0] - values[1]) / (2 * step), (values[2] - values[3]) / (2 * step)]
    return grad


def _check(config: ScenarioConfig) -> None:
    check_planner("ao-miso-sdma", config)
    try:
        check_sdma_scenario(config)
    except ValueError as exc:
        raise ValueError(f"ao-miso-sdma: {exc}; score_plan scores SDMA flights only there") from None


def solve(
    config: ScenarioConfig,
    start: Plan | np.ndarray | None = None,
    *,
    resolution: float = 12.5,
    bound_resolution: float | None = None,
    max_rounds: int = MAX_ROUNDS,
    max_seconds: float = MAX_SECONDS,
    radius: float = RADIUS,
    min_radius: float = MIN_RADIUS,
    max_radius: float | None = None,
    patience: int = PATIENCE,
    fd_step: float = FD_STEP,
    solver: str = "CLARABEL",
    dp_options: dict[str, Any] | None = None,
    progress: bool = False,
) -> Plan:
    """AO/SCA from dp-miso-sdma's plan (module docstring): the best flight met and its history.

    ``start``: a ``Plan`` (e.g. dp-miso-sdma's; its ``info["upper_bound"]`` is carried when it is
    dp-miso-sdma's plan of this very config, the only plan whose bound certifies it) or a feasible
    (N, 2) flight; None runs ``dp_miso_sdma.solve(config, resolution, **dp_options)``.
    ``bound_resolution``: the relaxed DP's cell side (m) of ``sdma_bound`` when the start carries no
    bound (default ``resolution`` / 2). ``radius``, ``min_radius``, ``max_radius`` (default D): the
    trust region's initial radius, floor and cap (m); ``max_rounds``, ``patience``, ``max_seconds``:
    the ascent's budget (rounds, rejections in a row, seconds); ``fd_step``: the gradient's
    finite-difference step (m); ``solver``: cvxpy's.

    ``history``: one record per round (weights, radius, status, candidate score, predicted
    first-order gain, accepted). ``info``: ``start_rate``, ``upper_bound`` (certified, >= every
    feasible flight's score), ``bound_weights``, ``gap`` (upper_bound / mean_rate - 1),
    ``rounds``, ``accepted``, ``stop`` (why it stopped), ``start_seconds`` (the start plan's),
    ``bound_seconds``, ``fd_step``. ``seconds``: this call's wall time, the start's and the bound's
    included when it runs them.
    """
    t0 = time.perf_counter()
    _check(config)
    region = checked_region(config, max_rounds=max_rounds, patience=patience, radius=radius,
                            min_radius=min_radius, max_radius=max_radius, fd_step=fd_step)  # fmt: skip
    fd_step = region.pop("fd_step")
    max_seconds = positive("max_seconds", max_seconds)
    from baselines import dp_miso_sdma

    start_info: dict[str, Any] = {}
    if start is None:
        start = dp_miso_sdma.solve(
            config, resolution, bound_resolution=bound_resolution, **(dp_options or {})
        )
    if isinstance(start, Plan):
        start_info = {"seconds": start.seconds}
        if start.scheme == "dp-miso-sdma" and start.config == config:  # its bound certifies this config
            start_info.update(
                upper_bound=start.info.get("upper_bound"), bound_weights=start.info.get("bound_weights")
            )
        start = start.trajectory
    q = np.asarray(start, dtype=float)
    if q.shape != (config.N, 2) or not check_trajectory(config, q).feasible:
        raise ValueError(f"start must be a feasible (N = {config.N}, 2) flight (check_trajectory)")
    score = score_plan(config, q).rate
    t1 = time.perf_counter()

    def model(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        points, _ = slot_points(config, q)
        w = maxmin_regions(sdma_pricer(points), config.K, tol=1e-9).dual_weights
        return w, gradients(config, q, w, active_settings(points, w), fd_step)

    def evaluate(cand: np.ndarray) -> tuple[bool, float]:
        scored = score_plan(config, cand)
        return scored.feasible, scored.rate

    run = ascend(config, q, score, model, evaluate, **region, max_seconds=max_seconds, solver=solver,
                 repair=True, name="ao-miso-sdma", progress=progress)  # fmt: skip
    ascent_seconds = time.perf_counter() - t1
    upper, bound_w, bound_seconds = start_info.get("upper_bound"), start_info.get("bound_weights"), 0.0
    if upper is None:
        t2 = time.perf_counter()
        h = resolution / 2 if bound_resolution is None else bound_resolution
        upper, w_ub, _, _ = dp_miso_sdma.sdma_bound(config, h)
        bound_w, bound_seconds = w_ub.tolist(), time.perf_counter() - t2
    info = {
        "start_rate": score,
        "upper_bound": float(upper),
        "bound_weights": bound_w,
        "gap": float(upper) / run.score - 1.0 if run.score > 0 else math.inf,
        "rounds": len(run.history),
        "accepted": run.accepted,
        "stop": run.stop,
        "start_seconds": start_info.get("seconds", 0.0),
        "ascent_seconds": ascent_seconds,
        "bound_seconds": bound_seconds,
        "fd_step": fd_step,
    }
    seconds = time.perf_counter() - t0
    return Plan.from_trajectory(
        "ao-miso-sdma", config, run.trajectory, seconds, history=run.history, info=info
    )
