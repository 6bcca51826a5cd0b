"""Stable-Baselines3 PPO on an ios_uav_env id: check the env, train briefly, evaluate one episode.

Run:  python examples/sb3_ppo.py --steps 2048 [--env ID [ID ...]] [--seed 0]
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


def train_and_evaluate(env_id: str, steps: int, seed: int) -> dict:
    """SB3's env checker, PPO for ``steps`` timesteps, then one evaluation episode; its last info."""
    check_env(gym.make(env_id).unwrapped)
    venv = make_vec_env(env_id, n_envs=2, seed=seed)
    model = PPO("MlpPolicy", venv, n_steps=128, batch_size=64, n_epochs=2, gamma=0.999, seed=seed)
    model.learn(total_timesteps=steps)
    venv.close()
    info = evaluate(model, env_id, seed)
    print(
        f"{env_id}: average rate {info['average_rate']:.3f} bps/Hz, feasible {bool(info['feasible'])}, "
        f"{int(info['slot'])} slots, {info['distance_to_final']:.1f} m from qF"
    )
    return info


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", nargs="+", default=["ios_uav_env/IOSUAV-v0"], help="one or more ids")
    parser.add_argument("--steps", type=int, default=2048, help="training timesteps")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    return [train_and_evaluate(env_id, args.steps, args.seed) for env_id in args.env]


if __name__ == "__main__":
    main()
