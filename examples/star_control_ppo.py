"""SB3 PPO setting a STAR surface (``ios_uav_env/STARControl-v0``), scored as % of the per-slot optimum.

Run:  python examples/star_control_ppo.py [--elements 16 64] [--bits none 1] [--steps 50000]
            [--control direct residual] [--seed 0 1 2] [--imitate 200]
For each surface size M (a square surface, sqrt(M) x sqrt(M)), phase resolution b, control (the
env's ``control``: ``direct`` sets the phases, ``residual`` offsets the aligned ones, so that a zero
action is the aligned surface) and seed, PPO (the recipe of ``agents/hyperparams/ppo.yml``'s
``ios_uav_env/STARControl-v0`` entry) trains for ``--steps`` slots on 4 envs, then its
deterministic policy plays ``--episodes`` held-out episodes (seeds 1000, 1001, ...). One row per
(M, b, control, seed), each a % of the per-slot optimum summed over those episodes
(100 sum_n R_n / sum_n R*_n, R* = ``star_slot.slot_optimum`` of the env's own surface):

- ``ppo``: the learned policy;
- ``imitated``: with ``--imitate E``, the policy after imitation and before PPO: its action mean
  fitted (squared error, Adam) to the optimum's own action (``env.action_of`` of
  ``slot_optimum``'s setting) on the slots of E episodes (seeds 5000, ...); PPO then starts from
  it (``-`` without imitation);
- ``zero``: the zero action of the residual control (the aligned phases, rounded to the grid,
  and the aligned share);
- ``random``: ``star_slot.random_phase_value`` (uniform phases on the grid, the share then best);
- ``quantised``: the continuous optimum's phases rounded to the b-bit grid (``star.quantise``), the
  share then best: what a controller that knows the channels but not the grid gets (100 when b is
  None);
- ``b-bit/cont``: the b-bit optimum as % of the continuous one (what the grid itself costs).

``--policy element`` (TDMA with the channel phases observed) replaces the recipe's linear actor
by one small network shared by every group (:class:`ElementPolicy`): it maps a group's own two
phase features and the 8 scalar features to that group's two phase actions, so its weights do not
grow with M and every group's step trains the same weights.

With ``--group g`` the policy sets groups of g elements (``random`` and ``quantised`` stay
per element) and the optimum stays the per-element one: what grouping costs is in the score.

``--plot PATH`` draws the rows (% of the per-slot optimum against M, one colour per b: PPO solid,
one marker per control, the mean over the seeds with their range as error bars; random phases
dashed, the rounded optimum dotted); an existing file is never overwritten.

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
from stable_baselines3.common.policies import ActorCriticPolicy
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize
from torch import nn

import ios_uav_env
from ios_uav_env.envs.star_control import N_SLOTS
from ios_uav_env.envs.star_control_rows import CONTROLS
from ios_uav_env.model.star import StarSurface, quantise, side_amplitude, tdma_maxmin
from ios_uav_env.model.star_slot import random_phase_value, slot_optimum

ID = ios_uav_env.STAR_CONTROL_ID
#: The recipe (``agents/hyperparams/ppo.yml``, ``ios_uav_env/STARControl-v0``).
PPO_KWARGS = dict(
    n_steps=256, batch_size=256, n_epochs=10, gamma=0.0, gae_lambda=1.0, learning_rate=1e-3, ent_coef=0.0,
    policy_kwargs=dict(net_arch=dict(pi=[], vf=[64, 64]), log_std_init=-1.0),
)  # fmt: skip
N_ENVS = 4
#: The first seed of the imitation episodes (the held-out ones start at 1000).
IMITATION_SEED = 5000
#: The imitation fit: passes over the labels, batch size, Adam's learning rate.
FIT_EPOCHS, FIT_BATCH, FIT_LR = 60, 256, 3e-3


#: The policies of ``--policy``: SB3's MlpPolicy (the recipe's linear actor), or the shared network.
POLICIES = ("mlp", "element")
#: The scalar features at the head of the observation (before the per-group phases).
HEAD = 8


class ElementExtractor(nn.Module):
    """The actor: one MLP (``HEAD`` + 2 -> width -> width -> 2) shared by the G groups, applied to
    (group k's phase features theta^r_k, theta^t_k, the head) for group k's two phase actions, and
    a linear map of the head for the TDMA share: the A = 2G + 1 action means themselves (the
    policy's ``action_net`` is the identity). The critic: an MLP (64, 64) of the whole observation."""

    def __init__(self, obs_dim: int, width: int = 32) -> None:
        super().__init__()
        self.groups = (obs_dim - HEAD) // 2
        self.element = nn.Sequential(
            nn.Linear(HEAD + 2, width), nn.Tanh(), nn.Linear(width, width), nn.Tanh(), nn.Linear(width, 2)
        )  # fmt: skip
        self.share = nn.Linear(HEAD, 1)
        self.policy_net = nn.ModuleList([self.element, self.share])  # the actor's weights (as MlpExtractor's)
        self.value = nn.Sequential(nn.Linear(obs_dim, 64), nn.Tanh(), nn.Linear(64, 64), nn.Tanh())
        self.latent_dim_pi, self.latent_dim_vf = 2 * self.groups + 1, 64

    def forward_actor(self, x: torch.Tensor) -> torch.Tensor:
        g, head = self.groups, x[:, :HEAD]
        phases = torch.stack([x[:, HEAD : HEAD + g], x[:, HEAD + g :]], dim=-1)  # (B, G, 2)
        inputs = torch.cat([phases, head[:, None, :].expand(-1, g, -1)], dim=-1)
        out = self.element(inputs)
        return torch.cat([out[..., 0], out[..., 1], self.share(head)], dim=-1)

    def forward_critic(self, x: torch.Tensor) -> torch.Tensor:
        return self.value(x)

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.forward_actor(x), self.forward_critic(x)


class ElementPolicy(ActorCriticPolicy):
    """SB3's actor-critic with :class:`ElementExtractor`; its action means are the extractor's
    outputs (``action_net`` the identity), their last layers initialised small (gain 0.01, as SB3
    does its ``action_net``) so that the first actions are near zero."""

    def _build_mlp_extractor(self) -> None:
        self.mlp_extractor = ElementExtractor(self.features_dim)

    def _build(self, lr_schedule) -> None:
        super()._build(lr_schedule)
        self.action_net = nn.Identity()
        for layer in (self.mlp_extractor.element[-1], self.mlp_extractor.share):
            nn.init.orthogonal_(layer.weight, gain=0.01)
            nn.init.zeros_(layer.bias)
        self.optimizer = self.optimizer_class(self.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs)


def env_kwargs(m: int, bits: int | None, group: int = 1, control: str = "direct") -> dict:
    side = math.isqrt(m)
    if side * side != m:
        raise ValueError(f"--elements must be square numbers (a sqrt(M) x sqrt(M) surface), got {m}")
    return {"elements": (side, side), "bits": bits, "group": group, "control": control}


def _rate(ch, theta_r: np.ndarray, theta_t: np.ndarray) -> float:
    """TDMA max-min rate of the whole surface on each side with these phases, the share best."""
    amps = [side_amplitude(a, phi, d, th) for a, phi, d, th in
            ((ch.a_r, ch.phi_r, ch.direct_r, theta_r), (ch.a_t, ch.phi_t, ch.direct_t, theta_t))]  # fmt: skip
    return tdma_maxmin(*(math.log2(1 + ch.eta * a * a) for a in amps))[0]


def references(kwargs: dict, episodes: int) -> dict[str, float]:
    """The reference rows over the held-out episodes (% of the per-slot optimum)."""
    env = gym.make(ID, **{**kwargs, "control": "residual"}).unwrapped
    rng = np.random.default_rng(0)
    cont = StarSurface("es", "independent", None)
    sums = dict(opt=0.0, cont=0.0, random=0.0, quantised=0.0, zero=0.0)
    for k in range(episodes):
        env.reset(seed=1000 + k)
        for _ in range(N_SLOTS):  # the residual control's zero action
            sums["zero"] += env.step(np.zeros(env.action_space.shape))[1]
        for ch in env.channels:
            sums["opt"] += slot_optimum(ch, env.surface, env.access).value
            sums["cont"] += slot_optimum(ch, cont, env.access).value
            sums["random"] += random_phase_value(ch, env.surface, env.access, "maxmin", rng)
            bits = env.surface.bits
            sums["quantised"] += _rate(ch, quantise(ch.phi_r, bits), quantise(ch.phi_t, bits))
    out = {key: 100 * sums[key] / sums["opt"] for key in ("random", "quantised", "zero")}
    return {**out, "cont": 100 * sums["opt"] / sums["cont"]}


def aligned_label(setting: dict, ch, bits: int | None) -> dict:
    """The optimum's ``setting`` with each side's phases turned as a whole by the multiple of
    2 pi / 2^b that brings them nearest to the aligned phases phi^s (largest sum_m cos(theta_m -
    phi_m)). Without direct links (the env's default) a side's |h| is the same under any common
    turn of its phases, and 2 pi / 2^b keeps them on the grid, so this is an optimum too: the one
    whose action is the smallest offset from the aligned surface. The exact b-bit search returns
    whichever turn its sweep meets first, an offset that changes from slot to slot and cannot be
    read from the observation. Unchanged with continuous phases (the optimum is phi itself) or a
    direct link."""
    if bits is None or ch.direct_r != 0 or ch.direct_t != 0:
        return setting
    turns = 2 * np.pi * np.arange(2**bits) / 2**bits
    out = dict(setting)
    for key, phi in (("theta_r", ch.phi_r), ("theta_t", ch.phi_t)):
        theta = np.asarray(setting[key])
        k = int(np.argmax(np.cos(theta[None] + turns[:, None] - phi[None]).sum(axis=1)))
        out[key] = quantise(theta + turns[k], bits)
    return out


def imitate(model: PPO, kwargs: dict, episodes: int, seed: int) -> None:
    """Fit ``model``'s action mean to the optimum's own action (:func:`aligned_label`) on the slots
    of ``episodes`` episodes (seeds ``IMITATION_SEED``, ...): squared error, Adam, ``FIT_EPOCHS``
    passes."""
    env = gym.make(ID, **kwargs).unwrapped
    obs_rows, labels = [], []
    for k in range(episodes):
        obs, _ = env.reset(seed=IMITATION_SEED + k)
        for _ in range(N_SLOTS):
            ch = env.channels[env.slot]
            best = slot_optimum(ch, env.surface, env.access)
            action = env.action_of(aligned_label(best.setting, ch, env.surface.bits))
            obs_rows.append(obs)
            labels.append(action)
            obs = env.step(action)[0]
    x = torch.as_tensor(np.asarray(obs_rows), dtype=torch.float32)
    y = torch.as_tensor(np.asarray(labels), dtype=torch.float32)
    policy = model.policy
    params = [*policy.mlp_extractor.policy_net.parameters(), *policy.action_net.parameters()]
    opt = torch.optim.Adam(params, lr=FIT_LR)
    gen = torch.Generator().manual_seed(seed)
    policy.set_training_mode(True)
    for _ in range(FIT_EPOCHS):
        for batch in torch.randperm(len(x), generator=gen).split(FIT_BATCH):
            latent = policy.mlp_extractor.forward_actor(policy.extract_features(x[batch]))
            loss = ((policy.action_net(latent) - y[batch]) ** 2).mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
    policy.set_training_mode(False)


def score(model: PPO, kwargs: dict, episodes: int) -> float:
    """The deterministic policy's % of the per-slot optimum on the held-out episodes."""
    env = gym.make(ID, **kwargs)
    total = best = 0.0
    for k in range(episodes):
        obs, _ = env.reset(seed=1000 + k)
        done = False
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, _, done, _, info = env.step(action)
        total, best = total + info["return"], best + info["optimum_return"]
    return 100 * total / best


def train_and_score(
    kwargs: dict, steps: int, episodes: int, seed: int, imitation: int = 0, policy: str = "mlp",
    **overrides: float | None,
) -> tuple[float, float | None, float]:  # fmt: skip
    """PPO for ``steps`` slots (after imitation on ``imitation`` episodes if > 0), then its % of
    the per-slot optimum on the held-out episodes; the imitated policy's (None without
    imitation); the training time (s, imitation included). ``overrides``: PPO arguments in place
    of the recipe's."""
    venv = DummyVecEnv([lambda: gym.make(ID, **kwargs) for _ in range(N_ENVS)])
    venv.seed(seed)
    venv = VecNormalize(venv, norm_obs=False, norm_reward=True, gamma=0.99)
    ppo_kwargs = {**PPO_KWARGS, **overrides}
    if policy == "element":
        if kwargs.get("access", "tdma") != "tdma" or not kwargs.get("channel_phases", True):
            raise ValueError("--policy element needs access='tdma' and the channel phases observed")
        ppo_kwargs["policy_kwargs"] = dict(log_std_init=PPO_KWARGS["policy_kwargs"]["log_std_init"])
    model = PPO(
        ElementPolicy if policy == "element" else "MlpPolicy", venv, seed=seed, device="cpu", **ppo_kwargs
    )
    start = time.perf_counter()
    imitated = None
    if imitation > 0:
        imitate(model, kwargs, imitation, seed)
        imitated = score(model, kwargs, episodes)
    model.learn(total_timesteps=steps)
    seconds = time.perf_counter() - start
    return score(model, kwargs, episodes), imitated, seconds


def _mean_range(rows: list[dict], key: str) -> tuple[float, float, float]:
    """The mean of ``key`` over ``rows`` (the seeds of one point) and its distance to the min and max."""
    values = np.array([r[key] for r in rows])
    return float(values.mean()), float(values.mean() - values.min()), float(values.max() - values.mean())


def plot_rows(rows: list[dict], path: Path, title: str) -> Path:
    """The rows' % of the per-slot optimum against M (log scale), one colour per phase resolution,
    one marker per control; several seeds: their mean, their range as error bars."""
    from ios_uav_env.plotting import figure_image, save_png

    markers = {"direct": "o-", "residual": "^-"}

    def draw(ax) -> None:
        for i, bits in enumerate(dict.fromkeys(r["bits"] for r in rows)):
            colour, label = f"C{i}", "continuous" if bits is None else f"{bits}-bit"
            ms = sorted({r["M"] for r in rows if r["bits"] == bits})
            for control in dict.fromkeys(r["control"] for r in rows):
                points = [
                    [r for r in rows if (r["bits"], r["M"], r["control"]) == (bits, m, control)] for m in ms
                ]
                stats = [_mean_range(p, "ppo") for p in points if p]
                xs = [m for m, p in zip(ms, points, strict=True) if p]
                ax.errorbar(xs, [s[0] for s in stats], yerr=np.array([s[1:] for s in stats]).T,
                            fmt=markers[control], color=colour, capsize=2,
                            label=f"PPO {control}, {label}")  # fmt: skip
            first = [next(r for r in rows if (r["bits"], r["M"]) == (bits, m)) for m in ms]
            ax.plot(
                ms, [r["random"] for r in first], "s--", color=colour, alpha=0.6, label=f"random, {label}"
            )
            if bits is not None:
                ax.plot(ms, [r["quantised"] for r in first], "v:", color=colour, alpha=0.6,
                        label=f"optimum rounded, {label}")  # fmt: skip
        ax.set_xscale("log", base=2)
        ax.set_xticks(sorted({r["M"] for r in rows}), [str(m) for m in sorted({r["M"] for r in rows})])
        ax.set_xlabel("elements M")
        ax.set_ylabel("% of the per-slot optimum")
        ax.set_ylim(0, 105)
        ax.set_title(title, fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6, ncol=3)

    return save_png(figure_image(draw, figsize=(7.2, 4.4)), path, colors=64)


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elements", type=int, nargs="+", default=[16, 64], help="surface sizes M (squares)")
    parser.add_argument("--bits", nargs="+", default=["none", "1"], help="phase bits b ('none': continuous)")
    parser.add_argument(
        "--control", nargs="+", default=["direct"], choices=CONTROLS, help="the env's control"
    )
    parser.add_argument("--steps", type=int, default=50_000, help="training slots per run")
    parser.add_argument("--episodes", type=int, default=20, help="held-out evaluation episodes")
    parser.add_argument("--group", type=int, default=1, help="elements per group (a divisor of sqrt(M))")
    parser.add_argument("--seed", type=int, nargs="+", default=[0], help="one run per seed")
    parser.add_argument("--policy", default="mlp", choices=POLICIES, help="the actor (element: shared)")
    parser.add_argument("--imitate", type=int, default=0, help="imitation episodes before PPO (0: none)")
    parser.add_argument("--learning-rate", type=float, default=PPO_KWARGS["learning_rate"])
    parser.add_argument("--target-kl", type=float, default=None, help="PPO's early stop (None: off)")
    parser.add_argument("--plot", type=Path, default=None, help="draw the rows here (PNG; never overwritten)")
    args = parser.parse_args(argv)
    if args.plot is not None and args.plot.exists():
        parser.error(f"--plot {args.plot} exists: give a new path (shipped figures are never overwritten)")
    if args.imitate < 0:
        parser.error(f"--imitate must be >= 0 episodes, got {args.imitate}")
    torch.set_num_threads(1)
    rows = []
    print(
        f"PPO ({args.policy} actor) on {ID} (group {args.group}): {args.steps} slots a run, "
        f"{args.episodes} held-out episodes, imitation on {args.imitate} episodes, % of the per-slot optimum"
    )
    heads = (
        ("M", 4),
        ("b", 5),
        ("control", 8),
        ("seed", 4),
        ("ppo", 7),
        ("imitated", 8),
        ("zero", 6),
    )
    heads += ("random", 7), ("quantised", 9), ("b-bit/cont", 10), ("train s", 8)
    print(" ".join(f"{name:>{width}}" for name, width in heads))
    for m in args.elements:
        for b in args.bits:
            bits = None if b == "none" else int(b)
            ref = references(env_kwargs(m, bits, args.group), args.episodes)
            for control in args.control:
                kwargs = env_kwargs(m, bits, args.group, control)
                for seed in args.seed:
                    ppo, imitated, seconds = train_and_score(
                        kwargs, args.steps, args.episodes, seed, args.imitate, args.policy,
                        learning_rate=args.learning_rate, target_kl=args.target_kl,
                    )  # fmt: skip
                    row = {"M": m, "bits": bits, "control": control, "seed": seed, "ppo": ppo,
                           "imitated": imitated, **ref, "seconds": seconds}  # fmt: skip
                    rows.append(row)
                    fitted = "-" if imitated is None else f"{imitated:.1f}"
                    cells = (f"{ppo:7.1f} {fitted:>8} {ref['zero']:6.1f} {ref['random']:7.1f} "
                             f"{ref['quantised']:9.1f} {ref['cont']:10.1f}")  # fmt: skip
                    print(f"{m:>4} {b:>5} {control:>8} {seed:>4} {cells} {seconds:8.0f}", flush=True)
    if args.plot is not None:
        seeds = ", ".join(str(s) for s in args.seed)
        title = (
            f"PPO ({args.policy} actor) setting the STAR surface ({args.steps} slots a run, seeds {seeds}, "
            f"group {args.group})"
        )
        print(f"figure: {plot_rows(rows, args.plot, title)}")
    return rows


if __name__ == "__main__":
    main()
