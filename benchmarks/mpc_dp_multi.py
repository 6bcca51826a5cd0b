"""MPC on the frozen ``multi-node-mobile-v1`` scenarios, against the suite's stored rows.

    python benchmarks/mpc_dp_multi.py [--k 10] [--planner dp-tour|dp|tour] [--oracle] [--plans F.npz]
        [--trace] [IDX ...]

Per scenario (all 24 by default, or the indices given) one episode of ``MPC(k, planner)``
(``baselines.mpc.run_online`` at the scenario's episode seed, MPC-DP at the suite's grid,
``MPC_RESOLUTION``), scored as the suite scores its rows (``baselines.references.online.score``:
the max-min rate with the planner's own shares on the true paths), printed as % of the stored
optimum next to the stored ``mpc_dp_k<k>`` row (k = 1 or 10) and ``mpc_k10``, with the re-plans
made and kept; then the mean / 10th percentile / minimum of each column over the scenarios run.

``--oracle``: the planner is given the true future paths in place of the Kalman filter's
estimate and prediction (the reports and the measured rates are drawn as usual): the part of
the gap to the optimum that prediction, not planning, accounts for.

``--plans FILE.npz``: also write each episode's flight, shares and planning seconds
(``baselines.mpc.OnlineResult.seconds``) as a trajectories file of the suite, rewritten after every
scenario; the scenarios it already holds are read back and not run again (the run resumes). The
benchmark scores it as any row, ``python -m ios_uav_env.benchmark evaluate --suite
multi-node-mobile-v1 --trajectories FILE.npz`` (``docs/leaderboard.md``). Not with ``--oracle``.

``--trace``: every re-plan's predicted frame values (``OnlineResult.replans``: the incumbent's and
each candidate's on the predictions of that slot, and what was kept), then the drift of the plans
flown: each plan's predicted value at the re-plan that kept it against its value on the next
re-plan's predictions (the incumbent there), as the mean relative drop of the plans that replaced
the incumbent and of the incumbents kept.

One process; to use two cores run two with disjoint indices (and distinct ``--plans`` files).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from baselines import mpc  # noqa: E402
from baselines.references.online import MPC_RESOLUTION, score  # noqa: E402
from ios_uav_env import ScenarioConfig  # noqa: E402
from ios_uav_env.benchmark.trajectories import read_plans, write_trajectories  # noqa: E402
from ios_uav_env.model.motion import node_paths  # noqa: E402

SUITE = ROOT / "ios_uav_env" / "benchmark" / "suites" / "multi-node-mobile-v1.json"


class Oracle:
    """A stand-in for ``NodeFilter`` that knows the true paths (N, K, 2): its estimate of slot n
    is the true position, its prediction the true future."""

    def __init__(self, truth: np.ndarray) -> None:
        self.truth, self.n = truth, 0

    @property
    def position(self) -> np.ndarray:
        return self.truth[self.n]

    def step(self, reports: np.ndarray) -> None:
        self.n += 1

    def predict_paths(self, steps: int) -> np.ndarray:
        return self.truth[self.n + 1 : self.n + 1 + steps]


def episode(task: dict[str, Any], k: int, planner: str, oracle: bool) -> mpc.OnlineResult:
    """One episode of ``MPC(k, planner)`` on a stored scenario at its episode seed."""
    config = ScenarioConfig(**task["config"])
    options: dict[str, Any] = {"planner": planner, "resolution": MPC_RESOLUTION} if planner != "tour" else {}
    real = mpc.NodeFilter
    if oracle:
        truth = node_paths(config, np.random.default_rng(task["seed"]))
        mpc.NodeFilter = type("OracleFilter", (), {"start": staticmethod(lambda *a: Oracle(truth))})
    try:
        result = mpc.run_online(config, mpc.MPC(k=k, **options), task["seed"])
    finally:
        mpc.NodeFilter = real
    return result


def drift(replans: tuple[mpc.Replan, ...]) -> dict[str, list[float]]:
    """The relative drop (%) of each flown plan's predicted frame value from the re-plan that kept
    it to the next re-plan's predictions, for the plans that replaced the incumbent (the first plan
    included) and for the incumbents kept."""
    out: dict[str, list[float]] = {"replaced": [], "kept": []}
    for made, after in zip(replans, replans[1:], strict=False):
        value = made.incumbent if made.kept == "incumbent" else made.candidates[made.kept]
        if value is None or after.incumbent is None or value <= 0:
            continue
        what = "kept" if made.kept == "incumbent" else "replaced"
        out[what].append(100.0 * (value - after.incumbent) / value)
    return out


def pct_of_optimum(task: dict[str, Any], q: np.ndarray, shares: np.ndarray) -> float:
    """% of the stored optimum of a flight ``q`` with its ``shares`` on the scenario's true paths."""
    config = ScenarioConfig(**task["config"])
    truth = node_paths(config, np.random.default_rng(task["seed"]))
    return 100.0 * score(config, q, shares, truth).rate / task["optimum"]["rate"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("indices", nargs="*", type=int, help="scenario indices (default: all)")
    parser.add_argument("--k", type=int, default=10, help="slots between re-plans")
    parser.add_argument("--planner", choices=("dp-tour", "dp", "tour"), default="dp-tour")
    parser.add_argument("--oracle", action="store_true", help="plan on the true future paths")
    parser.add_argument("--plans", type=Path, default=None, help="write the flights here (.npz), resuming")
    parser.add_argument("--trace", action="store_true", help="print every re-plan's predicted frame values")
    args = parser.parse_args(argv)
    if args.trace and args.plans is not None:
        parser.error("--trace runs every episode: not with --plans")
    if args.plans is not None and (args.oracle or args.plans.suffix != ".npz"):
        parser.error("--plans is a .npz file, and not with --oracle (the flights of the online task only)")
    plans: tuple[dict[int, np.ndarray], dict[int, float], dict[int, np.ndarray]] = ({}, {}, {})
    if args.plans is not None and args.plans.exists():
        plans = read_plans(args.plans)
    tasks = json.loads(SUITE.read_text())["scenarios"]
    chosen = args.indices or list(range(len(tasks)))
    stored_row = f"mpc_dp_k{args.k}" if args.k in (1, 10) else None
    cols: dict[str, list[float]] = {"run": [], "stored": [], "mpc_k10": []}
    for i in chosen:
        task = tasks[i]
        if i in plans[0]:  # in the --plans file already
            pct, made, kept = pct_of_optimum(task, plans[0][i], plans[2][i]), -1, -1
        else:
            result = episode(task, args.k, args.planner, args.oracle)
            pct = pct_of_optimum(task, result.trajectory, result.shares)
            made, kept = result.n_plans, result.n_kept
            if args.trace:
                for r in result.replans:
                    old = "-" if r.incumbent is None else f"{r.incumbent:.4f}"
                    cands = " ".join(f"{name} {value:.4f}" for name, value in r.candidates.items())
                    print(f"    slot {r.slot:3d}: incumbent {old} | {cands} -> {r.kept}")
                for what, drops in drift(result.replans).items():
                    mean = f"{np.mean(drops):+.1f} %" if drops else "-"
                    print(f"    {what}: {len(drops)} plans, predicted value lost by the next re-plan {mean}")
            if args.plans is not None:
                plans[0][i], plans[1][i], plans[2][i] = result.trajectory, result.seconds, result.shares
                write_trajectories(args.plans, *plans, compressed=True)
        opt = task["optimum"]["rate"]
        stored = 100.0 * task[stored_row]["rate"] / opt if stored_row else float("nan")
        tour10 = 100.0 * task["mpc_k10"]["rate"] / opt
        for key, value in zip(cols, (pct, stored, tour10), strict=True):
            cols[key].append(value)
        k_nodes = len(task["config"]["ground_nodes"])
        print(f"#{i:2d} K={k_nodes} run {pct:6.2f} %  stored {stored:6.2f} %  mpc_k10 {tour10:6.2f} %  "
              f"plans {made} kept {kept}", flush=True)  # fmt: skip
    for key, values in cols.items():
        v = np.asarray(values)
        print(f"{key:8s} mean / p10 / min: {v.mean():.2f} / {np.percentile(v, 10):.2f} / {v.min():.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
