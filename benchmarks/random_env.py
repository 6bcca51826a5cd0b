"""Reset and step throughput of ``ios_uav_env/IOSUAV-Random-v0`` against the fixed ``IOSUAV-v0``.

Every reset of the randomised env draws a scenario (``sample_scenario``) and builds its rate
kernel (``rate_kernel``: the Chebyshev node compression, whose cost does not depend on M),
so a reset costs more than a fixed env's; steps cost the same (same kernel size, same
observation code plus 6 constants). Measured on the bare envs (``.unwrapped``): the reset
time per distinct scenario (median and 95th percentile), and the step throughput without
and with the resets (pre-sampled actions, the two envs taking turns).
The bars: a reset < 5 ms, steps at the fixed env's speed. ``--peak-hint`` times the
env with ``peak_hint=True`` too: its reset adds the grid search of ``ios_uav_env.rate_peak``.
``--energy`` times the resets of ``ios_uav_env/IOSUAV-Energy-Random-v0`` with each reward
reference (the hover plan's EE, the default; ``energy_reference="loiter"``; each with and
without the peak hint): its reset adds the peak search and the reference flights, and it is
part of an energy policy's plan time (the observation's energy weight needs the reference).

    python benchmarks/random_env.py [--resets 500] [--steps 5000] [--repeats 5] [--peak-hint] [--energy]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable, Sequence

import gymnasium as gym
import numpy as np

import ios_uav_env  # noqa: F401  (registers the ids)

RANDOM, FIXED = "ios_uav_env/IOSUAV-Random-v0", "ios_uav_env/IOSUAV-v0"
ENERGY_RANDOM = "ios_uav_env/IOSUAV-Energy-Random-v0"


def reset_times(resets: int, seed: int = 0, env_id: str = RANDOM, **env_kwargs: object) -> np.ndarray:
    """Seconds of each of ``resets`` resets of the bare random env (a new scenario each)."""
    env = gym.make(env_id, **env_kwargs).unwrapped
    env.reset(seed=seed)
    out = np.empty(resets)
    for i in range(resets):
        start = time.perf_counter()
        env.reset()
        out[i] = time.perf_counter() - start
    return out


def step_loop(env: gym.Env, steps: int, seed: int = 0) -> Callable[[], tuple[float, float]]:
    """A timer: each call runs ``steps`` pre-sampled actions through ``env`` (resetting at the
    end of each episode) and returns (seconds in ``step``, seconds in ``reset``)."""
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(steps)]
    step, reset, clock = env.step, env.reset, time.perf_counter
    reset(seed=seed)

    def run() -> tuple[float, float]:
        in_step = in_reset = 0.0
        for action in actions:
            start = clock()
            _, _, terminated, truncated, _ = step(action)
            in_step += clock() - start
            if terminated or truncated:
                start = clock()
                reset()
                in_reset += clock() - start
        return in_step, in_reset

    return run


def step_rates(steps: int, repeats: int) -> dict[str, dict[str, float]]:
    """{env id: {"steps": steps/s in step() alone, "with_resets": steps/s resets included}} of
    the bare envs: the best of ``repeats`` after a warm-up, the envs taking turns."""
    loops = {env_id: step_loop(gym.make(env_id).unwrapped, steps) for env_id in (FIXED, RANDOM)}
    best = {env_id: [float("inf"), float("inf")] for env_id in loops}
    for rep in range(repeats + 1):  # rep 0 is the warm-up
        for env_id, run in loops.items():
            in_step, in_reset = run()
            if rep:
                best[env_id][0] = min(best[env_id][0], in_step)
                best[env_id][1] = min(best[env_id][1], in_step + in_reset)
    return {k: {"steps": steps / a, "with_resets": steps / b} for k, (a, b) in best.items()}


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resets", type=int, default=500, help="timed resets (default 500)")
    parser.add_argument("--steps", type=int, default=5000, help="timed steps per repeat (default 5000)")
    parser.add_argument("--repeats", type=int, default=5, help="timed repeats; the best counts (default 5)")
    parser.add_argument("--peak-hint", action="store_true", help="also time resets with peak_hint=True")
    parser.add_argument("--energy", action="store_true", help=f"also time the resets of {ENERGY_RANDOM}")
    args = parser.parse_args(argv)
    if min(args.resets, args.steps, args.repeats) < 1:
        parser.error("--resets, --steps and --repeats must be >= 1")
    times = reset_times(args.resets) * 1e3
    median, p95 = np.median(times), np.percentile(times, 95)
    print(f"{RANDOM} reset (new scenario + rate kernel), {args.resets} resets:")
    print(f"  median {median:.3f} ms, 95th percentile {p95:.3f} ms, max {times.max():.3f} ms")
    print(f"  {'meets' if median < 5 else 'MISSES'} the bar (< 5 ms)")
    if args.peak_hint:
        hinted = reset_times(args.resets, peak_hint=True) * 1e3
        print(f"{RANDOM} reset with peak_hint=True (+ rate_peak), {args.resets} resets:")
        print(f"  median {np.median(hinted):.3f} ms, 95th percentile {np.percentile(hinted, 95):.3f} ms")
    if args.energy:
        print(f"{ENERGY_RANDOM} reset (new scenario, peak search, reference flights), {args.resets} resets:")
        for kwargs in ({}, {"peak_hint": True}, {"energy_reference": "loiter"},
                       {"energy_reference": "loiter", "peak_hint": True}):  # fmt: skip
            energy = reset_times(args.resets, env_id=ENERGY_RANDOM, **kwargs) * 1e3
            label = ", ".join(f"{k}={v!r}" for k, v in kwargs.items()) or "defaults (hover reference)"
            print(f"  {label:45s} median {np.median(energy):.3f} ms, 95th percentile "
                  f"{np.percentile(energy, 95):.3f} ms")  # fmt: skip
    rates = step_rates(args.steps, args.repeats)
    print(f"throughput of the bare envs, best of {args.repeats} x {args.steps} steps:")
    print(f"  {'':32s} {'step() alone':>22s} {'resets included':>22s}")
    for env_id, row in rates.items():
        a, b = row["steps"], row["with_resets"]
        print(f"  {env_id:32s} {a:9.0f} /s ({1e6 / a:5.1f} us) {b:9.0f} /s ({1e6 / b:5.1f} us)")
    for key, what in (("steps", "step() alone"), ("with_resets", "resets included")):
        print(f"  random / fixed, {what}: {rates[RANDOM][key] / rates[FIXED][key]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
