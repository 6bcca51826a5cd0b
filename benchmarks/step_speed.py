"""Raw ``env.step`` throughput of ``ios_uav_env/IOSUAV-v0`` (M = 6000) against ``CartPole-v1``.

Both envs run the same loop: actions pre-sampled from the action space, reset on episode end
(counted in the time), a warm-up, then the best of several timed repeats, the two envs taking
turns so that a busy machine slows both alike. "raw" is the bare env
(``gym.make(...).unwrapped``), "wrapped" the ``gym.make`` stack (TimeLimit, checkers). The
bar: raw IOSUAV throughput >= 0.5 x raw CartPole's on the same machine.

``--env`` measures another flight id the same way, made with ``--env-kwargs`` (train.py's
``key:value`` pairs), e.g. the STAR id with 2-bit phases, whose every slot searches the node's
exact phases element by element (the bar is the paper's id's):

    python benchmarks/step_speed.py [--steps 5000] [--repeats 10]
    python benchmarks/step_speed.py --env ios_uav_env/STARUAV-v0 --env-kwargs star_bits:2
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

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


def measure(
    steps: int, repeats: int, ours: str = OURS, kwargs: dict[str, Any] | None = None
) -> dict[str, dict[str, float]]:
    """{"raw" | "wrapped": {env id: steps/s}}: best of ``repeats`` after one warm-up pass; ``ours``
    made with ``kwargs``."""
    out: dict[str, dict[str, float]] = {}
    for mode in ("raw", "wrapped"):
        envs = {REFERENCE: gym.make(REFERENCE), ours: gym.make(ours, **(kwargs or {}))}
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
    parser.add_argument("--env", default=OURS, help=f"the id measured (default {OURS}, the bar's)")
    parser.add_argument("--env-kwargs", nargs="*", default=None, metavar="KEY:VALUE",
                        help="the id's keyword arguments (train.py's form), e.g. star_bits:2")  # fmt: skip
    args = parser.parse_args(argv)
    if args.steps < 1 or args.repeats < 1:
        parser.error("--steps and --repeats must be >= 1")
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # (agents, for the kwargs' parser)
    from agents.hyperparams import parse_env_kwargs

    try:
        kwargs = parse_env_kwargs(args.env_kwargs)
        gym.make(args.env, **kwargs).close()
    except (ValueError, TypeError, gym.error.Error) as exc:
        parser.error(f"argument --env/--env-kwargs: {exc}")
    ours = args.env
    results = measure(args.steps, args.repeats, ours, kwargs)
    named = ours + "".join(f" {k}={v!r}" for k, v in kwargs.items())
    print(f"env.step throughput, best of {args.repeats} x {args.steps} steps (resets included)")
    print(f"{'':8s} {REFERENCE:>14s} {named:>24s} {'ratio':>7s}")
    for mode, row in results.items():
        ref, own = row[REFERENCE], row[ours]
        print(f"{mode:8s} {ref:10.0f} /s {own:20.0f} /s {own / ref:7.2f}"
              f"   ({1e6 / ref:.1f} vs {1e6 / own:.1f} us/step)")  # fmt: skip
    ratio = results["raw"][ours] / results["raw"][REFERENCE]
    if ours == OURS and not kwargs:
        verdict = "meets" if ratio >= 0.5 else "MISSES"
        print(f"raw ratio {ratio:.2f}: {verdict} the bar (>= 0.5 x CartPole-v1)")
    else:
        print(f"raw ratio {ratio:.2f} (the bar is {OURS}'s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
