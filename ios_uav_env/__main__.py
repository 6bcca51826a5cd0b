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
from typing import Any

import gymnasium as gym
import numpy as np

import ios_uav_env  # noqa: F401  (registers the ids)
from ios_uav_env.config import SURFACES, ScenarioConfig
from ios_uav_env.peak import rate_peak
from ios_uav_env.registration import ENV_IDS
from ios_uav_env.rendering import save_png
from ios_uav_env.trajectory import average_rate

ID_OF_SURFACE = {kwargs["surface"]: env_id for env_id, kwargs in ENV_IDS.items()}
DOCS_FRAME = Path("docs/demo_frame.png")
DOCS_FRAME_MAX_BYTES = 150_000


class HoverPolicy:
    """Fly to ``target`` at full speed and hover there (the guard handles the way to qF)."""

    def __init__(self, target: tuple[float, float], length_scale: float, D: float) -> None:
        self.target = np.asarray(target, dtype=float)
        self.length_scale, self.D = length_scale, D

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        position = obs[:2].astype(float) * self.length_scale  # observation 0-1: q / L
        move = (self.target - position) / self.D
        norm = float(np.hypot(*move))
        return (move / norm if norm > 1.0 else move).astype(np.float32)


def straight_line(config: ScenarioConfig) -> np.ndarray:
    """q0 -> qF at constant speed over the N slots (feasible whenever the config is)."""
    return np.linspace(config.q0, config.qF, config.N)


def run_episode(env_id: str, seed: int, **env_kwargs: Any) -> tuple[dict[str, Any], np.ndarray, float]:
    """Roll out the hover heuristic once; return (final info, last frame, return)."""
    env = gym.make(env_id, render_mode="rgb_array", **env_kwargs)
    base = env.unwrapped
    peak = rate_peak(base.config)
    policy = HoverPolicy((peak.x, peak.y), base.length_scale, base.config.D)
    obs, info = env.reset(seed=seed)
    total, done = 0.0, False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        total += float(reward)
        done = terminated or truncated
    frame = env.render()
    env.close()
    return info, frame, total


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m ios_uav_env", description=__doc__.splitlines()[0])
    parser.add_argument("--surface", choices=SURFACES, default="ios", help="which env id (default: ios)")
    parser.add_argument("--seed", type=int, default=0, help="reset seed (default: 0)")
    parser.add_argument("--out", type=Path, default=Path("out/demo.png"), help="PNG of the last frame")
    parser.add_argument(
        "--docs-frame", action="store_true", help=f"also write a small copy of the frame to {DOCS_FRAME}"
    )
    args = parser.parse_args(argv)

    env_id = ID_OF_SURFACE[args.surface]
    start = time.perf_counter()
    info, frame, total = run_episode(env_id, args.seed)
    seconds = time.perf_counter() - start
    config = ScenarioConfig(surface=args.surface)
    print(f"{env_id}: M = {config.M}, N = {config.N} slots, D = {config.D:g} m, seed {args.seed}")
    print(f"heuristic (fly to the reachable rate peak, hover, guard to qF), {seconds:.2f} s:")
    print(f"  average rate (eq. 9)  {info['average_rate']:.4f} bps/Hz   return {total:.4f}")
    print(f"  feasibility (eq. 10)  {info['report']}")
    print(f"straight line q0 -> qF: average rate {average_rate(config, straight_line(config)):.4f} bps/Hz")
    print(f"frame: {save_png(frame, args.out)}")
    if args.docs_frame:
        path = save_png(frame, DOCS_FRAME)
        if path.stat().st_size > DOCS_FRAME_MAX_BYTES:  # keep the README light: use a palette
            path = save_png(frame, DOCS_FRAME, colors=256)
        print(f"docs frame: {path} ({path.stat().st_size / 1024:.0f} KB)")
    return 0 if info["feasible"] else 1


if __name__ == "__main__":
    sys.exit(main())
