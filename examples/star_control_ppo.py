"""SB3 PPO setting a STAR surface (``ios_uav_env/STARControl-v0``), scored as % of the per-slot optimum.

Run:  python examples/star_control_ppo.py [--elements 16 64] [--bits none 1] [--steps 50000]
For each surface size M (a square surface, sqrt(M) x sqrt(M)) and phase resolution b, PPO (the
recipe of ``agents/hyperparams/ppo.yml``'s ``ios_uav_env/STARControl-v0`` entry) trains for
``--steps`` slots on 4 envs, then its deterministic policy plays ``--episodes`` held-out episodes
(seeds 1000, 1001, ...). One row per (M, b), each a % of the per-slot optimum summed over those
episodes (100 sum_n R_n / sum_n R*_n, R* = ``star_slot.slot_optimum`` of the env's own surface):

- ``ppo``: the learned policy;
- ``random``: ``star_slot.random_phase_value`` (uniform phases on the grid, the share then best);
- ``quantised``: the continuous optimum's phases rounded to the b-bit grid (``star.quantise``), the
  share then best: what a controller that knows the channels but not the grid gets (100 when b is
  None);
- ``b-bit/cont``: the b-bit optimum as % of the continuous one (what the grid itself costs).

With ``--group g`` the policy sets groups of g elements (``random`` and ``quantised`` stay
per element) and the optimum stays the per-element one: what grouping costs is in the score.

``--plot PATH`` draws the rows (% of the per-slot optimum against M, one colour per b: PPO solid,
random phases dashed, the rounded optimum dotted); an existing file is never overwritten.

Needs the ``rl`` extra (and matplotlib for ``--plot``). The models are not saved.
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
from ios_uav_env.model.star import StarSurface, quantise, side_amplitude, tdma_maxmin
from ios_uav_env.model.star_slot import random_phase_value, slot_optimum

ID = ios_uav_env.STAR_CONTROL_ID
#: The recipe (``agents/hyperparams/ppo.yml``, ``ios_uav_env/STARControl-v0``).
PPO_KWARGS = dict(
    n_steps=256, batch_size=256, n_epochs=10, gamma=0.0, gae_lambda=1.0, learning_rate=1e-3, ent_coef=0.0,
    policy_kwargs=dict(net_arch=dict(pi=[], vf=[64, 64]), log_std_init=-1.0),
)  # fmt: skip
N_ENVS = 4


def env_kwargs(m: int, bits: int | None, group: int = 1) -> dict:
    side = math.isqrt(m)
    if side * side != m:
        raise ValueError(f"--elements must be square numbers (a sqrt(M) x sqrt(M) surface), got {m}")
    return {"elements": (side, side), "bits": bits, "group": group}


def _rate(ch, theta_r: np.ndarray, theta_t: np.ndarray) -> float:
    """TDMA max-min rate of the whole surface on each side with these phases, the share best."""
    amps = [side_amplitude(a, phi, d, th) for a, phi, d, th in
            ((ch.a_r, ch.phi_r, ch.direct_r, theta_r), (ch.a_t, ch.phi_t, ch.direct_t, theta_t))]  # fmt: skip
    return tdma_maxmin(*(math.log2(1 + ch.eta * a * a) for a in amps))[0]


def references(kwargs: dict, episodes: int) -> dict[str, float]:
    """The reference rows over the held-out episodes (% of the per-slot optimum)."""
    env = gym.make(ID, **kwargs).unwrapped
    rng = np.random.default_rng(0)
    cont = StarSurface("es", "independent", None)
    sums = dict(opt=0.0, cont=0.0, random=0.0, quantised=0.0)
    for k in range(episodes):
        env.reset(seed=1000 + k)
        for ch in env.channels:
            sums["opt"] += slot_optimum(ch, env.surface, env.access).value
            sums["cont"] += slot_optimum(ch, cont, env.access).value
            sums["random"] += random_phase_value(ch, env.surface, env.access, "maxmin", rng)
            bits = env.surface.bits
            sums["quantised"] += _rate(ch, quantise(ch.phi_r, bits), quantise(ch.phi_t, bits))
    out = {key: 100 * sums[key] / sums["opt"] for key in ("random", "quantised")}
    return {**out, "cont": 100 * sums["opt"] / sums["cont"]}


def train_and_score(
    kwargs: dict, steps: int, episodes: int, seed: int, **overrides: float | None
) -> tuple[float, float]:
    """PPO for ``steps`` slots, then its % of the per-slot optimum on the held-out episodes; and
    the training time (s). ``overrides``: PPO arguments in place of the recipe's."""
    venv = DummyVecEnv([lambda: gym.make(ID, **kwargs) for _ in range(N_ENVS)])
    venv.seed(seed)
    venv = VecNormalize(venv, norm_obs=False, norm_reward=True, gamma=0.99)
    model = PPO("MlpPolicy", venv, seed=seed, device="cpu", **{**PPO_KWARGS, **overrides})
    start = time.perf_counter()
    model.learn(total_timesteps=steps)
    seconds = time.perf_counter() - start
    env = gym.make(ID, **kwargs)
    total = best = 0.0
    for k in range(episodes):
        obs, _ = env.reset(seed=1000 + k)
        done = False
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, _, done, _, info = env.step(action)
        total, best = total + info["return"], best + info["optimum_return"]
    return 100 * total / best, seconds


def plot_rows(rows: list[dict], path: Path, title: str) -> Path:
    """The rows' % of the per-slot optimum against M (log scale), one colour per phase resolution."""
    from ios_uav_env.plotting import figure_image, save_png

    def draw(ax) -> None:
        for i, bits in enumerate(dict.fromkeys(r["bits"] for r in rows)):
            mine = sorted((r for r in rows if r["bits"] == bits), key=lambda r: r["M"])
            ms = [r["M"] for r in mine]
            label = "continuous" if bits is None else f"{bits}-bit"
            colour = f"C{i}"
            ax.plot(ms, [r["ppo"] for r in mine], "o-", color=colour, label=f"PPO, {label}")
            ax.plot(ms, [r["random"] for r in mine], "s--", color=colour, alpha=0.6, label=f"random, {label}")
            if bits is not None:
                ax.plot(ms, [r["quantised"] for r in mine], "^:", color=colour, alpha=0.6,
                        label=f"optimum rounded, {label}")  # fmt: skip
        ax.set_xscale("log", base=2)
        ax.set_xticks(sorted({r["M"] for r in rows}), [str(m) for m in sorted({r["M"] for r in rows})])
        ax.set_xlabel("elements M")
        ax.set_ylabel("% of the per-slot optimum")
        ax.set_ylim(0, 105)
        ax.set_title(title, fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=2)

    return save_png(figure_image(draw, figsize=(7.2, 4.2)), path, colors=64)


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elements", type=int, nargs="+", default=[16, 64], help="surface sizes M (squares)")
    parser.add_argument("--bits", nargs="+", default=["none", "1"], help="phase bits b ('none': continuous)")
    parser.add_argument("--steps", type=int, default=50_000, help="training slots per run")
    parser.add_argument("--episodes", type=int, default=20, help="held-out evaluation episodes")
    parser.add_argument("--group", type=int, default=1, help="elements per group (a divisor of sqrt(M))")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--learning-rate", type=float, default=PPO_KWARGS["learning_rate"])
    parser.add_argument("--target-kl", type=float, default=None, help="PPO's early stop (None: off)")
    parser.add_argument("--plot", type=Path, default=None, help="draw the rows here (PNG; never overwritten)")
    args = parser.parse_args(argv)
    if args.plot is not None and args.plot.exists():
        parser.error(f"--plot {args.plot} exists: give a new path (shipped figures are never overwritten)")
    torch.set_num_threads(1)
    rows = []
    print(
        f"PPO on {ID} (group {args.group}): {args.steps} slots a run, {args.episodes} held-out episodes, "
        "% of the per-slot optimum"
    )
    print(f"{'M':>4} {'b':>5} {'ppo':>7} {'random':>7} {'quantised':>9} {'b-bit/cont':>10} {'train s':>8}")
    for m in args.elements:
        for b in args.bits:
            bits = None if b == "none" else int(b)
            kwargs = env_kwargs(m, bits, args.group)
            ppo, seconds = train_and_score(
                kwargs,
                args.steps,
                args.episodes,
                args.seed,
                learning_rate=args.learning_rate,
                target_kl=args.target_kl,
            )
            ref = references(kwargs, args.episodes)
            row = {"M": m, "bits": bits, "ppo": ppo, **ref, "seconds": seconds}
            rows.append(row)
            cells = f"{ppo:7.1f} {ref['random']:7.1f} {ref['quantised']:9.1f} {ref['cont']:10.1f}"
            print(f"{m:>4} {b:>5} {cells} {seconds:8.0f}", flush=True)
    if args.plot is not None:
        title = (
            f"PPO setting the STAR surface ({args.steps} slots a run, seed {args.seed}, group {args.group})"
        )
        print(f"figure: {plot_rows(rows, args.plot, title)}")
    return rows


if __name__ == "__main__":
    main()
