"""Raw ``env.step`` throughput of ``ios_uav_env/IOSUAV-v0`` (M = 6000) against ``CartPole-v1``.

Both envs run the same loop: actions pre-sampled from the action space, reset on episode end
(counted in the time), a warm-up, then the best of several timed repeats, the two envs taking
turns so that a busy machine slows both alike. "raw" is the bare env
(``gym.make(...).unwrapped``), "wrapped" the ``gym.make`` stack (TimeLimit, checkers). The
bar: raw IOSUAV throughput >= 0.5 x raw CartPole's on the same machine.

    python benchmarks/step_speed.py [--steps 5000] [--repeats 10]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable, Sequence

import gymnasium as gym

import ios_uav_env  # noqa: F401  (registers the ids)

OURS, REFERENCE = "ios_uav_env/IOSUAV-v0", "CartPole-v1"


def step_loop(env: gym.Env, steps: int, seed: int = 0) -> Callable[[], float]:
    """A timer: each call runs ``steps`` pre-sampled actions through ``env`` and returns the seconds."""
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(steps)]
    step, reset = env.step, env.reset
    reset(seed=seed)

    def run() -> float:
        start = time.perf_counter()
        for action in actions:
            _, _, terminated, truncated, _ = step(action)
            if terminated or truncated:
                reset()
        return time.perf_counter() - start

    return run


def measure(steps: int, repeats: int) -> dict[str, dict[str, float]]:
    """{"raw" | "wrapped": {env id: steps/s}}: best of ``repeats`` after one warm-up pass."""
    out: dict[str, dict[str, float]] = {}
    for mode in ("raw", "wrapped"):
        envs = {env_id: gym.make(env_id) for env_id in (REFERENCE, OURS)}
        loops = {k: step_loop(env.unwrapped if mode == "raw" else env, steps) for k, env in envs.items()}
        best = dict.fromkeys(loops, float("inf"))
        for rep in range(repeats + 1):  # rep 0 is the warm-up
            for env_id, run in loops.items():
                elapsed = run()
                if rep:
                    best[env_id] = min(best[env_id], elapsed)
        out[mode] = {env_id: steps / seconds for env_id, seconds in best.items()}
        for env in envs.values():
            env.close()
    return out


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=5000, help="timed steps per repeat (default 5000)")
    parser.add_argument("--repeats", type=int, default=10, help="timed repeats; the best counts (default 10)")
    args = parser.parse_args(argv)
    if args.steps < 1 or args.repeats < 1:
        parser.error("--steps and --repeats must be >= 1")
    results = measure(args.steps, args.repeats)
    print(f"env.step throughput, best of {args.repeats} x {args.steps} steps (resets included)")
    print(f"{'':8s} {REFERENCE:>14s} {OURS:>24s} {'ratio':>7s}")
    for mode, row in results.items():
        ref, ours = row[REFERENCE], row[OURS]
        print(f"{mode:8s} {ref:10.0f} /s {ours:20.0f} /s {ours / ref:7.2f}"
              f"   ({1e6 / ref:.1f} vs {1e6 / ours:.1f} us/step)")  # fmt: skip
    ratio = results["raw"][OURS] / results["raw"][REFERENCE]
    verdict = "meets" if ratio >= 0.5 else "MISSES"
    print(f"raw ratio {ratio:.2f}: {verdict} the bar (>= 0.5 x CartPole-v1)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
