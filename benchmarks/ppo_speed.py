"""PPO on IOSUAV-v0 against the clock: time to 99.5 % of DP with the fast recipe.

Trains SB3 PPO with a zoo-format entry (default ``agents/hyperparams/ppo_fast.yml``) on the
natively batched env (``agents.vec_env.BatchedVecEnv``, wrapped in ``VecNormalize`` as the
recipe says), checkpoints nothing, and every ``--eval-every`` seconds of wall time rolls the
deterministic policy out for one episode of ``IOSUAVEnv()`` (the default scenario, arrival
guard on) with ``ios_uav_env.envs.rollout.run_episode``. It prints the elapsed time, the steps,
the steps/s and the % of DP (2.404068 bps/Hz, ``baselines.dp.solve(ScenarioConfig())``),
and stops at the bar (default 99.5 % of DP) or at ``--time-cap`` seconds. The clock starts
after the imports: it includes building the env and the model, the numba kernels' loading,
training and the evaluations. At the end it prints where the time went: env stepping, the
policy's forward passes while collecting, the rest of SB3's rollout loop (buffer, wrappers,
callbacks), the gradient updates and the evaluations, with the load average of the machine
(``/proc/loadavg``) before and after.

    python benchmarks/ppo_speed.py                       # the shipped fast recipe
    python benchmarks/ppo_speed.py --set n_envs=256 n_steps=32 --threads 2 --time-cap 300
    python benchmarks/ppo_speed.py --profile ppo.prof    # + a cProfile of the whole run
"""

from __future__ import annotations

import argparse
import ast
import cProfile
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # agents/ from a checkout

import numpy as np  # noqa: E402
import torch  # noqa: E402
import yaml  # noqa: E402
from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.callbacks import BaseCallback  # noqa: E402
from stable_baselines3.common.vec_env import VecEnvWrapper, VecMonitor, VecNormalize  # noqa: E402

from agents.hyperparams import Hyperparams, check_entry, resolve  # noqa: E402
from agents.loading import Agent  # noqa: E402
from agents.vec_env import BatchedVecEnv, wrap_batched  # noqa: E402
from ios_uav_env.envs.rollout import run_episode  # noqa: E402
from ios_uav_env.envs.single import IOSUAVEnv  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_FILE = ROOT / "agents" / "hyperparams" / "ppo_fast.yml"
ENV_ID = "ios_uav_env/IOSUAV-v0"
#: DP's average rate on the default scenario (2.5 m grid), ``baselines.dp.solve(ScenarioConfig())``.
DP_RATE = 2.404068


def loadavg() -> str:
    try:
        return " ".join(Path("/proc/loadavg").read_text().split()[:3])
    except OSError:
        return "n/a"


class EnvTimer(VecEnvWrapper):
    """Seconds spent in the wrapped VecEnv's ``step_wait`` (``seconds``) and ``reset`` (``reset_seconds``,
    the stagger's hover moves included)."""

    def __init__(self, venv: Any):
        super().__init__(venv)
        self.seconds = self.reset_seconds = 0.0

    def reset(self) -> Any:
        start = time.perf_counter()
        obs = self.venv.reset()
        self.reset_seconds += time.perf_counter() - start
        return obs

    def step_wait(self) -> Any:
        start = time.perf_counter()
        out = self.venv.step_wait()
        self.seconds += time.perf_counter() - start
        return out


class ForwardTimer:
    """Wraps a policy's ``forward`` (what SB3's rollout loop calls on each batch of observations)."""

    def __init__(self, policy: torch.nn.Module):
        self.seconds, self.calls = 0.0, 0
        self._forward = policy.forward
        policy.forward = self  # type: ignore[method-assign]  # nn.Module.__call__ looks it up on the instance

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        start = time.perf_counter()
        out = self._forward(*args, **kwargs)
        self.seconds += time.perf_counter() - start
        self.calls += 1
        return out


class RaceCallback(BaseCallback):
    """Times rollouts and updates; evaluates the deterministic policy every ``eval_every`` seconds
    (after an update) and stops training once it reaches ``bar`` x DP."""

    def __init__(self, start: float, eval_every: float, bar: float, time_cap: float):
        super().__init__()
        self.cpu_start = time.process_time()
        self.start, self.eval_every, self.bar, self.time_cap = start, eval_every, bar, time_cap
        self.rollout_s = self.train_s = self.eval_s = 0.0
        self._mark = 0.0
        self._last_eval = 0.0
        self.reached: tuple[float, int, float, float] | None = None  # (seconds, steps, % of DP, cpu s)
        self.best: tuple[float, int, float, float] = (float("nan"), 0, 0.0, float("nan"))
        self.last: dict[str, Any] = {}
        self._stop = False
        self.env = IOSUAVEnv()

    def elapsed(self) -> float:
        return time.perf_counter() - self.start

    def cpu(self) -> float:
        """CPU seconds of this process (all its threads) since the clock started."""
        return time.process_time() - self.cpu_start

    def evaluate(self) -> float:
        t0 = time.perf_counter()
        agent = Agent(self.model, self.model.get_vec_normalize_env(), ENV_ID, {})
        episode = run_episode(self.env, agent.act, seed=0)
        self.eval_s += time.perf_counter() - t0
        pct = 100.0 * episode.average_rate / DP_RATE
        now, steps = self.elapsed(), self.model.num_timesteps
        self.last = {"rate": episode.average_rate, "feasible": episode.feasible, "pct": pct}
        cpu = self.cpu()
        if pct > self.best[2]:
            self.best = (now, steps, pct, cpu)
        print(
            f"{now:7.1f} s (cpu {cpu:6.1f} s)  {steps:8d} steps  {steps / max(now, 1e-9):7.0f} steps/s  "
            f"rate {episode.average_rate:.6f}  {pct:6.2f} % of DP  feasible {episode.feasible}  "
            f"miss {episode.terminal_miss:.2f} m  load {loadavg()}",
            flush=True,
        )
        if pct >= 100.0 * self.bar and episode.feasible and self.reached is None:
            self.reached = (now, steps, pct, cpu)
            self._stop = True
        return pct

    def _on_rollout_start(self) -> None:
        now = time.perf_counter()
        if self._mark:
            self.train_s += now - self._mark  # since the last rollout's end: the update
        if self.model.num_timesteps and self.elapsed() - self._last_eval >= self.eval_every:
            self._last_eval = self.elapsed()
            self.evaluate()
        if self.elapsed() >= self.time_cap:
            self._stop = True
        self._mark = time.perf_counter()

    def _on_rollout_end(self) -> None:
        now = time.perf_counter()
        self.rollout_s += now - self._mark
        self._mark = now

    def _on_step(self) -> bool:
        return not self._stop


def read_entry(path: Path, env_id: str, overrides: Sequence[str]) -> dict[str, Any]:
    """The zoo entry of ``env_id`` in ``path`` with ``key=value`` overrides (Python literals or words;
    ``log_std=start,end`` sets the LogStdSchedule)."""
    entry = dict(yaml.safe_load(path.read_text())[env_id])
    for item in overrides:
        key, _, text = item.partition("=")
        if key == "shift":
            entry["env_wrapper"] = [{"agents.wrappers.ShiftReward": {"offset": float(text)}}]
            continue
        if key == "log_std":
            start, end = (float(x) for x in text.split(","))
            entry["callback"] = [{"agents.callbacks.LogStdSchedule": {"start": start, "end": end}}]
            continue
        try:
            entry[key] = ast.literal_eval(text)
        except (ValueError, SyntaxError):
            entry[key] = text
    return entry


def build(hp: Hyperparams, n_envs: int, seed: int, threads: int, stagger: bool) -> tuple[PPO, EnvTimer]:
    torch.set_num_threads(threads)
    timer = EnvTimer(BatchedVecEnv(ENV_ID, n_envs, seed=seed, stagger=stagger))
    venv: Any = wrap_batched(VecMonitor(timer), hp.env_wrappers)
    if hp.normalize is not None:
        venv = VecNormalize(venv, gamma=hp.model_kwargs.get("gamma", 0.99), **hp.normalize)
    model = PPO(hp.policy, venv, seed=seed, device="cpu", verbose=0, **hp.model_kwargs)
    return model, timer


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hyperparams", type=Path, default=DEFAULT_FILE, help="zoo-format YAML")
    parser.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE", help="override entry keys")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--threads", type=int, default=1, help="torch threads")
    parser.add_argument("--time-cap", type=float, default=300.0, help="stop after this many seconds")
    parser.add_argument("--eval-every", type=float, default=4.0, help="seconds between evaluations")
    parser.add_argument("--bar", type=float, default=0.995, help="fraction of DP that ends the race")
    parser.add_argument("--no-stop", action="store_true", help="train to n_timesteps even past the bar")
    parser.add_argument("--no-stagger", action="store_true", help="all rows start their episodes together")
    parser.add_argument("--profile", type=Path, default=None, help="write a cProfile of the run here")
    args = parser.parse_args(argv)

    load_before = loadavg()
    start = time.perf_counter()
    cpu_start = time.process_time()
    entry = read_entry(args.hyperparams, ENV_ID, args.set)
    hp = resolve(check_entry("ppo", entry))
    model, env_timer = build(hp, hp.n_envs, args.seed, args.threads, not args.no_stagger)
    forward = ForwardTimer(model.policy)
    race = RaceCallback(start, args.eval_every, 2.0 if args.no_stop else args.bar, args.time_cap)
    setup_s = time.perf_counter() - start
    print(
        f"{args.hyperparams.relative_to(ROOT) if args.hyperparams.is_relative_to(ROOT) else args.hyperparams}"
        f" {ENV_ID}: n_envs {hp.n_envs}, n_timesteps {hp.n_timesteps}, "
        + ", ".join(f"{k} {v}" for k, v in hp.raw.items() if k not in ("n_envs", "n_timesteps", "policy"))
        + f"; torch threads {args.threads}, seed {args.seed}; setup {setup_s:.1f} s; load {load_before}",
        flush=True,
    )
    profiler = cProfile.Profile() if args.profile else None
    if profiler:
        profiler.enable()
    model.learn(hp.n_timesteps, callback=[*hp.callbacks, race])
    if race.reached is None and model.num_timesteps > 0:
        race.evaluate()  # the final policy
    if profiler:
        profiler.disable()
        profiler.dump_stats(args.profile)
    total = race.elapsed()
    cpu_total = time.process_time() - cpu_start
    steps = model.num_timesteps
    env_s, fwd_s = env_timer.seconds, forward.seconds
    other_s = race.rollout_s - env_s - fwd_s
    in_learn = steps / max(race.rollout_s + race.train_s, 1e-9)
    print(f"\nsteps {steps}, wall {total:.1f} s (cpu {cpu_total:.1f} s), {steps / total:.0f} steps/s "
          f"overall, {in_learn:.0f} steps/s in learn()")  # fmt: skip
    print("where the time went (s):")
    for name, sec in (
        ("setup (env, model, numba load)", setup_s),
        ("env reset (+ stagger)", env_timer.reset_seconds),
        ("env stepping (BatchedVecEnv)", env_s),
        ("policy forward while collecting", fwd_s),
        ("rest of SB3's rollout loop", other_s),
        ("gradient updates (PPO.train)", race.train_s),
        ("evaluations", race.eval_s),
    ):
        print(f"  {name:34s} {sec:7.2f}  {100 * sec / total:5.1f} %")
    if steps:
        print(
            f"per env step: env {1e6 * env_s / steps:.2f} us, forward {1e6 * fwd_s / steps:.2f} us, "
            f"rest of rollout {1e6 * other_s / steps:.2f} us, update {1e6 * race.train_s / steps:.2f} us"
        )
    cpu_setup = cpu_total - race.cpu()
    if race.reached:
        sec, at, pct, cpu = race.reached
        print(f"REACHED {100 * args.bar:.1f} % of DP: {pct:.2f} % after {sec:.1f} s wall, "
              f"{cpu + cpu_setup:.1f} s cpu ({at} steps)")  # fmt: skip
    else:
        sec, at, pct, cpu = race.best
        print(f"NOT REACHED {100 * args.bar:.1f} % of DP; best {pct:.2f} % at {sec:.1f} s wall, "
              f"{cpu + cpu_setup:.1f} s cpu ({at} steps)")  # fmt: skip
    print(f"load average: {load_before} before, {loadavg()} after; {os.cpu_count()} cpus")
    return 0 if race.reached or args.no_stop else 1


if __name__ == "__main__":
    np.set_printoptions(precision=4)
    sys.exit(main())
