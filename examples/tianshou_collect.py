"""Tianshou on an ios_uav_env id: a Collector fills a replay buffer with whole episodes and their info.

Run:  python examples/tianshou_collect.py --episodes 4 [--env ID [ID ...]]
Two ``DummyVectorEnv`` copies of the id, a random-action policy, ``Collector(..., VectorReplayBuffer)``
with Tianshou's NaN check on; asserts the buffer holds every key of the env's info, all finite.
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np
from tianshou.algorithm.algorithm_base import RandomActionPolicy
from tianshou.data import Collector, VectorReplayBuffer
from tianshou.env import DummyVectorEnv

import ios_uav_env


def collect(env_id: str, episodes: int, num_envs: int, seed: int) -> VectorReplayBuffer:
    """Collect ``episodes`` random-action episodes of ``env_id`` into a buffer and check its info."""
    envs = DummyVectorEnv([lambda: gym.make(env_id) for _ in range(num_envs)])
    envs.seed(seed)
    policy = RandomActionPolicy(envs.action_space[0])
    buffer = VectorReplayBuffer(total_size=400 * episodes, buffer_num=num_envs)
    collector = Collector(policy, envs, buffer, raise_on_nan_in_buffer=True)
    collector.reset()
    stats = collector.collect(n_episode=episodes)
    envs.close()

    if stats.n_collected_episodes != episodes or len(buffer) != stats.n_collected_steps:
        raise RuntimeError(f"collected {stats.n_collected_episodes} episodes, buffer holds {len(buffer)}")
    batch, _ = buffer.sample(0)  # the whole buffer
    missing = [k for k in ios_uav_env.INFO_KEYS if k not in batch.info]
    if missing:
        raise RuntimeError(f"the buffer's info lacks {missing}")
    for key in ios_uav_env.INFO_KEYS:
        values = np.asarray(batch.info[key], dtype=np.float64)
        if values.shape[0] != len(buffer) or not np.isfinite(values).all():
            raise RuntimeError(f"info[{key!r}] in the buffer: shape {values.shape}, not all finite")
    ends = batch.info["slot"][batch.terminated]
    print(
        f"{env_id}: {stats.n_collected_episodes} episodes, {len(buffer)} transitions, mean return "
        f"{stats.returns_stat.mean:.2f}, mean rate {np.mean(batch.info['rate']):.3f} bps/Hz, "
        f"final slots {sorted(int(s) for s in ends)}"
    )
    return buffer


def main(argv: list[str] | None = None) -> list[VectorReplayBuffer]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", nargs="+", default=["ios_uav_env/IOSUAV-v0"], help="one or more ids")
    parser.add_argument("--episodes", type=int, default=4)
    parser.add_argument("--num-envs", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    return [collect(env_id, args.episodes, args.num_envs, args.seed) for env_id in args.env]


if __name__ == "__main__":
    main()
