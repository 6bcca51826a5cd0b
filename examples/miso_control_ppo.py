"""SB3 PPO setting a multi-antenna UAV's beams and the surface's phases (``ios_uav_env/MISOControl-v0``).

Run:  python examples/miso_control_ppo.py [--antennas 2 4 8] [--users 2 4] [--elements 16 64]
For each N_t, K and M (a square surface, sqrt(M) x sqrt(M)), PPO (the recipe of
``agents/hyperparams/ppo.yml``'s ``ios_uav_env/MISOControl-v0`` entry) trains for ``--steps`` slots
on 4 envs without the per-slot AO (``optimum=False``: it is costly and training does not need
it), then its deterministic policy plays ``--episodes`` held-out episodes (seeds 1000, 1001, ...)
with it. One row per (N_t, K, M), each summed over those episodes' slots:

- ``ppo``: the learned policy, as % of the per-slot AO value (100 sum_n R_n / sum_n R*_n,
  R* = ``miso_slot.slot_optimum``) and as % of the certified bound (``miso.slot_bounds``);
- ``mrt``, ``zf``: equal-power MRT / ZF with the best user's aligned phases (``miso.baselines``;
  ZF needs N_t >= K, NaN otherwise), % of the AO value;
- ``random``: actions drawn uniformly over the action space (random beams on the full-power
  sphere and random phases), % of the AO value;
- ``AO/bound``: the AO value as % of the bound (how far the bound is from what AO reaches).

``--plot PATH`` draws the rows (% of the AO value and % of the bound for each configuration); an
existing file is never overwritten. Needs the ``rl`` extra (and matplotlib for ``--plot``). The
models are not saved.
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

import ios_uav_env

ID = ios_uav_env.MISO_CONTROL_ID
#: The recipe (``agents/hyperparams/ppo.yml``, ``ios_uav_env/MISOControl-v0``).
PPO_KWARGS = dict(
    n_steps=256, batch_size=256, n_epochs=10, gamma=0.0, gae_lambda=1.0, learning_rate=1e-3, ent_coef=0.0,
    policy_kwargs=dict(net_arch=dict(pi=[64, 64], vf=[64, 64]), log_std_init=-1.0),
)  # fmt: skip
N_ENVS = 4
COLUMNS = ("ppo", "ppo_bound", "mrt", "zf", "random", "ao_bound")


def env_kwargs(n_t: int, k: int, m: int, objective: str) -> dict:
    side = math.isqrt(m)
    if side * side != m:
        raise ValueError(f"--elements must be square numbers (a sqrt(M) x sqrt(M) surface), got {m}")
    return {"antennas": n_t, "users": k, "elements": (side, side), "objective": objective}


def train(kwargs: dict, steps: int, seed: int) -> tuple[PPO, float]:
    """PPO for ``steps`` slots on envs without the per-slot AO; the model and the time (s)."""
    venv = DummyVecEnv([lambda: gym.make(ID, **kwargs, optimum=False) for _ in range(N_ENVS)])
    venv.seed(seed)
    venv = VecNormalize(venv, norm_obs=False, norm_reward=True, gamma=0.99)
    model = PPO("MlpPolicy", venv, seed=seed, device="cpu", **PPO_KWARGS)
    start = time.perf_counter()
    model.learn(total_timesteps=steps)
    return model, time.perf_counter() - start


def score(model: PPO, kwargs: dict, episodes: int) -> dict[str, float]:
    """The row's columns over the held-out episodes (module docstring)."""
    env = gym.make(ID, **kwargs)  # with the per-slot AO
    plain = gym.make(ID, **kwargs, optimum=False)  # the random actions' episodes
    rng = np.random.default_rng(0)
    sums = dict(ppo=0.0, ao=0.0, bound=0.0, mrt=0.0, zf=0.0, random=0.0)
    for k in range(episodes):
        obs, _ = env.reset(seed=1000 + k)
        plain.reset(seed=1000 + k)
        done = False
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, reward, done, _, info = env.step(action)
            _, drawn, _, _, _ = plain.step(rng.uniform(-1.0, 1.0, env.action_space.shape))
            sums["ppo"] += reward
            sums["ao"] += info["optimum"]
            sums["bound"] += info["bound"]
            sums["mrt"] += info["mrt_aligned"]
            sums["zf"] += info["zf_aligned"]
            sums["random"] += drawn
    ao = sums["ao"]
    return {
        "ppo": 100 * sums["ppo"] / ao, "ppo_bound": 100 * sums["ppo"] / sums["bound"],
        "mrt": 100 * sums["mrt"] / ao, "zf": 100 * sums["zf"] / ao, "random": 100 * sums["random"] / ao,
        "ao_bound": 100 * ao / sums["bound"],
    }  # fmt: skip


def plot_rows(rows: list[dict], path: Path, title: str) -> Path:
    """Two panels over the configurations (markers, no lines: they are not a sequence): % of the
    per-slot AO value, and % of the bound."""
    from ios_uav_env.plotting import figure_image, save_png

    labels = [f"{r['N_t']}/{r['K']}/{r['M']}" for r in rows]
    x = np.arange(len(rows))

    def draw(ax) -> None:  # the one axes figure_image gives, replaced by two panels
        fig = ax.figure
        ax.remove()
        left, right = fig.subplots(1, 2, sharex=True)
        curves = (("ppo", "o", "PPO"), ("mrt", "s", "MRT, aligned phases"),
                  ("zf", "^", "ZF, aligned phases"), ("random", "x", "random actions"))  # fmt: skip
        for key, style, label in curves:
            left.plot(x, [r[key] for r in rows], style, label=label)
        right.plot(x, [r["ppo_bound"] for r in rows], "o", label="PPO")
        right.plot(x, [r["ao_bound"] for r in rows], "D", color="k", label="per-slot AO")
        for ax, name in ((left, "% of the per-slot AO value"), (right, "% of the certified bound")):
            ax.set_xticks(x, labels, rotation=60, fontsize=7)
            ax.set_xlabel("N_t / K / M")
            ax.set_ylabel(name)
            ax.set_ylim(0, 105)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
        fig.suptitle(title, fontsize=9)

    return save_png(figure_image(draw, figsize=(9.0, 4.2)), path, colors=64)


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--antennas", type=int, nargs="+", default=[2, 4, 8], help="antennas N_t")
    parser.add_argument("--users", type=int, nargs="+", default=[2, 4], help="users K")
    parser.add_argument("--elements", type=int, nargs="+", default=[16, 64], help="surface sizes M (squares)")
    parser.add_argument("--objective", default="sum", choices=("sum", "maxmin"))
    parser.add_argument("--steps", type=int, default=20_000, help="training slots per run")
    parser.add_argument("--episodes", type=int, default=3, help="held-out evaluation episodes")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--plot", type=Path, default=None, help="draw the rows here (PNG; never overwritten)")
    args = parser.parse_args(argv)
    if args.plot is not None and args.plot.exists():
        parser.error(f"--plot {args.plot} exists: give a new path (shipped figures are never overwritten)")
    torch.set_num_threads(1)
    print(
        f"PPO on {ID} ({args.objective}): {args.steps} slots a run, {args.episodes} held-out episodes; "
        "ppo, mrt, zf, random: % of the per-slot AO value; ppo/bd, AO/bd: % of the bound"
    )
    print(f"{'N_t':>3} {'K':>2} {'M':>3} {'ppo':>6} {'ppo/bd':>6} {'mrt':>6} {'zf':>6} {'random':>6} "
          f"{'AO/bd':>6} {'train s':>7} {'total s':>7}")  # fmt: skip
    rows = []
    for n_t in args.antennas:
        for k in args.users:
            for m in args.elements:
                start = time.perf_counter()
                kwargs = env_kwargs(n_t, k, m, args.objective)
                model, seconds = train(kwargs, args.steps, args.seed)
                row = {"N_t": n_t, "K": k, "M": m, **score(model, kwargs, args.episodes), "seconds": seconds}
                rows.append(row)
                cells = " ".join(f"{row[c]:6.1f}" for c in COLUMNS)
                total = time.perf_counter() - start
                print(f"{n_t:>3} {k:>2} {m:>3} {cells} {seconds:7.0f} {total:7.0f}", flush=True)
    if args.plot is not None:
        title = (
            f"PPO setting the beams and phases ({args.objective}, {args.steps} slots a run, seed {args.seed})"
        )
        print(f"figure: {plot_rows(rows, args.plot, title)}")
    return rows


if __name__ == "__main__":
    main()
