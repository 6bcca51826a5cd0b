"""Benchmark of the energy planners: energy efficiency, time and % of the certified bound.

Usage
-----
``python benchmarks/energy.py``                      default scenario (T = 150 s, M = 6000, IOS)
``python benchmarks/energy.py --surfaces ios ris none``   the same for each surface
``python benchmarks/energy.py --budgets 0.8 0.9 1.0``     also the budget DP: rate vs E_max
``python benchmarks/energy.py --agents agents/models/ppo_IOSUAV-Energy-v0``   and a trained agent's row

Per surface, one row per planner (``dp-ee``: the grid DP with Dinkelbach, ``baselines.dp_energy``
at the rate DP's grid; ``sca-ee``: ``baselines.sca_energy`` when it can be imported; ``loiter``
and ``hover``: ``baselines.loiter``; ``dp``: the rate DP's plan scored for EE): the energy
efficiency (bits/J), the energy (J), the average rate, the % of DP-EE, the % of the certified
bound of ``baselines.energy_bound`` (when it can be imported), feasibility and wall time. With
``--budgets`` (fractions of the rate DP plan's energy), the budget DP's rate, energy, dual bound
and gap per budget. ``--agents`` adds one row per run or model folder (the ``rl`` extra): its
deterministic episode in its own env (``agents.loading.load_numpy_agent``) on the same scenario,
scored by the same ``score_plan``; its seconds are the episode's wall time, env included.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from baselines import dp, dp_energy, loiter  # noqa: E402
from baselines.plan import Plan  # noqa: E402
from ios_uav_env import ScenarioConfig  # noqa: E402


def _optional(module: str):
    try:
        return __import__(module, fromlist=["solve"])
    except ImportError as exc:
        print(f"({module} unavailable: {exc})")
        return None


def _timed(name: str, fn) -> Plan | str:
    try:
        plan = fn()
    except Exception as exc:  # a benchmark reports failures instead of stopping
        return f"failed: {type(exc).__name__}: {exc}"
    plan.scheme = name
    return plan


def agent_plan(path: str, config: ScenarioConfig) -> Plan:
    """The deterministic episode of the agent in ``path`` on ``config``, in its own env."""
    import gymnasium as gym

    from agents.loading import load_numpy_agent
    from ios_uav_env.envs.rollout import run_episode

    policy = load_numpy_agent(path)
    # the scenario's own fields over the id's registered ones (e.g. its surface)
    overrides = {"surface": config.surface, "objective": config.objective}
    env = gym.make(policy.env_id, config=config, **{**policy.env_kwargs, **overrides})
    if env.unwrapped.config != config:
        raise ValueError(f"the agent's env flies {env.unwrapped.config}, not the scenario {config}")
    episode = run_episode(env, policy, seed=0)
    return Plan.from_trajectory(Path(path).name, config, episode.trajectory, episode.seconds)


def surface_table(config: ScenarioConfig, resolution: float, agents: tuple[str, ...] = ()) -> None:
    """Print every planner's (and agent's) EE, energy, rate, % of DP-EE, % of the bound,
    feasibility, time."""
    sca, bound_module = _optional("baselines.sca_energy"), _optional("baselines.energy_bound")
    plans = {
        "dp-ee": _timed("dp-ee", lambda: dp_energy.solve_ee(config, resolution=resolution)),
        "loiter": _timed("loiter", lambda: loiter.loiter(config)),
        "hover": _timed("hover", lambda: loiter.hover(config)),
        "dp": _timed(
            "dp", lambda: dp.solve(config.replace(objective="rate"), resolution=resolution).scored_on(config)
        ),
    }
    if sca is not None:
        plans["sca-ee"] = _timed("sca-ee", lambda: sca.solve(config))
    for path in agents:
        plans[Path(path).name] = _timed(Path(path).name, lambda p=path: agent_plan(p, config))
    ref = plans["dp-ee"].energy_efficiency if isinstance(plans["dp-ee"], Plan) else float("nan")
    bound, bound_s = float("nan"), float("nan")
    if bound_module is not None:
        found = [p for p in plans.values() if isinstance(p, Plan)]
        t0 = time.perf_counter()
        try:
            best = max(found, key=lambda p: p.energy_efficiency) if found else None
            bound = float(bound_module.solve(config, reference=best).upper_bound)
        except Exception as exc:
            print(f"bound failed: {type(exc).__name__}: {exc}")
        bound_s = time.perf_counter() - t0
    print(
        f"{config.surface.upper()}: T = {config.T:g} s, N = {config.N}, M = {config.M}, "
        f"grid {resolution:g} m; "
        f"certified EE bound {bound:.2f} bits/J ({bound_s:.1f} s)"
    )
    head = (
        f"{'planner':>7} {'EE (bits/J)':>12} {'energy (J)':>11} {'rate':>9} {'% DP-EE':>8} {'% bound':>8} "
        f"{'feasible':>9} {'seconds':>8}"
    )
    print(head)
    print("-" * len(head))
    for name, plan in plans.items():
        if not isinstance(plan, Plan):
            print(f"{name:>7} {plan}")
            continue
        ee = plan.energy_efficiency
        print(
            f"{name:>7} {ee:12.2f} {plan.energy:11.1f} {plan.mean_rate:9.6f} {100 * ee / ref:8.3f} "
            f"{100 * ee / bound:8.3f} {'yes' if plan.feasible else 'NO':>9} {plan.seconds:8.2f}"
        )
    print()


def budget_table(config: ScenarioConfig, resolution: float, fractions: list[float]) -> None:
    """Print the budget DP's rate, energy, dual bound and gap for budgets = fractions x the rate
    DP plan's energy (clipped below at the scenario's least energy)."""
    rate_plan = dp.solve(config, resolution=resolution)
    print(
        f"budget DP ({config.surface.upper()}), E_rate = {rate_plan.energy:.1f} J: the rate DP plan's energy"
    )
    head = (
        f"{'E_max/E_rate':>12} {'rate':>9} {'energy (J)':>11} {'dual bound':>11} {'gap %':>8} {'seconds':>8}"
    )
    print(head)
    print("-" * len(head))
    for f in fractions:
        budget = max(f * rate_plan.energy, config.least_energy())
        plan = _timed("dp-budget", lambda b=budget: dp_energy.solve_budget(config, b, resolution=resolution))
        if not isinstance(plan, Plan):
            print(f"{f:12.3f} {plan}")
            continue
        print(
            f"{f:12.3f} {plan.mean_rate:9.6f} {plan.energy:11.1f} {plan.info['dual_bound']:11.6f} "
            f"{100 * plan.info['dual_gap']:8.4f} {plan.seconds:8.2f}"
        )
    print()


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--T", type=float, default=150.0, help="mission duration T (s), default 150")
    p.add_argument("--surfaces", nargs="+", default=["ios"], choices=["ios", "ris", "none"])
    p.add_argument("--resolution", type=float, default=2.5, help="DP grid spacing (m), default 2.5")
    p.add_argument("--budgets", type=float, nargs="*", default=[], help="budgets as fractions of E_rate")
    p.add_argument("--agents", nargs="*", default=[], help="run or model folders to add as rows (rl extra)")
    args = p.parse_args(argv)
    for surface in args.surfaces:
        config = ScenarioConfig(T=args.T, surface=surface, objective="energy_efficiency")
        surface_table(config, args.resolution, tuple(args.agents))
        if args.budgets:
            budget_table(config.replace(objective="rate"), args.resolution, args.budgets)
    return 0


if __name__ == "__main__":
    sys.exit(main())
