"""rl-baselines3-zoo on an ios_uav_env id: train with the repo's zoo YAML, then replay with enjoy.

Run (from the repository root):  python examples/rl_zoo3_train.py --steps 512 [--algo sac] [--env ...]
Runs ``python -m rl_zoo3.train --gym-packages ios_uav_env --conf-file agents/hyperparams/<algo>.yml``
with a tiny budget into a temporary log folder, then ``python -m rl_zoo3.enjoy --no-render``.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# Tiny overrides so that a CI run takes seconds; drop them for a real run.
TINY = {
    "ppo": ["n_envs:2", "n_steps:64", "batch_size:64", "n_epochs:1"],
    "sac": ["learning_starts:64", "batch_size:32"],
}


def run(cmd: list[str]) -> None:
    """Echo and run one zoo command from the repository root (the YAML names agents.* classes)."""
    print("+", " ".join(cmd), flush=True)
    subprocess.run(cmd, cwd=ROOT, check=True)


def main(argv: list[str] | None = None) -> Path:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="ios_uav_env/IOSUAV-v0")
    parser.add_argument("--algo", default="ppo", choices=sorted(TINY))
    parser.add_argument("--steps", type=int, default=512, help="training timesteps (-n of rl_zoo3.train)")
    parser.add_argument("--enjoy-steps", type=int, default=200, help="steps replayed by rl_zoo3.enjoy")
    parser.add_argument("--log-folder", type=Path, default=None, help="default: a temporary folder")
    args = parser.parse_args(argv)

    log_folder = args.log_folder or Path(tempfile.mkdtemp(prefix="ios_uav_zoo_"))
    common = ["--algo", args.algo, "--env", args.env, "--gym-packages", "ios_uav_env", "-f", str(log_folder)]
    run(
        [sys.executable, "-m", "rl_zoo3.train", *common, "--seed", "0", "-n", str(args.steps),
         "--conf-file", f"agents/hyperparams/{args.algo}.yml", "--hyperparams", *TINY[args.algo],
         "--eval-freq", "-1", "--log-interval", "-1"]
    )  # fmt: skip
    run([sys.executable, "-m", "rl_zoo3.enjoy", *common, "--exp-id", "0", "--no-render",
         "-n", str(args.enjoy_steps), "--deterministic"])  # fmt: skip
    models = sorted(log_folder.rglob(f"{args.env.replace('/', '-')}.zip"))
    if not models:
        raise RuntimeError(f"rl_zoo3.train saved no model under {log_folder}")
    print(f"model: {models[-1]}")
    return models[-1]


if __name__ == "__main__":
    main()
