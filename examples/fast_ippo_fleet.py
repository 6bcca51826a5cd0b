"""IPPO with shared parameters on several UAVs, on the fast trainer (``agents.fast.fleet``).

Run:  python examples/fast_ippo_fleet.py [--steps 2000000] [--fleets 128] [--seed 0] [--out runs/x]

Trains the recipe ``agents/hyperparams/fast_ippo_fleet.yml`` (two UAVs on
``baselines.fleet.MARL_SCENARIO``): ``FastPPO`` on ``--fleets`` fleets of
``ios_uav_env.envs.fleet_vector.FleetVectorEnv``, every agent a row of one policy with its
fleet's team reward, and writes the run folder a fast run writes (``agents.fast.fleet_run``).
At the end the deterministic policy flies the fleet of ``ios_uav_env.parallel_env`` and its team
max-min rate is printed as a share of the centralised planner's plan and of its certified bound
(``baselines.fleet.learner_report``), as ``examples/sb3_ippo_fleet.py`` prints SB3's.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # agents/ and baselines/ run from a checkout
from agents.fast.fleet_run import FleetSettings, train_fleet  # noqa: E402
from agents.training.interrupt import TrainingInterrupted  # noqa: E402
from baselines.fleet import learner_report  # noqa: E402


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=None, help="agent steps (default: the recipe's)")
    parser.add_argument(
        "--fleets", type=int, default=None, help="fleets stepped at once (default: the recipe's)"
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=None, help="run folder (default: runs/fleet_ippo__<seed>__<time>)")
    parser.add_argument("--hyperparams", default=None, help="recipe file (default: fast_ippo_fleet.yml)")
    parser.add_argument("--env-threads", type=int, default=1, help="the fleets' kernel threads (default 1)")
    parser.add_argument("--threads", type=int, default=None, help="torch threads (default 1)")
    parser.add_argument("--eval-freq", type=int, default=0, help="agent steps between evaluations (0: end)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    settings = FleetSettings(
        timesteps=args.steps, seed=args.seed, n_envs=args.fleets, out=args.out,
        hyperparams_file=args.hyperparams, env_threads=args.env_threads, threads=args.threads,
        eval_freq=args.eval_freq, progress_bar=not args.no_progress,
    )  # fmt: skip
    try:
        result = train_fleet(settings)
    except TrainingInterrupted as exc:  # its checkpoint is saved; a fleet run is not resumed
        print(f"stopped at step {exc.steps_at_signal}: saved checkpoint {exc.checkpoint}", file=sys.stderr)
        raise SystemExit(exc.exit_status) from None
    summary, final = result.summary, result.summary["final_eval"]
    env = settings.hyperparams()[2].parallel_env()
    config, uavs = env.config, len(env.possible_agents)
    env.close()
    trained = (
        f"trained {summary['steps']} agent steps in {summary['wall_time_s']:.0f} s "
        f"({summary['steps_per_s']:.0f} steps/s), run {result.run_dir}"
    )
    print(
        learner_report(
            "IPPO (fast trainer, shared)", config, uavs, final["score"], final["feasible"], trained
        )
    )
    return {"min_rate": final["score"], "run_dir": str(result.run_dir)}


if __name__ == "__main__":
    main()
