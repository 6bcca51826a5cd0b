"""The step-level tables of ``benchmarks/vector_speed.py --steps``: ``step`` of a batched env
against ``CartPoleVectorEnv`` and the raw ``CartPole-v1`` per batch size B, and the multi-node id's
single env against its batched env (see ``vector_speed``'s docstring).
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable, Sequence

import gymnasium as gym
import numpy as np
from gymnasium.envs.classic_control.cartpole import CartPoleVectorEnv

from ios_uav_env.jit import HAVE_NUMBA
from ios_uav_env.model.schedule import maxmin_rate


def numba_threads_available() -> int:
    import numba

    return int(numba.get_num_threads())


def _timer(step: Callable[[], object], calls: int) -> Callable[[], float]:
    def run() -> float:
        start = time.perf_counter()
        for _ in range(calls):
            step()
        return time.perf_counter() - start

    return run


def single_cartpole(steps: int) -> Callable[[], float]:
    env = gym.make("CartPole-v1").unwrapped
    env.reset(seed=0)
    actions = [int(a) for a in np.random.default_rng(0).integers(0, 2, steps)]

    def run() -> float:
        start = time.perf_counter()
        for a in actions:
            _, _, terminated, truncated, _ = env.step(a)
            if terminated or truncated:
                env.reset()
        return time.perf_counter() - start

    return run


def batched(env_id: str, size: int, calls: int, **kwargs: object) -> Callable[[], float]:
    vec = gym.make_vec(env_id, num_envs=size, vectorization_mode="vector_entry_point", **kwargs)
    vec.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-1, 1, (size, *vec.single_action_space.shape))
    vec.step(actions)  # compile (numba) before timing
    return _timer(lambda: vec.step(actions), calls)


def cartpole_vector(size: int, calls: int) -> Callable[[], float]:
    vec = CartPoleVectorEnv(num_envs=size)
    vec.reset(seed=0)
    actions = np.random.default_rng(0).integers(0, 2, size)
    return _timer(lambda: vec.step(actions), calls)


def single_multinode(env_id: str, episodes: int) -> tuple[Callable[[], float], int, float]:
    """A timer of ``episodes`` episodes of the single env (random actions, its LP included), their
    steps, and the time of one best-schedule LP (s; the median of 5 on a random flight)."""
    env = gym.make(env_id).unwrapped
    env.reset(seed=0)
    moves = env.config.N - 1
    actions = np.random.default_rng(0).uniform(-1, 1, (moves, *env.action_space.shape))
    for a in actions:
        env.step(a)
    lp = []
    for _ in range(5):
        start = time.perf_counter()
        maxmin_rate(env.config, env.trajectory)
        lp.append(time.perf_counter() - start)

    def run() -> float:
        start = time.perf_counter()
        for _ in range(episodes):
            env.reset(seed=0)
            for a in actions:
                env.step(a)
        return time.perf_counter() - start

    return run, episodes * moves, float(np.median(lp))


def multinode_table(env_id: str, sizes: Sequence[int], env_steps: int, repeats: int) -> None:
    """The multi-node id: single env vs batched env (without and with the LP), per B."""
    single, single_steps, lp = single_multinode(env_id, 2)
    single_rate = single_steps / min(single() for _ in range(repeats))
    moves = single_steps // 2
    bare = 1.0 / max(1e-12, 1.0 / single_rate - lp / moves)  # the single env's steps without the LP
    print(f"\n{env_id} ({moves} moves per episode): single MultiNodeEnv {single_rate:,.0f} steps/s "
          f"with its LP (LP {lp * 1e3:.1f} ms per episode; ~{bare:,.0f} steps/s without it)")  # fmt: skip
    head = ("B", "batched, no LP", "x single", "batched + LP", "x single")
    print(f"{head[0]:>6} {head[1]:>16} {head[2]:>10} {head[3]:>14} {head[4]:>10}")
    for size in sizes:
        calls = max(10, env_steps // size)
        ours = batched(env_id, size, calls, best_schedule=False)
        rate = calls * size / min(ours() for _ in range(repeats))
        with_lp = 1.0 / (1.0 / rate + lp / moves)  # one LP per row and episode of `moves` steps
        ratios = rate / single_rate, with_lp / single_rate
        print(f"{size:>6} {rate:>16,.0f} {ratios[0]:>10.1f} {with_lp:>14,.0f} {ratios[1]:>10.1f}")


def step_tables(args: argparse.Namespace) -> None:
    """The step-level tables of ``--steps`` (see the module's docstring)."""
    single = single_cartpole(20_000)
    single_best = min(single() for _ in range(args.repeats))
    cartpole_rate = 20_000 / single_best
    threads = args.threads or (numba_threads_available() if HAVE_NUMBA else 1)
    kernels = "yes" if HAVE_NUMBA else "no (plain-Python kernels)"
    print(f"numba: {kernels}; env {args.id}; our batched env on {threads} thread(s)")
    print(f"CartPole-v1 raw (one env): {cartpole_rate:,.0f} steps/s")
    head = ("B", "ours (steps/s)", "CartPoleVectorEnv", "x CartPole raw", "x CartPoleVec")
    print(f"{head[0]:>6} {head[1]:>16} {head[2]:>18} {head[3]:>15} {head[4]:>14}")
    for size in args.sizes:
        calls = max(10, args.env_steps // size)
        ours, theirs = batched(args.id, size, calls, num_threads=args.threads), cartpole_vector(size, calls)
        best_ours = best_theirs = float("inf")
        for _ in range(args.repeats):  # take turns
            best_ours = min(best_ours, ours())
            best_theirs = min(best_theirs, theirs())
        rate, ref = calls * size / best_ours, calls * size / best_theirs
        print(f"{size:>6} {rate:>16,.0f} {ref:>18,.0f} {rate / cartpole_rate:>15.1f} {rate / ref:>14.2f}")
    if args.multinode_id:
        multinode_table(args.multinode_id, args.sizes, args.env_steps, args.repeats)
