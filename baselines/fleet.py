r"""Several UAVs: a centralised plan of U separated flights and a certified bound of their max-min.

The problem is ``ios_uav_env.model.fleet``'s: U UAVs in orthogonal bands share one IOS and serve
the scenario's K static nodes; UAV u flies from ``starts[u]`` to ``finals[u]`` in its own N_u
slots (its horizon, ``horizons[u]`` = N_u dt; default the scenario's N) at most D_u per slot, no
two UAVs closer than ``min_separation`` while both fly (``model.separation``), and the team
maximises the nodes' max-min rate over the scenario's N slots with time sharing in every slot
(``fleet_maxmin``, the one scorer of a fleet's flights, whoever planned them); a UAV past its
horizon serves nothing (``model.fleet_horizons``).

**The bound** (``baselines.fleet_bound``, proved there): min over node weights w of the UAVs'
single-UAV relaxed DP bounds, each scaled by its share of the slots.

**The plans.** Candidates, each scored by ``fleet_maxmin`` and kept only if separated all along
(``flights_separated``) and feasible for every UAV over its own slots:
(i) at each Kelley w, every UAV's plain grid DP path on f_w over its N_u slots (the bound's dual
plans, as ``dp_bound.solve_multinode``'s); (ii) node covers: each UAV flies the tour
heuristic (``baselines.tour``) over the nodes it covers on its own scenario (straight to its
final point if none; a node may be covered by several UAVs, which then share it), starting from
each node's nearest lane and improved by adding a node to or taking one from one UAV at a time
while the score rises (every node covered); (iii) the best cover's tours polished by a pattern
search on their hover points (one point of one UAV moved 40, 20, 10 then 5 m along an axis or a
diagonal while the fleet's value rises; ``baselines.fleet_candidates``); (iv) the best of them
refined by block-coordinate SCA (``baselines.fleet_sca.refine``: the exact schedule, then one SCA
step per UAV's flight with the others and the schedule fixed, accepted only if feasible,
separated and not worse; each UAV's way-points over its own N_u slots), kept if it scores
higher. The best candidate is returned with the bound; ``gap`` says how far it may be from the
optimum.
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from baselines.fleet_bound import dual_flights, fleet_bound
from baselines.fleet_candidates import guarded_flights, nearest_lanes, polish_routes
from baselines.grid import DEFAULT_MARGIN, validate_grid_args
from ios_uav_env import ScenarioConfig
from ios_uav_env.model.fleet import ACCESS, fleet_maxmin, fleet_setup
from ios_uav_env.model.fleet_horizons import flights_feasibility, hold_flights, horizon_slots
from ios_uav_env.model.separation import DEFAULT_SEPARATION, flights_separated

__all__ = ["MARL_SCENARIO", "FleetPlan", "fleet_bound", "guarded_flights", "learner_report", "solve"]


@dataclass
class FleetPlan:
    """U flights ``trajectories`` (U, N, 2) m, their max-min rate ``value`` (bps/Hz,
    ``fleet_maxmin``), the certified ``upper_bound`` (>= every separated fleet's value) and how
    they were found (``info``)."""

    config: ScenarioConfig
    trajectories: np.ndarray
    value: float
    upper_bound: float
    solve_seconds: float
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def gap(self) -> float:
        """upper_bound / value - 1 (inf for a plan of value 0 below a positive bound)."""
        if self.value > 0:
            return self.upper_bound / self.value - 1.0
        return 0.0 if self.upper_bound <= 0 else math.inf


def _tour_flight(
    config: ScenarioConfig, nodes: tuple[int, ...]
) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
    """One UAV's flight and its route: the tour over ``nodes`` of ``config`` (its own start, final
    point and horizon) with its hover points and hover slots, or the straight flight to its final
    point (no route) for no node."""
    from baselines import tour

    if not nodes:
        return np.linspace(config.q0, config.qF, config.N), None
    plan = tour.solve(config.replace(ground_nodes=tuple(config.nodes[k] for k in nodes)))
    points = np.array(plan.info["hover_points"], dtype=float).reshape(-1, 2)
    return plan.trajectory, (points, np.array(plan.info["hover_slots"], dtype=float))


#: Default most rounds of block-coordinate SCA on the best plan (``baselines.fleet_sca``).
SCA_ITERATIONS = 5


def solve(
    config: ScenarioConfig,
    *,
    uavs: int = 2,
    starts: Any = None,
    finals: Any = None,
    min_separation: float = DEFAULT_SEPARATION,
    resolution: float = 5.0,
    bound_resolution: float | None = None,
    margin: float = DEFAULT_MARGIN,
    max_cuts: int = 15,
    tol: float = 1e-3,
    local_moves: int = 30,
    access: str = "orthogonal",
    speeds: Any = None,
    horizons: Any = None,
    polish_steps: tuple[float, ...] = (40.0, 20.0, 10.0, 5.0),
    polish_budget: int | None = None,
    sca_iterations: int = SCA_ITERATIONS,
    progress: bool = False,
) -> FleetPlan:
    """The best separated fleet found and the certified bound (module docstring).

    ``uavs``, ``starts``, ``finals``, ``min_separation``, ``speeds``, ``horizons``: the fleet
    (defaults: the env's lanes, every UAV the scenario's T; ``ios_uav_env.parallel_env``); the
    returned ``trajectories`` are (U, N, 2), each UAV held at its final point after its horizon
    (``model.fleet_horizons``), scored with its slot count; ``resolution``: the plain DP grid
    (m); ``bound_resolution``: the relaxed DP's cells (default ``resolution``); ``max_cuts``,
    ``tol``: Kelley's iterations and relative gap; ``local_moves``: most covers tried after the
    first; ``polish_steps``: the steps (m) of the pattern search on the best cover's hover points
    (empty: none), ``polish_budget`` the most flights it scores (None: until no step helps);
    ``sca_iterations``: most rounds of block-coordinate SCA on the best plan (0: none; each UAV's
    way-points over its own horizon);
    ``access``: orthogonal bands or one shared band (the plans are scored with its interference;
    the bound, interference-free, holds for both). The fleet's arguments are
    checked by ``model.fleet.fleet_setup``. ``info``: ``source`` (which candidate won), ``cover``
    (the nodes each UAV tours, for a tour candidate), ``weights`` (the bound's w),
    ``kelley_lower``, ``cuts``, ``candidates`` (scored, separated), ``rejected`` (candidates that
    were not separated), ``horizons`` (s, each UAV's), ``sca`` (the refinement's value before and
    after, its rounds and why it stopped; None without it)."""
    t0 = time.perf_counter()
    if isinstance(sca_iterations, bool) or not isinstance(sca_iterations, int) or sca_iterations < 0:
        raise ValueError(f"sca_iterations must be an integer >= 0, got {sca_iterations!r}")
    if not isinstance(config, ScenarioConfig):
        raise TypeError(f"config must be a ScenarioConfig, got {type(config).__name__}")
    if polish_budget is not None and (
        isinstance(polish_budget, bool) or not isinstance(polish_budget, int) or polish_budget < 0
    ):
        raise ValueError(
            f"polish_budget must be None or an integer >= 0 (flights scored), got {polish_budget!r}"
        )
    if config.objective != "rate" or config.motion is not None or config.energy_budget_j is not None:
        raise ValueError(
            "the fleet planner maximises the max-min rate of static nodes: objective='rate', motion=None, "
            f"energy_budget_j=None; got objective={config.objective!r}, motion={config.motion!r}, "
            f"energy_budget_j={config.energy_budget_j!r}"
        )
    starts_, finals_, configs = fleet_setup(
        config, uavs, starts, finals, min_separation, access, speeds, horizons
    )
    points, slots, n_slots = [starts_, finals_], horizon_slots(configs), config.N
    for c in configs:
        validate_grid_args(c, resolution, margin)
    h = resolution if bound_resolution is None else bound_resolution

    scored: list[tuple[float, str, np.ndarray, Any]] = []
    rejected: list[str] = []
    seen: dict[bytes, float] = {}  # each candidate's value (-inf: rejected), by its flights' bytes

    def consider(source: str, flights: np.ndarray | None, assignment: Any = None) -> float:
        if flights is None:
            return -math.inf
        key = flights.tobytes()
        if key in seen:
            return seen[key]
        seen[key] = -math.inf
        feasible = flights_feasibility(configs, flights)[0]  # each UAV over its own slots
        if feasible and not flights_separated(flights, min_separation, slots):
            repaired = guarded_flights(configs, flights, points[1], min_separation)
            if repaired is not None and not np.array_equal(repaired, flights):
                consider(f"{source}-guarded", repaired, assignment)
            feasible = False
        if not feasible:
            rejected.append(source)
            return -math.inf
        value = fleet_maxmin(config, flights, access=access, slots=slots).value
        seen[key] = value
        scored.append((value, source, flights, assignment))
        if progress:
            print(f"[fleet] {source}: {value:.6f} bps/Hz")
        return value

    # (i) the bound's dual plans, at every w Kelley tries
    weights_tried: list[np.ndarray] = []
    upper, w_best, lower, records = fleet_bound(
        configs, resolution=h, margin=margin, max_cuts=max_cuts, tol=tol, on_weights=weights_tried.append,
        slots=n_slots,
    )  # fmt: skip
    for i, w in enumerate(weights_tried):
        consider(f"dual-dp{i}", dual_flights(configs, w, resolution, margin, n_slots))
    # (ii) tours over the nodes each UAV covers (a node may be covered by several), from the
    # nearest lanes' partition, one node added to or taken from one UAV at a time
    tours: dict[tuple[int, tuple[int, ...]], tuple[np.ndarray, Any]] = {}

    def covering(cover: tuple[tuple[int, ...], ...]) -> np.ndarray:
        for u, nodes in enumerate(cover):
            if (u, nodes) not in tours:
                tours[(u, nodes)] = _tour_flight(configs[u], nodes)
        return hold_flights([tours[(u, nodes)][0] for u, nodes in enumerate(cover)], n_slots)

    lanes_of = nearest_lanes(configs)
    current = tuple(tuple(k for k in range(config.K) if lanes_of[k] == u) for u in range(len(configs)))
    value = consider(f"tour{current}", covering(current), current)
    u_n, everyone = len(configs), set(range(config.K))

    def neighbours(cover: tuple[tuple[int, ...], ...]) -> list[tuple[tuple[int, ...], ...]]:
        """Covers one step away: node k moved from one UAV to another, added or taken away."""
        out = []
        for k, u, v in itertools.product(range(config.K), range(u_n), range(u_n)):
            sets = [set(nodes) for nodes in cover]
            if u == v:
                sets[u] ^= {k}  # add or take away
            elif k in sets[u] and k not in sets[v]:
                sets[u].discard(k)
                sets[v].add(k)  # move
            else:
                continue
            if set().union(*sets) >= everyone:  # every node covered by some UAV
                out.append(tuple(tuple(sorted(nodes)) for nodes in sets))
        return out

    tried = 0
    improved = True
    while improved and tried < local_moves:
        improved = False
        for trial in neighbours(current):
            if tried >= local_moves:
                break
            tried += 1
            got = consider(f"tour{trial}", covering(trial), trial)
            if got > value:
                current, value, improved = trial, got, True
                break
    # (iii) the best cover's tours polished: their hover points moved while the value rises
    if polish_steps and current is not None:
        polished_from = value

        tries = itertools.count()

        def score(flights: np.ndarray) -> float:
            return consider(f"polished{next(tries)}", flights, current)

        routes = [tours[(u, nodes)][1] for u, nodes in enumerate(current)]
        polish_routes(covering(current), routes, configs, tuple(polish_steps), score, polish_budget)
    else:
        polished_from = None
    if not scored:
        raise ValueError(
            f"no candidate fleet keeps min_separation = {min_separation:g} m all along ({len(rejected)} "
            "rejected): give lanes further apart or a smaller separation"
        )
    best = max(scored, key=lambda s: s[0])
    sca = None
    if sca_iterations:  # (iv) block-coordinate SCA of the best plan, each UAV over its own slots
        from baselines.fleet_sca import refine

        got = refine(config, best[2], access=access, min_separation=min_separation, speeds=speeds,
                     horizons=horizons, iterations=sca_iterations, progress=progress)  # fmt: skip
        sca = {"from": best[0], "value": got.value, "rounds": got.rounds, "stop": got.stop,
               "seconds": got.seconds}  # fmt: skip
        if got.value > best[0]:
            best = (got.value, f"{best[1]}-sca", got.trajectories, best[3])
    info = {
        "source": best[1], "cover": None if best[3] is None else [list(nodes) for nodes in best[3]],
        "weights": w_best.tolist(),
        "kelley_lower": lower, "cuts": records, "candidates": {s: v for v, s, _, _ in scored},
        "rejected": rejected, "resolution": float(resolution), "bound_resolution": float(h),
        "polished_from": polished_from, "sca": sca,
        "starts": points[0].tolist(), "finals": points[1].tolist(), "min_separation": float(min_separation),
        "horizons": [c.T for c in configs],
    }  # fmt: skip
    return FleetPlan(config, best[2], best[0], upper, time.perf_counter() - t0, info)


#: The MARL recipes' scenario (``examples/torchrl_mappo_fleet.py``, ``sb3_ippo_fleet.py``,
#: ``sb3_fleet_central.py``): the multi-node env's three nodes, a 20 x 12 surface and a 60-slot
#: mission, so that a recipe trains in minutes on a laptop CPU.
MARL_SCENARIO = ScenarioConfig(
    ground_nodes=((-100.0, -20.0), (150.0, -60.0), (-40.0, 90.0)), ios_shape=(20, 12), T=60.0,
    q0=(-200.0, 20.0), qF=(200.0, 20.0),
)  # fmt: skip


def learner_report(
    label: str, config: ScenarioConfig, uavs: int, min_rate: float, feasible: bool, trained: str
) -> str:
    """The line a learner's recipe prints: its team max-min rate as a share of this planner's plan
    and of its certified bound on the same fleet (``solve(config, uavs=uavs)``)."""
    plan = solve(config, uavs=uavs)
    return (
        f"{label}, U = {uavs}: min rate {min_rate:.4f} bps/Hz (feasible {bool(feasible)}), "
        f"{100 * min_rate / plan.value:.1f} % of the planner ({plan.value:.4f}), "
        f"{100 * min_rate / plan.upper_bound:.1f} % of the bound ({plan.upper_bound:.4f}); {trained}"
    )


def main(argv: list[str] | None = None) -> None:
    """``python -m baselines.fleet``: plan U UAVs on the multi-node env's scenario and print the
    plan's max-min rate, the certified bound, the gap and the compute."""
    import argparse

    from ios_uav_env.model.scenarios import DEFAULT_NODES

    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument(
        "--uavs", type=int, nargs="+", default=[1, 2, 3], help="fleet sizes U (default: 1 2 3)"
    )
    parser.add_argument(
        "--resolution", type=float, default=5.0, help="DP grid and bound cells, m (default: 5)"
    )
    parser.add_argument("--separation", type=float, default=DEFAULT_SEPARATION, help="min_separation, m")
    parser.add_argument("--access", choices=ACCESS, nargs="+", default=["orthogonal"], help="spectrum access")
    parser.add_argument(
        "--plot", type=Path, default=None, help="draw the last plan here (PNG; not overwritten)"
    )
    parser.add_argument(
        "--no-polish", action="store_true", help="skip the pattern search on the hover points"
    )
    parser.add_argument(
        "--horizons", type=float, nargs="+", default=None, metavar="S",
        help="each UAV's horizon, s (one per UAV, or one for every UAV; default: the scenario's T)",
    )  # fmt: skip
    parser.add_argument(
        "--sca-iterations", type=int, default=SCA_ITERATIONS,
        help=f"most rounds of block-coordinate SCA on the best plan, 0 for none (default: {SCA_ITERATIONS})",
    )  # fmt: skip
    args = parser.parse_args(argv)
    steps = () if args.no_polish else (40.0, 20.0, 10.0, 5.0)
    if args.plot is not None and args.plot.exists():
        parser.error(f"--plot {args.plot} exists: give a new path (shipped figures are never overwritten)")
    config = ScenarioConfig(ground_nodes=DEFAULT_NODES)
    if args.horizons is not None:
        for u in args.uavs:
            try:
                fleet_setup(config, u, horizons=args.horizons)
            except ValueError as err:
                parser.error(f"--horizons with --uavs {u}: {err}")
        print(f"horizons: {' '.join(f'{h:g}' for h in args.horizons)} s (the scenario's T = {config.T:g} s)")
    print("| U | access | plan (bps/Hz) | bound | gap | source | s |\n|---|---|---:|---:|---:|---|---:|")
    for u in args.uavs:
        for access in args.access:
            plan = solve(
                config, uavs=u, resolution=args.resolution, min_separation=args.separation, access=access,
                polish_steps=steps, horizons=args.horizons, sca_iterations=args.sca_iterations,
            )  # fmt: skip
            print(
                f"| {u} | {access} | {plan.value:.4f} | {plan.upper_bound:.4f} | {100 * plan.gap:.1f} % "
                f"| {plan.info['source']} | {plan.solve_seconds:.1f} |"
            )
    if args.plot is not None:
        from ios_uav_env.plotting import figure_image, plot_fleet, save_png

        def draw(ax: Any) -> None:
            slots = [round(h / config.dt) for h in plan.info["horizons"]]
            plot_fleet(ax, config, [f[:n] for f, n in zip(plan.trajectories, slots, strict=True)])
            title = f"U = {len(plan.trajectories)}, {plan.value:.4f} bps/Hz (bound {plan.upper_bound:.4f})"
            ax.set_title(title, fontsize=9)

        print(f"plot: {save_png(figure_image(draw), args.plot)}")


if __name__ == "__main__":
    main()
