"""How far a shipped model's replayed episode moves under float32 noise of the size another CPU
makes, against how far a real regression moves it: the measurement behind ``tests/tolerances.py``.

    python benchmarks/replay_tolerance.py [--ulps 4 64] [--seeds 6]
    python benchmarks/replay_tolerance.py --multi-node-mobile [--ulps 4 64] [--seeds 6]

For each shipped agent every action is multiplied by 1 + u, u uniform within +-U float32 ulps
and redrawn each call (what different float32 kernels do to the same weights), and the episode
is compared with the rate and terminal miss recorded when the model shipped (``summary.json``);
then every observation is scaled by 1 + 1e-3 (a changed normalisation). Prints the worst relative
rate deviation and the worst miss deviation (m) of each, and whether the tolerances of
``tests/tolerances.py`` hold the noise and break on the regression. The multi-node generalist
(``dagger_IOSUAV-MultiNode-Random-v0``) is replayed as its test replays it: the first 8
scenarios of ``multi-node-v1`` (``Suite.subset(8)``) against the rates of its recorded suite
table (``suite_report.csv``); its plans have no terminal miss (a plan is feasible or not).

``--multi-node-mobile``: the multi-node agent with memory (``MULTI_MOBILE``), whose single episodes
move by several % under that noise, is measured as its test replays it: the deviation (points)
of its mean % of the optimum over all of ``multi-node-mobile-v1`` from the unperturbed mean,
against ``MULTI_MOBILE_MEAN_ABS``.
"""

from __future__ import annotations

import argparse
import csv
import functools
import json
import sys
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # agents/ and tests/ from a checkout

from agents.evaluate import MODELS_DIR, SHIPPED  # noqa: E402
from agents.loading import load_agent  # noqa: E402
from agents.rollout import rollout  # noqa: E402
from tests.tolerances import MISS_ABS, MULTI_MOBILE_MEAN_ABS, NORMALISATION_CHANGE, RATE_REL  # noqa: E402

AGENTS = (*SHIPPED, "ppo_IOSUAV-MultiNode-v0")
#: The multi-node generalist, replayed on suite scenarios (see the module docstring).
GENERALIST = "dagger_IOSUAV-MultiNode-Random-v0"
#: How many of ``multi-node-v1``'s scenarios its replay covers (the test's subset).
GENERALIST_SCENARIOS = 8
#: The multi-node agent with memory, replayed on all of multi-node-mobile-v1 (module docstring).
MULTI_MOBILE = "ppo_memory_IOSUAV-MultiNode-Mobile-v0"


class _Perturbed:
    """``agent`` with its actions jittered by ``ulps`` float32 ulps, or its observations scaled."""

    def __init__(self, agent: Any, *, ulps: float = 0.0, scale: float = 0.0, seed: int = 0) -> None:
        self.agent, self.ulps, self.scale = agent, ulps, scale
        self.rng = np.random.default_rng(seed)
        self.env_id, self.env_kwargs = agent.env_id, agent.env_kwargs

    def act(self, obs: np.ndarray) -> np.ndarray:
        a = np.asarray(self.agent.act(obs * (1.0 + self.scale)), dtype=np.float32)
        noise = 1.0 + self.ulps * float(np.finfo(np.float32).eps) * self.rng.uniform(-1, 1, a.shape)
        return (a * noise).astype(np.float32)


def deviation(agent: Any, record: dict[str, float], **perturbation: Any) -> tuple[float, float]:
    """(relative rate deviation, miss deviation in m) of one perturbed episode from the record."""
    episode = rollout(_Perturbed(agent, **perturbation))
    rate = abs(episode.average_rate / record["average_rate"] - 1.0)
    return rate, abs(episode.terminal_miss - record["terminal_miss"])


def suite_record() -> dict[int, float]:
    """The generalist's recorded rate on each scenario of its suite table, by scenario index."""
    with (MODELS_DIR / GENERALIST / "suite_report.csv").open() as table:
        return {int(r["index"]): float(r["rate"]) for r in csv.DictReader(table)}


def suite_deviation(agent: Any, recorded: dict[int, float], **perturbation: Any) -> tuple[float, float]:
    """(worst relative rate deviation, 0.0: no miss) of the generalist's perturbed plans on the
    replayed suite scenarios from ``recorded`` (:func:`suite_record`); an infeasible plan counts
    as inf."""
    from agents.evaluate_multi import fast_act
    from agents.suite.multi import suite_env_kwargs
    from ios_uav_env.benchmark import load_suite
    from ios_uav_env.benchmark.scoring import evaluate_scenarios

    suite = load_suite("multi-node-v1")
    fast = SimpleNamespace(act=fast_act(agent), env_id=agent.env_id, env_kwargs=agent.env_kwargs)
    rows = evaluate_scenarios(
        _Perturbed(fast, **perturbation).act, suite, suite.subset(GENERALIST_SCENARIOS),
        suite_env_kwargs(agent, 4), 0, GENERALIST,
    ).scenarios  # fmt: skip
    worst = max(abs(r.rate / recorded[r.index] - 1.0) if r.feasible else float("inf") for r in rows)
    return worst, 0.0


def multi_mobile_mean(agent: Any, **perturbation: Any) -> float:
    """The mean % of the optimum over multi-node-mobile-v1 of ``agent`` (the numpy export, its
    memory beside it) with ``perturbation`` (:class:`_Perturbed`'s arguments)."""
    from ios_uav_env.benchmark import evaluate

    perturbed = _Perturbed(agent, **perturbation)
    results = evaluate(perturbed.act, "multi-node-mobile-v1", env_kwargs=agent.env_kwargs, name=MULTI_MOBILE)
    return float(results.aggregate.stats["mean_pct_optimum"])


def multi_mobile(ulps: list[float], seeds: int) -> None:
    """Print the ``--multi-node-mobile`` measurement (module docstring)."""
    from agents.loading import load_numpy_agent

    agent = load_numpy_agent(MODELS_DIR / MULTI_MOBILE)
    base = multi_mobile_mean(agent)
    print(f"{MULTI_MOBILE}: mean {base:.2f} % of the optimum; tolerance {MULTI_MOBILE_MEAN_ABS:g} points")
    for u in ulps:
        worst = max(abs(multi_mobile_mean(agent, ulps=u, seed=s) - base) for s in range(seeds))
        print(f"  {u:g} ulps: mean moved by up to {worst:.2f} points "
              f"({'held' if worst <= MULTI_MOBILE_MEAN_ABS else 'NOT held'})")  # fmt: skip
    moved = abs(multi_mobile_mean(agent, scale=NORMALISATION_CHANGE) - base)
    print(f"  obs x (1 + {NORMALISATION_CHANGE:g}): mean moved by {moved:.2f} points")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--ulps", type=float, nargs="+", default=[4.0, 64.0], help="jitter sizes (float32 ulps)")
    p.add_argument("--seeds", type=int, default=6, help="jitter draws per size (default 6)")
    p.add_argument("--multi-node-mobile", action="store_true", help=f"measure {MULTI_MOBILE} only")
    args = p.parse_args(argv)
    if args.seeds < 1 or any(u <= 0 for u in args.ulps):
        p.error("--seeds must be >= 1 and every --ulps > 0")
    if args.multi_node_mobile:
        multi_mobile(args.ulps, args.seeds)
        return 0
    print(f"tolerances: rate {RATE_REL:g} relative, terminal miss {MISS_ABS:g} m")
    for name in (*AGENTS, GENERALIST):
        agent = load_agent(MODELS_DIR / name)
        replay: Callable[..., tuple[float, float]]
        if name == GENERALIST:
            replay = functools.partial(suite_deviation, recorded=suite_record())
        else:
            record = json.loads((MODELS_DIR / name / "summary.json").read_text())["final_eval"]
            replay = functools.partial(deviation, record=record)
        cells = []
        for ulps in args.ulps:
            worst = np.max([replay(agent, ulps=ulps, seed=s) for s in range(args.seeds)], axis=0)
            held = worst[0] <= RATE_REL and worst[1] <= MISS_ABS
            cells.append(
                f"{ulps:g} ulps: rate {worst[0]:.1e}, miss {worst[1]:.1e} ({'held' if held else 'NOT held'})"
            )
        rate, miss = replay(agent, scale=NORMALISATION_CHANGE)
        caught = rate > RATE_REL or miss > MISS_ABS
        cells.append(f"obs x (1 + {NORMALISATION_CHANGE:g}): rate {rate:.1e}, miss {miss:.1e} "
                     f"({'caught' if caught else 'NOT caught'})")  # fmt: skip
        print(f"{name}: " + "; ".join(cells))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
