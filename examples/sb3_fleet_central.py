"""PPO (Stable-Baselines3) as one controller of several UAVs: the fleet's Gymnasium form.

Run:  python examples/sb3_fleet_central.py [--steps 400000] [--uavs 2] [--envs 8] [--seed 0]

``ios_uav_env.envs.fleet.FleetCentralEnv`` (the fleet of ``ios_uav_env.parallel_env``: the agents'
observations and actions concatenated, the team reward) on the recipe's scenario of
``examples/torchrl_mappo_fleet.py`` (three nodes, a 20 x 12 surface, 60 slots), ``--envs`` copies
in a ``DummyVecEnv`` with SB3's ``VecNormalize``. At the end the deterministic policy flies one
episode and its team max-min rate is printed as a share of the centralised planner's plan and of
its certified bound (``baselines.fleet``) on the same fleet.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import VecNormalize

from ios_uav_env.envs.fleet_central import FleetCentralEnv

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # baselines/ runs from a checkout
from baselines.fleet import MARL_SCENARIO, learner_report  # noqa: E402

#: The MARL recipes' scenario (``baselines.fleet.MARL_SCENARIO``).
CONFIG = MARL_SCENARIO


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=400_000, help="env steps to train for")
    parser.add_argument("--uavs", type=int, default=2, help="U, the number of UAVs")
    parser.add_argument("--envs", type=int, default=8, help="env copies in the DummyVecEnv")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    kwargs = {"config": CONFIG, "uavs": args.uavs, "best_schedule": False}
    venv = VecNormalize(make_vec_env(FleetCentralEnv, n_envs=args.envs, seed=args.seed, env_kwargs=kwargs))
    model = PPO("MlpPolicy", venv, n_steps=512, batch_size=1024, learning_rate=3e-4, gamma=0.995,
                seed=args.seed, verbose=0)  # fmt: skip
    start = time.perf_counter()
    model.learn(args.steps)
    seconds = time.perf_counter() - start
    venv.training = False
    env = FleetCentralEnv(CONFIG, uavs=args.uavs)
    obs, _ = env.reset(seed=args.seed)
    done = False
    while not done:
        action, _ = model.predict(venv.normalize_obs(obs), deterministic=True)
        obs, _, done, _, infos = env.step(action)
    info = infos["uav_0"]
    trained = f"trained {args.steps} steps in {seconds:.0f} s"
    print(learner_report("PPO (central)", CONFIG, args.uavs, info["min_rate"], info["feasible"], trained))
    return {"min_rate": info["min_rate"]}


if __name__ == "__main__":
    main()
