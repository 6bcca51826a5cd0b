"""Train :class:`agents.star_learner.StarLearner` on STARControl-v0: one command, a few minutes.

    python -m agents.star_training --out agents/models/star_learner_STARControl-v0 \\
        [--iterations 600] [--episodes 16] [--batch 32] [--imitate 4000] [--seed 0] [--overwrite]

The training episodes: for each of the 27 settings of the suite ``star-v1`` (M in {16, 64, 256},
phases continuous, 1-bit, 2-bit; TDMA, ES-NOMA, MS-NOMA; group 1, links blocked) ``--episodes``
episodes of the env (``optimum=False``: no per-slot optimum is computed, the learner sees rewards
only) seeded ``TRAIN_SEED + 1000 i + k`` for setting i, none of them a suite episode's seed
(checked). Their 16 slots each are the pool; an episode's slots do not depend on the actions (the
line is drawn at reset), so a slot is a one-step episode (gamma = 0).

The method, in three stages (the group network's and the split network's last layers start at
zero: the first policy is ``ChannelPhases``):

1. imitation of the best split: per slot, the split offset that maximises the env's reward with
   the current amplitudes (:meth:`Pool.best_split`, a search over the env's own action map and
   reward: ``ControlMap.settings`` and ``star_slot.evaluate_rows``, what ``env.step`` pays), then
   the split network fitted to it (``--imitate`` full-batch Adam steps); this is the per-slot
   optimum of the split alone (the phases stay the observed ones);
2. a Gaussian policy gradient of the group network, the split fixed: each of ``--iterations``
   steps takes ``--batch`` slots of every setting, draws noise e on every group's outputs and
   plays the mean +- sigma e (antithetic samples, sigma ``SIGMA``: the phases' and the
   amplitude's); the advantage is (r+ - r-) / 2 over the mean's reward r0 (a relative change, so
   that the settings, whose rates differ by orders of magnitude, weigh alike), and the surrogate
   (adv e / sigma) . mean is ascended with Adam (the learning rate decaying linearly to 0);
3. stage 1 again, for the learned group outputs.

Needs torch (the ``rl`` extra). Writes ``weights.npz`` and ``config.json`` (the command's
arguments, the time, each stage's % of the zero residual on the training slots) to ``--out``; an
existing model is replaced only with ``--overwrite``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from itertools import product
from pathlib import Path
from typing import TextIO

import numpy as np
import torch
from torch import nn

from agents.star_learner import ELEMENT_IN, ELEMENT_OUT, GLOBAL_FEATURES, compose, features
from ios_uav_env.benchmark import load_suite
from ios_uav_env.benchmark.star_policies import ChannelPhases
from ios_uav_env.benchmark.star_suite import StarTask
from ios_uav_env.envs.star_control import N_SLOTS, STARControlEnv
from ios_uav_env.model.star_rows import StarRows
from ios_uav_env.model.star_slot import evaluate_rows

#: The settings of star-v1: (M_y = M_z, bits, access, protocol).
SETTINGS = tuple(product((4, 8, 16), (None, 1, 2), (("tdma", "es"), ("noma", "es"), ("noma", "ms"))))
#: The first training seed (setting i's episodes: TRAIN_SEED + 1000 i + k).
TRAIN_SEED = 7_000_000
#: The exploration noise of the residual's outputs (action units).
#: The exploration noise of the group outputs (two phases, amplitude; action units).
SIGMA = (0.05, 0.05, 0.1)
WIDTH, LEARNING_RATE = 32, 1e-3
#: The imitation's learning rate (Adam, full batch).
FIT_LEARNING_RATE = 3e-3


@dataclass
class Pool:
    """One setting's training slots: the task, its env (for the action map), the slots' channels,
    ``ChannelPhases``' actions and the features."""

    task: StarTask
    env: STARControlEnv
    rows: StarRows
    base: np.ndarray  # (S, A)
    group: np.ndarray  # (S, G, 4)
    glob: np.ndarray  # (S, 17)

    def value(self, index: np.ndarray, actions: np.ndarray) -> np.ndarray:
        """min(R_r, R_t) of ``actions`` at the slots ``index``: the env's reward."""
        rows = self.rows.take(index)
        rates = evaluate_rows(rows, self.env.surface, self.env.access, self.env.map.settings(actions, rows))
        return np.minimum(*rates)

    def tensors(self, index: np.ndarray) -> tuple[torch.Tensor, torch.Tensor]:
        """The group and global features of the slots ``index``, as tensors."""
        return torch.from_numpy(self.group[index]), torch.from_numpy(self.glob[index])

    def player(self, index: np.ndarray) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
        """The env's reward at the slots ``index`` of the residuals (group outputs, split output)."""
        return lambda group, split: self.value(index, compose(self.base[index], group, split, self.task))

    def best_split(self, group_out: np.ndarray) -> np.ndarray:
        """Per slot, the split residual (the log-odds offset of the TDMA share or the NOMA power
        fraction, ``star_learner.compose``) that maximises the env's reward with the group
        residuals ``group_out`` (S, G, 3): a grid of step 0.5 on [-12, 12], then steps of 0.02 and
        0.0008 around the best (the imitation's label)."""
        index = np.arange(len(self.base))
        best = np.zeros(len(index))
        for grid in (np.linspace(-12, 12, 49), np.linspace(-0.5, 0.5, 51), np.linspace(-0.02, 0.02, 51)):
            offsets = best[None, :] + grid[:, None]
            values = np.stack([self.player(index)(group_out, o) for o in offsets])
            best = offsets[np.argmax(values, axis=0), index]
        return best


def _stack(parts: Sequence[StarRows]) -> StarRows:
    return StarRows(
        *(np.concatenate([getattr(p, f.name) for p in parts]) for f in dataclasses.fields(StarRows))
    )


def make_pool(i: int, episodes: int, forbidden: set[int]) -> Pool:
    """Setting ``i``'s pool of ``episodes`` episodes (``ValueError`` if a seed is in ``forbidden``)."""
    side, bits, (access, protocol) = SETTINGS[i]
    star = dict(
        elements=[side, side], bits=bits, group=1, protocol=protocol, access=access, direct_link=False
    )
    env = STARControlEnv(elements=(side, side), bits=bits, protocol=protocol, access=access, optimum=False)
    task = StarTask.of(star, env)
    heuristic = ChannelPhases().bind(task)
    obs_rows, base, rows = [], [], []
    for k in range(episodes):
        seed = TRAIN_SEED + 1000 * i + k
        if seed in forbidden:
            raise ValueError(f"training seed {seed} is a suite episode's seed: choose another TRAIN_SEED")
        obs, _ = env.reset(seed=seed)
        rows.append(env.rows)
        for _ in range(N_SLOTS):
            action = heuristic(obs)
            obs_rows.append(obs)
            base.append(action)
            obs = env.step(action)[0]
    group, glob = features(np.asarray(obs_rows), task)
    return Pool(task, env, _stack(rows), np.asarray(base), group, glob)


def _networks(width: int) -> nn.ModuleDict:
    def net(n_in: int, n_out: int) -> nn.Sequential:
        layers = nn.Sequential(nn.Linear(n_in, width), nn.Tanh(), nn.Linear(width, width), nn.Tanh(),
                               nn.Linear(width, n_out)).double()  # fmt: skip
        nn.init.zeros_(layers[-1].weight)
        nn.init.zeros_(layers[-1].bias)
        return layers

    return nn.ModuleDict({"element": net(ELEMENT_IN, ELEMENT_OUT), "split": net(GLOBAL_FEATURES, 1)})


def _forward(
    nets: nn.ModuleDict, group: torch.Tensor, glob: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """The torch form of ``star_learner.residuals``."""
    inputs = torch.cat([group, glob[:, None, :].expand(-1, group.shape[1], -1)], dim=-1)
    return nets["element"](inputs), nets["split"](glob)[:, 0]


def export(nets: nn.ModuleDict) -> dict[str, np.ndarray]:
    """The networks as ``weights.npz``'s arrays (``star_learner.load_weights``)."""
    out = {}
    for name, seq in nets.items():
        linears = [m for m in seq if hasattr(m, "weight")]
        for j, layer in enumerate(linears):
            out[f"{name}_w{j}"] = layer.weight.detach().numpy().T.copy()
            out[f"{name}_b{j}"] = layer.bias.detach().numpy().copy()
    return out


def group_outputs(nets: nn.ModuleDict, pool: Pool) -> np.ndarray:
    """The group network's outputs (S, G, 3) on every slot of ``pool``."""
    with torch.no_grad():
        return _forward(nets, *pool.tensors(np.arange(len(pool.base))))[0].numpy()


def imitate(nets: nn.ModuleDict, pools: Sequence[Pool], steps: int) -> float:
    """Fit the split network to every pool's :meth:`Pool.best_split` for the group network's
    outputs (squared error, full batch, Adam, ``steps`` steps, the learning rate decaying
    linearly to 0); returns the last loss."""
    x = torch.from_numpy(np.concatenate([pool.glob for pool in pools]))
    y = torch.from_numpy(np.concatenate([pool.best_split(group_outputs(nets, pool)) for pool in pools]))
    opt = torch.optim.Adam(nets["split"].parameters(), lr=FIT_LEARNING_RATE)
    decay = torch.optim.lr_scheduler.LambdaLR(opt, lambda step: 1 - step / steps)  # linear, to 0
    loss = torch.zeros(())
    for _ in range(steps):
        opt.zero_grad()
        loss = ((nets["split"](x)[:, 0] - y) ** 2).mean()
        loss.backward()
        opt.step()
        decay.step()
    return float(loss.detach())


def policy_gradient(
    nets: nn.ModuleDict, pools: Sequence[Pool], iterations: int, batch: int, rng: np.random.Generator
) -> None:
    """``iterations`` steps of the group network (module docstring) on ``pools``, the split fixed."""
    opt = torch.optim.Adam(nets["element"].parameters(), lr=LEARNING_RATE)
    decay = torch.optim.lr_scheduler.LambdaLR(opt, lambda it: 1 - it / iterations)  # linear, to 0
    for _ in range(iterations):
        opt.zero_grad()
        for pool in pools:
            index = rng.choice(len(pool.base), size=batch, replace=False)
            mu_g, mu_s = _forward(nets, *pool.tensors(index))
            noise = rng.standard_normal(mu_g.shape)
            m_g, m_s, play = mu_g.detach().numpy(), mu_s.detach().numpy(), pool.player(index)
            step = np.asarray(SIGMA) * noise
            gain = (play(m_g + step, m_s) - play(m_g - step, m_s)) / (2 * np.maximum(play(m_g, m_s), 1e-12))
            score = (torch.from_numpy(noise / np.asarray(SIGMA)) * mu_g).sum(dim=(1, 2))
            (-(torch.from_numpy(gain) * score).mean() / len(pools)).backward()
        torch.nn.utils.clip_grad_norm_(nets["element"].parameters(), 1.0)
        opt.step()
        decay.step()


def pct_of_zero_residual(nets: nn.ModuleDict, pools: Sequence[Pool]) -> float:
    """The mean over ``pools`` of the deterministic policy's reward sum as % of ``ChannelPhases``'."""
    pct = []
    for pool in pools:
        index = np.arange(len(pool.base))
        with torch.no_grad():
            g, s = (t.numpy() for t in _forward(nets, *pool.tensors(index)))
        pct.append(100 * pool.player(index)(g, s).sum() / pool.value(index, pool.base).sum())
    return float(np.mean(pct))


def train(
    pools: Sequence[Pool], iterations: int, batch: int, seed: int, fit_steps: int, log: TextIO | None = None
) -> tuple[nn.ModuleDict, dict[str, float]]:
    """The networks (module docstring): the split imitated, the group network's policy gradient
    (``iterations`` > 0), the split imitated again for the learned group outputs; and
    the mean % of the zero residual on the pools after each stage."""
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    nets = _networks(WIDTH)
    scores = {}

    def stage(name: str) -> None:
        scores[name] = pct_of_zero_residual(nets, pools)
        if log is not None:
            print(f"{name}: {scores[name]:.3f} % of the zero residual (ChannelPhases)", file=log, flush=True)

    imitate(nets, pools, fit_steps)
    stage("split imitated")
    if iterations > 0:
        policy_gradient(nets, pools, iterations, batch, rng)
        stage("group outputs learned")
        imitate(nets, pools, fit_steps)
        stage("split imitated again")
    return nets, scores


def main(argv: Sequence[str] | None = None) -> Path:
    parser = argparse.ArgumentParser(
        prog="python -m agents.star_training", description=__doc__.splitlines()[0]
    )
    parser.add_argument("--out", type=Path, required=True, help="the model folder to write")
    parser.add_argument("--iterations", type=int, default=600, help="gradient steps (each: every setting)")
    parser.add_argument("--episodes", type=int, default=16, help="training episodes per setting")
    parser.add_argument("--batch", type=int, default=32, help="slots per setting and iteration")
    parser.add_argument("--imitate", type=int, default=4000, help="steps of each fit of the split")
    parser.add_argument("--seed", type=int, default=0, help="the noise's and the initial weights' seed")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing model in --out")
    args = parser.parse_args(argv)
    for name, low in (("iterations", 0), ("episodes", 1), ("batch", 1), ("imitate", 1), ("seed", 0)):
        if getattr(args, name) < low:
            parser.error(f"--{name} must be >= {low}, got {getattr(args, name)}")
    if args.batch > args.episodes * N_SLOTS:
        parser.error(
            f"--batch must be <= --episodes x {N_SLOTS} = {args.episodes * N_SLOTS} slots, got {args.batch}"
        )
    if (args.out / "weights.npz").exists() and not args.overwrite:
        parser.error(f"--out {args.out} holds a model: pass --overwrite to replace it")
    torch.set_num_threads(1)
    start = time.perf_counter()
    forbidden = {s.seed for s in load_suite("star-v1").scenarios}
    pools = [make_pool(i, args.episodes, forbidden) for i in range(len(SETTINGS))]
    nets, scores = train(pools, args.iterations, args.batch, args.seed, args.imitate, log=sys.stdout)
    seconds = time.perf_counter() - start
    args.out.mkdir(parents=True, exist_ok=True)
    np.savez(args.out / "weights.npz", **export(nets))
    command = ["python -m agents.star_training", "--out", str(args.out), "--iterations", str(args.iterations),
               "--episodes", str(args.episodes), "--batch", str(args.batch), "--imitate", str(args.imitate),
               "--seed", str(args.seed)]  # fmt: skip
    config = {
        "trainer": "agents.star_training", "command": " ".join(command), "settings": len(SETTINGS),
        "train_seed": TRAIN_SEED, "sigma": list(SIGMA), "width": WIDTH,
        "learning_rate": LEARNING_RATE, "seconds": round(seconds, 1),
        "pct_of_zero_residual": {name: round(value, 3) for name, value in scores.items()},
    }  # fmt: skip
    (args.out / "config.json").write_text(json.dumps(config, indent=2) + "\n", encoding="utf-8")
    print(f"model: {args.out} ({seconds:.0f} s)")
    return args.out


if __name__ == "__main__":
    main()
