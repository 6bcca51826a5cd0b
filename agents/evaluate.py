"""Evaluate trained agents against the planners on one scenario: table (markdown + CSV) and figure.

Each agent is rolled out deterministically (``agents.rollout``, ``ios_uav_env.envs.rollout.run_episode``):
its trajectory is checked with ``check_trajectory`` and scored with ``average_rate``, exactly
like the planners' plans (SCA "ia", DP, "ia-ft", "cuc") on the same
``ScenarioConfig``. Under the Rician channel every trajectory, agent's or planner's, is replayed
through the env with ``channel="rician"`` for seeds 0..K-1 (the same seed gives every scheme
the same fading draws) and the mean and standard deviation of its faded average rate reported.

    python -m agents.evaluate --shipped                     # shipped agents vs planners (make demo)
    python -m agents.evaluate runs/<run> agents/models/ppo_IOSUAV-v0 --scenario T:100
    python -m agents.evaluate runs/<multi-node run>     # vs SCA, tour and the bound (agents.evaluate_multi)

A folder that already holds a comparison (``comparison.md``, ``.csv``, ``.png``) is refused
before any agent loads or planner runs unless ``--overwrite`` is given.

Models trained on a multi-node id (``ios_uav_env/IOSUAV-MultiNode-v0`` or ``-Random-v0``) are
compared on the 3-node scenario (``--scenario`` fields applied to it) by
:mod:`agents.evaluate_multi`: their own min rate, the best schedule of their trajectory, SCA,
the tour heuristic and the certified bound (cached), and the shares figure.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from agents.loading import Agent, load_agent
from agents.report import Row
from agents.rollout import rollout, run_seeds
from ios_uav_env import ScenarioConfig

MODELS_DIR = Path(__file__).resolve().parent / "models"
#: The shipped agents (folders of agents/models), in table order.
SHIPPED: tuple[str, ...] = ("ppo_IOSUAV-v0", "sac_IOSUAV-v0", "ppo_IOSUAV-v0_noguard")
PLANNERS: tuple[str, ...] = ("dp", "ia", "ia-ft", "cuc")
PLANNER_LABELS = {"dp": "DP (2.5 m grid)", "ia": "SCA (IA)", "ia-ft": "IA-FT", "cuc": "CUC (SCA)"}


def planner_rows(config: ScenarioConfig, schemes: Sequence[str] = PLANNERS) -> list[Row]:
    """Run each planner scheme on ``config`` (surface set by the scheme, as in the paper)."""
    from baselines.schemes import available, run_scheme

    rows = []
    for name in schemes:
        if not available(name):
            print(f"skipping {name}: its planner is not available here", file=sys.stderr)
            continue
        plan = run_scheme(name, config)
        rows.append(
            Row(PLANNER_LABELS.get(name, name), "planner", plan.mean_rate, plan.feasible, plan.seconds,
                plan.trajectory, plan.config, terminal_miss=plan.report.end_error)
        )  # fmt: skip
    return rows


def agent_row(agent: Agent, config: ScenarioConfig) -> Row:
    """Roll ``agent`` out deterministically on ``config`` (its own env kwargs, e.g. the guard)."""
    episode = rollout(agent, config)
    e = episode
    return Row(agent.name, "agent", e.average_rate, e.feasible, e.seconds, e.trajectory, config,
               terminal_miss=e.terminal_miss)  # fmt: skip


def faded_replay(config: ScenarioConfig, trajectory: np.ndarray, seeds: int) -> np.ndarray:
    """Mean faded rates of ``trajectory`` replayed through the env (``channel="rician"``, no
    guard), one per seed 0 .. seeds - 1 (all at once, in the batched env)."""
    moves = np.diff(np.asarray(trajectory, dtype=float), axis=0) / config.D
    slot = iter(range(len(moves)))

    def replay(obs: np.ndarray) -> np.ndarray:  # every row flies the same moves
        return np.broadcast_to(moves[next(slot)], (len(obs), 2))

    replay.batched = True  # type: ignore[attr-defined]
    kwargs = {"channel": "rician", "arrival_guard": False}
    episodes = run_seeds(replay, config, "ios_uav_env/IOSUAV-v0", kwargs, seeds)
    return np.array([e.mean_faded_rate for e in episodes])


def add_rician(rows: list[Row], agents: dict[str, Agent], seeds: int) -> None:
    """Fill ``faded_mean`` / ``faded_std`` over ``seeds`` Rician episodes for every row.

    Agents run in their own env with ``channel="rician"``; planners' trajectories are replayed.
    Each row's episodes run at once in the batched env (row s: seed s).
    """
    for row in rows:
        if row.kind == "agent":
            agent = agents[row.scheme]
            kwargs = {**agent.env_kwargs, "channel": "rician"}
            episodes = run_seeds(agent, row.config, agent.env_id, kwargs, seeds)
            samples = [e.mean_faded_rate for e in episodes]
        else:
            samples = faded_replay(row.config, row.trajectory, seeds)
        row.faded_mean, row.faded_std = float(np.mean(samples)), float(np.std(samples))


def compare(
    agents: Sequence[Agent],
    config: ScenarioConfig | None = None,
    schemes: Sequence[str] = PLANNERS,
    rician_seeds: int = 20,
) -> list[Row]:
    """The comparison table's rows: planners first, then the agents, on ``config``."""
    config = config or ScenarioConfig()
    rows = planner_rows(config, schemes)
    rows += [agent_row(agent, config) for agent in agents]
    dp = next((r.average_rate for r in rows if r.scheme == PLANNER_LABELS["dp"]), None)
    for row in rows:
        if dp:
            row.pct["dp"] = 100.0 * row.rate / dp
    if rician_seeds > 0:
        add_rician(rows, {a.name: a for a in agents}, rician_seeds)
    return rows


def shipped_agents(names: Sequence[str] = SHIPPED) -> list[Agent]:
    """Load the shipped agents of ``agents/models`` that exist."""
    return [load_agent(MODELS_DIR / name) for name in names if (MODELS_DIR / name / "model.zip").exists()]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m agents.evaluate", description=__doc__.splitlines()[0])
    parser.add_argument("models", nargs="*", help="run or model folders (model.zip + config.json)")
    parser.add_argument("--shipped", action="store_true", help="evaluate the agents shipped in agents/models")
    parser.add_argument(
        "--schemes", nargs="*", default=list(PLANNERS), help="planner schemes to compare with"
    )
    parser.add_argument(
        "--scenario",
        nargs="*",
        default=None,
        metavar="KEY:VALUE",
        help="ScenarioConfig fields, e.g. T:100 ios_shape:(100,40)",
    )
    parser.add_argument("--rician-seeds", type=int, default=20, help="Rician episodes per scheme (0: none)")
    parser.add_argument("--out", type=Path, default=Path("out/agents"), help="folder of the table and figure")
    parser.add_argument("--overwrite", action="store_true", help="replace a comparison in --out")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    from agents.evaluate_multi import COMPARISON_FILES
    from agents.hyperparams import parse_env_kwargs
    from agents.report import markdown_table, save_comparison_figure, save_table_csv
    from ios_uav_env.benchmark.outputs import claim, remove_stale

    parser = build_parser()
    args = parser.parse_args(argv)
    if not args.models and not args.shipped:
        parser.error("give model folders or --shipped")
    try:
        config = ScenarioConfig(**parse_env_kwargs(args.scenario))
    except (TypeError, ValueError) as exc:
        parser.error(f"argument --scenario: {exc}")
    if args.rician_seeds < 0:
        parser.error(f"argument --rician-seeds: must be >= 0, got {args.rician_seeds}")
    try:  # before any agent loads or any planner runs
        previous = claim(args.out, COMPARISON_FILES, args.overwrite)
    except FileExistsError as exc:
        parser.error(f"argument --out: {exc}")
    try:
        agents = [load_agent(path) for path in args.models]
    except (FileNotFoundError, ValueError) as exc:
        parser.error(f"argument models: {exc}")
    if args.shipped:
        agents += shipped_agents()
    from agents.evaluate_multi import DEFAULT_MULTI, check_agents, is_multinode
    from agents.evaluate_multi import run as run_multi

    multi = [a.name for a in agents if is_multinode(a)]
    if multi:
        if len(multi) < len(agents):
            parser.error(
                f"argument models: multi-node agents {multi} cannot share a table with single-node ones"
            )
        try:  # the scenario and the agents' max_nodes, before any reference is solved
            multi_config = DEFAULT_MULTI.replace(**parse_env_kwargs(args.scenario))
            check_agents(agents, multi_config)
        except (TypeError, ValueError) as exc:
            parser.error(f"argument --scenario: {exc}")
        run_multi(agents, multi_config, args.out, overwrite=args.overwrite)
        return 0
    rows = compare(agents, config, args.schemes, args.rician_seeds)
    table = markdown_table(rows)
    print(table)
    for agent in agents:
        summary = agent.meta.get("summary", {})
        if summary:
            print(
                f"{agent.name}: trained {summary['steps']} steps in {summary['wall_time_s']:.0f} s "
                f"({summary['steps_per_s']:.0f} steps/s)"
            )
    from ios_uav_env.io import atomic_write_text

    written = [atomic_write_text(args.out / "comparison.md", table + "\n"),
               save_table_csv(rows, args.out / "comparison.csv")]  # fmt: skip
    print(f"table: {written[0]}, {written[1]}")
    written.append(save_comparison_figure(rows, config, args.out / "comparison.png"))
    print(f"figure: {written[-1]}")
    remove_stale(previous, written)
    return 0


if __name__ == "__main__":
    sys.exit(main())
