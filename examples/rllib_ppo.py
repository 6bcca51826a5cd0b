"""RLlib's PPO (the new API stack) on an ios_uav_env id, registered with Ray Tune's env registry.

Run:  python examples/rllib_ppo.py --iters 1 [--env ios_uav_env/IOSUAV-Random-v0] [--address HOST:6379]
``register_env`` names a creator that imports ``ios_uav_env`` (so that every RLlib env runner,
in any process of the cluster, registers the ids) and ``gym.make``s the id; PPO trains for
``--iters`` iterations with small batches (one episode is 149 steps) on a local Ray of
``--num-cpus`` CPUs, or the cluster at ``--address``, and prints each iteration's episode
return mean.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from typing import Any

import gymnasium as gym
import ray
from ray.rllib.algorithms.ppo import PPOConfig
from ray.tune.registry import register_env

ENV_NAME = "ios_uav_env_rllib"


def make_env(env_config: dict[str, Any]) -> gym.Env:
    """RLlib's env creator: ``env_config`` holds the id and the env's keyword arguments."""
    import ios_uav_env  # noqa: F401  (registers the ids in this process)

    kwargs = dict(env_config)
    return gym.make(kwargs.pop("id"), **kwargs)


def main(argv: list[str] | None = None) -> list[float]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="ios_uav_env/IOSUAV-v0")
    parser.add_argument("--iters", type=int, default=1, help="training iterations")
    parser.add_argument("--batch", type=int, default=320, help="env steps per iteration")
    parser.add_argument("--num-cpus", type=int, default=2, help="CPUs of the local Ray")
    parser.add_argument("--address", default=None, help="a running Ray cluster (default: a local Ray)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    start = time.perf_counter()
    if args.address is None:  # a new local instance, on the loopback interface only (single-node mode)
        os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"
        ray._private.ray_constants.ENABLE_RAY_CLUSTER = False
        ray.init(address="local", num_cpus=args.num_cpus, include_dashboard=False, log_to_driver=False)
    else:
        ray.init(address=args.address, log_to_driver=False)
    print(f"ray.init: {time.perf_counter() - start:.1f} s")
    register_env(ENV_NAME, make_env)
    config = (
        PPOConfig()
        .api_stack(enable_rl_module_and_learner=True, enable_env_runner_and_connector_v2=True)
        .environment(ENV_NAME, env_config={"id": args.env})
        .env_runners(num_env_runners=0, rollout_fragment_length=args.batch)
        .training(train_batch_size_per_learner=args.batch, minibatch_size=64, num_epochs=2, lr=3e-4)
        .learners(num_learners=0)
        .debugging(seed=args.seed)
    )
    algo = config.build_algo()
    returns = []
    try:
        for i in range(args.iters):
            result = algo.train()
            runners = result.get("env_runners", {})
            mean = float(runners.get("episode_return_mean", math.nan))
            returns.append(mean)
            steps = int(runners.get("num_env_steps_sampled_lifetime", 0))
            episodes = int(runners.get("num_episodes_lifetime", 0))
            print(f"{args.env}: iteration {i + 1}, {steps} env steps, {episodes} episodes, "
                  f"episode return mean {mean:.3f}")  # fmt: skip
    finally:
        algo.stop()
        ray.shutdown()
    print(f"done in {time.perf_counter() - start:.1f} s")
    return returns


if __name__ == "__main__":
    main()
