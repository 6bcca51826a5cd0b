"""``python -m ios_uav_env``: one episode of the env with a simple heuristic, scored and drawn.

The heuristic heads for the reachable rate peak (``ios_uav_env.rate_peak``) and hovers there; the arrival
guard (on by default) bends the path so that the UAV still reaches qF at slot N. It prints
the episode's average rate (eq. (9)) and its eq. (10) feasibility report next to the plain
straight line q0 -> qF at constant speed, and saves the last rendered frame.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import gymnasium as gym
import numpy as np

import ios_uav_env  # noqa: F401  (registers the ids)
from ios_uav_env.envs.policies import HoverAt
from ios_uav_env.envs.registration import ENV_IDS
from ios_uav_env.envs.rendering import save_png
from ios_uav_env.envs.rollout import Episode, run_episode
from ios_uav_env.model.config import ScenarioConfig
from ios_uav_env.model.trajectory import average_rate, check_trajectory

ID_OF_SURFACE = {kwargs["surface"]: env_id for env_id, kwargs in ENV_IDS.items()}
DOCS_FRAME = Path("docs/demo_frame.png")
DOCS_FRAME_MAX_BYTES = 150_000


def straight_line(config: ScenarioConfig) -> np.ndarray:
    """q0 -> qF at constant speed over the N slots (feasible whenever the config is)."""
    return np.linspace(config.q0, config.qF, config.N)


def demo_episode(env_id: str, seed: int) -> tuple[Episode, np.ndarray]:
    """Roll out the hover heuristic once; return the episode and its last frame."""
    policy = HoverAt("peak")
    env = gym.make(env_id, render_mode="rgb_array", **policy.env_kwargs)
    episode = run_episode(env, policy, seed=seed)
    frame = env.render()
    env.close()
    return episode, frame


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m ios_uav_env", description=__doc__.splitlines()[0])
    parser.add_argument(
        "--surface", choices=tuple(ID_OF_SURFACE), default="ios", help="which fixed env id (default: ios)"
    )
    parser.add_argument("--seed", type=int, default=0, help="reset seed (default: 0)")
    parser.add_argument("--out", type=Path, default=Path("out/demo.png"), help="PNG of the last frame")
    parser.add_argument(
        "--docs-frame", action="store_true", help=f"also write a small copy of the frame to {DOCS_FRAME}"
    )
    args = parser.parse_args(argv)

    env_id = ID_OF_SURFACE[args.surface]
    start = time.perf_counter()
    episode, frame = demo_episode(env_id, args.seed)
    seconds = time.perf_counter() - start
    config = ScenarioConfig(surface=args.surface)
    print(f"{env_id}: M = {config.M}, N = {config.N} slots, D = {config.D:g} m, seed {args.seed}")
    print(f"heuristic (fly to the reachable rate peak, hover, guard to qF), {seconds:.2f} s:")
    print(f"  average rate (eq. 9)  {episode.average_rate:.4f} bps/Hz   return {episode.episode_return:.4f}")
    print(f"  feasibility (eq. 10)  {check_trajectory(episode.config, episode.trajectory)}")
    print(f"straight line q0 -> qF: average rate {average_rate(config, straight_line(config)):.4f} bps/Hz")
    print(f"frame: {save_png(frame, args.out)}")
    if args.docs_frame:
        path = save_png(frame, DOCS_FRAME)
        if path.stat().st_size > DOCS_FRAME_MAX_BYTES:  # keep the README light: use a palette
            path = save_png(frame, DOCS_FRAME, colors=256)
        print(f"docs frame: {path} ({path.stat().st_size / 1024:.0f} KB)")
    return 0 if episode.feasible else 1


if __name__ == "__main__":
    sys.exit(main())
