"""Record an ios_uav_env episode to mp4 with Gymnasium's ``RecordVideo`` (needs moviepy).

Run:  python examples/record_video.py --out videos [--frames 40] [--env ID [ID ...]]
Makes the id with ``render_mode="rgb_array"``, flies the fly-to-G-and-hover heuristic
(``ios_uav_env.envs.policies.HoverAt``; the env's arrival guard brings it back to qF) and checks the mp4.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import gymnasium as gym
from gymnasium.wrappers import RecordVideo

import ios_uav_env  # noqa: F401  (registers the ids)
from ios_uav_env.envs.policies import HoverAt


def record(env_id: str, out: Path, frames: int, seed: int) -> Path:
    """Record one episode of ``env_id`` (its first ``frames`` frames if > 0) to an mp4 in ``out``."""
    prefix = env_id.replace("/", "-")
    env = gym.make(env_id, render_mode="rgb_array")
    env = RecordVideo(env, str(out), episode_trigger=lambda _: True, video_length=frames,
                      name_prefix=prefix, disable_logger=True)  # fmt: skip
    obs, info = env.reset(seed=seed)
    policy = HoverAt("ground", D=env.unwrapped.config.D, length_scale=env.unwrapped.length_scale)
    terminated = truncated = False
    steps = 0
    while not (terminated or truncated) and (frames <= 0 or steps < frames):
        obs, _, terminated, truncated, info = env.step(policy(obs))
        steps += 1
    env.close()  # writes the video

    videos = sorted(out.glob(f"{prefix}*.mp4"))
    if not videos or videos[0].stat().st_size == 0:
        raise RuntimeError(f"no video of {env_id} written in {out}")
    print(f"{env_id}: {steps} steps, average rate {info['average_rate']:.3f} bps/Hz -> {videos[0]}")
    return videos[0]


def main(argv: list[str] | None = None) -> list[Path]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", nargs="+", default=["ios_uav_env/IOSUAV-v0"], help="one or more ids")
    parser.add_argument("--out", type=Path, default=None, help="video folder (default: a temporary one)")
    parser.add_argument("--frames", type=int, default=0, help="frames to record (0: the whole episode)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    out = args.out or Path(tempfile.mkdtemp(prefix="ios_uav_video_"))
    return [record(env_id, out, args.frames, args.seed) for env_id in args.env]


if __name__ == "__main__":
    main()
