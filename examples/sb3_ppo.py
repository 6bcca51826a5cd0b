"""Stable-Baselines3 PPO on an ios_uav_env id: check the env, train briefly, evaluate one episode.

Run:  python examples/sb3_ppo.py --steps 2048 [--env ios_uav_env/IOSUAV-Random-v0] [--seed 0]
SB3's env checker, PPO on two vectorised copies of the id, then one deterministic episode whose
final ``info`` (average rate, feasibility) is printed. Needs the ``rl`` extra.
"""

from __future__ import annotations

import argparse

import gymnasium as gym
from stable_baselines3 import PPO
from stable_baselines3.common.env_checker import check_env
from stable_baselines3.common.env_util import make_vec_env

import ios_uav_env


def evaluate(model: PPO, env_id: str, seed: int) -> dict:
    """Run one deterministic episode and return its last ``info``."""
    env = gym.make(env_id)
    obs, info = env.reset(seed=seed)
    terminated = truncated = False
    while not (terminated or truncated):
        action, _ = model.predict(obs, deterministic=True)
        obs, _, terminated, truncated, info = env.step(action)
    env.close()
    missing = set(ios_uav_env.INFO_KEYS) - set(info)
    if missing:
        raise RuntimeError(f"info lacks {sorted(missing)}")
    return info


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="ios_uav_env/IOSUAV-v0")
    parser.add_argument("--steps", type=int, default=2048, help="training timesteps")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    check_env(gym.make(args.env).unwrapped)
    venv = make_vec_env(args.env, n_envs=2, seed=args.seed)
    model = PPO("MlpPolicy", venv, n_steps=128, batch_size=64, n_epochs=2, gamma=0.999, seed=args.seed)
    model.learn(total_timesteps=args.steps)
    venv.close()

    info = evaluate(model, args.env, args.seed)
    print(
        f"{args.env}: average rate {info['average_rate']:.3f} bps/Hz, feasible {bool(info['feasible'])}, "
        f"{int(info['slot'])} slots, {info['distance_to_final']:.1f} m from qF"
    )
    return info


if __name__ == "__main__":
    main()
